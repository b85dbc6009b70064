"""Vehicle derivation: matrix properties, static loads, hand-calculated frequencies, bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg as sla
import sympy as sp

from svbi.codegen.topology import TopologyError, builtin_topologies, load_topology, parse_topology
from svbi.codegen.vehicle import GRAVITY, a_split, derive_vehicle
from svbi.runtime.model.modes import vehicle_modes

WAGON = """
name = "two-axle-wagon"
description = "A rigid wagon body on two wheelsets, each on a spring and a dashpot."
[parameters.body_mass]
value = 20000.0
[parameters.body_pitch_inertia]
value = 3.0e5
[parameters.axle_mass]
value = 1200.0
[parameters.k]
value = 1.2e6
[parameters.c]
value = 2.0e4
[parameters.half_wheelbase]
value = 4.0
[parameters.front_share]
value = 1.5
[parameters.car_length]
value = 14.0
[[bodies]]
name = "body"
dofs = ["z", "theta"]
mass = "body_mass"
inertia = "body_pitch_inertia"
position = "half_wheelbase"
[[bodies]]
name = "axle_front"
dofs = ["z"]
mass = "axle_mass"
position = "0"
[[bodies]]
name = "axle_rear"
dofs = ["z"]
mass = "axle_mass"
position = "2*half_wheelbase"
[[suspensions]]
name = "front"
body_a = "body"
offset_a = "-half_wheelbase"
body_b = "axle_front"
stiffness = "k"
damping = "c"
[[suspensions]]
name = "rear"
body_a = "body"
offset_a = "half_wheelbase"
body_b = "axle_rear"
stiffness = "k"
damping = "c"
[[wheels]]
name = "front"
body = "axle_front"
position = "0"
[[wheels]]
name = "rear"
body = "axle_rear"
position = "2*half_wheelbase"
"""


def _static_wheel_loads(nv) -> np.ndarray:  # noqa: ANN001
    """Wheel loads on rigid level track: saddle solve [K W; W^T 0], rigid unloaded DOFs removed."""
    loaded = np.flatnonzero(np.any(nv.K != 0, axis=1) | np.any(nv.W_N != 0, axis=1))
    k = nv.K[np.ix_(loaded, loaded)]
    w = nv.W_N[loaded]
    nw = w.shape[1]
    saddle = np.block([[k, w], [w.T, np.zeros((nw, nw))]])
    rhs = np.concatenate([nv.F_gravity[loaded], np.zeros(nw)])
    sol = np.linalg.solve(saddle, rhs)
    # K u + W lam = F: lam is the force the track pulls with; the wheel load is -lam.
    return -sol[len(loaded) :]


@pytest.mark.parametrize("name", ["sprung-mass", "pioneer-2d"])
def test_mass_spd_stiffness_psd_with_expected_rigid_modes(name: str) -> None:
    model = derive_vehicle(name)
    nv = model.numeric()
    assert sp.simplify(model.mass_matrix - model.mass_matrix.T) == sp.zeros(*model.mass_matrix.shape)
    assert sp.simplify(model.stiffness_matrix - model.stiffness_matrix.T) == sp.zeros(
        *model.mass_matrix.shape
    )
    assert np.all(np.linalg.eigvalsh(nv.M) > 0)
    eig_k = np.linalg.eigvalsh(nv.K)
    tol = 1e-9 * eig_k.max()
    assert np.all(eig_k > -tol)
    # Free vehicle: every translation/pitch DOF not tied by a suspension is a mechanism, and each
    # rotation with no spring attached (wheelset spin) is free: rigid modes = DOFs - suspensions.
    topo = model.topology
    expected_rigid = len(model.dofs) - len(topo.suspensions)
    assert int(np.sum(eig_k <= tol)) == expected_rigid


@pytest.mark.parametrize("name", ["sprung-mass", "pioneer-2d"])
def test_static_wheel_loads_sum_to_weight_and_share_evenly(name: str) -> None:
    nv = derive_vehicle(name).numeric()
    loads = _static_wheel_loads(nv)
    weight = GRAVITY * sum(np.diag(nv.M)[i] for i, q in enumerate(nv.dof_names) if q.startswith("z_"))
    assert loads.sum() == pytest.approx(weight, rel=1e-12)
    # Both built-ins are symmetric fore and aft: every wheel takes the same share.
    assert np.allclose(loads, weight / len(loads), rtol=1e-12)


def test_active_mass_and_aux_points_conserve_mass() -> None:
    model = derive_vehicle("pioneer-2d")
    total = model.active_mass_matrix().trace() + model.aux_masses().trace()
    assert sp.simplify(total - model.mass_matrix.trace()) == 0
    wheels = model.contact_normal
    for i in range(wheels.shape[1]):
        seen = (wheels[:, i].T * model.active_mass_matrix() * wheels[:, i])[0, 0]
        assert sp.simplify(seen - (1 - a_split) * model.wheel_masses[i]) == 0


def test_user_wagon_frequencies_match_hand_calculation(tmp_path: Path) -> None:
    path = tmp_path / "wagon.toml"
    path.write_text(WAGON)
    model = derive_vehicle(load_topology(path))
    nv = model.numeric()
    modes = vehicle_modes(nv)
    mass, inertia, k, half = 20000.0, 3.0e5, 1.2e6, 4.0
    bounce = np.sqrt(2 * k / mass) / (2 * np.pi)
    pitch = np.sqrt(2 * k * half**2 / inertia) / (2 * np.pi)
    assert modes.rigid_modes == 0
    assert np.allclose(modes.frequencies_hz, sorted([bounce, pitch]), rtol=1e-12)
    loads = _static_wheel_loads(nv)
    axle_weight = 1200.0 * GRAVITY
    assert np.allclose(loads, mass * GRAVITY / 2 + axle_weight, rtol=1e-12)


def test_user_wagon_asymmetric_body_takes_lever_rule_shares(tmp_path: Path) -> None:
    # Body reference (centre of mass) 1.5 m behind the front axle on an 8 m wheelbase.
    path = tmp_path / "wagon.toml"
    path.write_text(
        WAGON.replace('position = "half_wheelbase"', 'position = "front_share"', 1)
        .replace('offset_a = "-half_wheelbase"', 'offset_a = "-front_share"')
        .replace('offset_a = "half_wheelbase"', 'offset_a = "2*half_wheelbase - front_share"')
    )
    nv = derive_vehicle(load_topology(path)).numeric()
    loads = _static_wheel_loads(nv)
    body = 20000.0 * GRAVITY
    assert loads[0] == pytest.approx(body * (8.0 - 1.5) / 8.0 + 1200.0 * GRAVITY, rel=1e-12)
    assert loads[1] == pytest.approx(body * 1.5 / 8.0 + 1200.0 * GRAVITY, rel=1e-12)


def test_pioneer_rigid_track_modes_are_the_suspension_modes() -> None:
    # On rigid track the bogie bounce frequency is sqrt((2 kp + ks) / mb) when the car body is held;
    # check the full eigen-solution against a direct reduced solve instead of typed numbers.
    nv = derive_vehicle("pioneer-2d").numeric()
    free = [i for i, n in enumerate(nv.dof_names) if not n.startswith(("z_wheelset", "theta_wheelset"))]
    eig = sla.eigh(nv.K[np.ix_(free, free)], nv.M[np.ix_(free, free)], eigvals_only=True)
    assert np.allclose(vehicle_modes(nv).frequencies_hz, np.sqrt(eig) / (2 * np.pi), rtol=1e-10)
    assert vehicle_modes(nv).rigid_modes == 4


def test_builtins_present_and_documented() -> None:
    assert {"sprung-mass", "pioneer-2d", "moving-load"} <= set(builtin_topologies())
    pioneer = load_topology("pioneer-2d")
    for name in (
        "carbody_mass",
        "carbody_pitch_inertia",
        "bogie_mass",
        "bogie_pitch_inertia",
        "wheelset_mass",
        "wheelset_spin_inertia",
        "wheel_radius",
        "primary_stiffness",
        "primary_damping",
        "secondary_stiffness",
        "secondary_damping",
        "bogie_half_spacing",
        "axle_half_spacing",
        "car_length",
    ):
        assert name in pioneer.parameters
    assert "Antolin" in pioneer.source
    assumed = {n for n, p in pioneer.parameters.items() if p.assumed}
    assert {"wheelset_spin_inertia", "car_length", "wheel_radius"} <= assumed
    assert set(load_topology("sprung-mass").parameters) >= {
        "sprung_mass",
        "wheel_mass",
        "stiffness",
        "damping",
    }
    ml = load_topology("moving-load")
    assert ml.kind == "moving-load" and {"axle_loads", "axle_offsets", "car_length"} <= set(ml.parameters)


def test_pioneer_geometry_follows_design_convention() -> None:
    nv = derive_vehicle("pioneer-2d").numeric()
    a, b = 1.25, 9.0
    assert np.allclose(nv.wheel_offsets, [0, 2 * a, 2 * b, 2 * b + 2 * a])
    # W_T: a spin of the wheelset moves its contact point forward by the rolling radius.
    assert np.allclose(nv.W_T[nv.dof_names.index("theta_wheelset_1"), 0], 0.4575)


@pytest.mark.parametrize(
    ("edit", "key", "problem"),
    [
        (lambda t: t + "\n[extra]\nx = 1\n", "extra", "unknown key"),
        (
            lambda t: t.replace('mass = "axle_mass"\nposition = "0"', 'position = "0"'),
            "bodies[1].mass",
            "no mass",
        ),
        (lambda t: t.replace('body_b = "axle_front"', 'body_b = "body"'), "suspensions[0].body_b", "itself"),
        (
            lambda t: t.replace('stiffness = "k"', 'stiffness = "kk"', 1),
            "suspensions[0].stiffness",
            "unknown parameter",
        ),
        (lambda t: t.replace("value = 1.2e6", "value = -1.2e6"), "parameters.k.value", "negative"),
        (lambda t: t.replace('mass = "body_mass"', 'mass = "body_mass *"'), "bodies[0].mass", "cannot parse"),
        (lambda t: t.replace('dofs = ["z"]', 'dofs = ["y"]', 1), "bodies[1].dofs", "must be"),
        (
            lambda t: t.replace("[parameters.car_length]\nvalue = 14.0\n", ""),
            "parameters.car_length",
            "missing",
        ),
        (lambda t: t.replace("value = 20000.0", "value = 0.0"), "bodies[0].mass", "positive"),
        (lambda t: t.replace('name = "two-axle-wagon"', 'name = "x"\n[oops'), "toml", "malformed"),
    ],
)
def test_bad_topologies_name_file_key_and_problem(tmp_path: Path, edit, key: str, problem: str) -> None:  # noqa: ANN001
    path = tmp_path / "bad.toml"
    path.write_text(edit(WAGON))
    with pytest.raises(TopologyError) as info:
        derive_vehicle(load_topology(path))
    message = str(info.value)
    assert str(path) in message and key in message and problem in message


def test_bad_parameter_overrides_are_named() -> None:
    topo = load_topology("pioneer-2d")
    with pytest.raises(TopologyError, match=r"train\.parameters\.nope.*unknown parameter"):
        topo.values({"nope": 1.0})
    with pytest.raises(TopologyError, match=r"train\.parameters\.bogie_mass.*negative"):
        topo.values({"bogie_mass": -1.0})
    with pytest.raises(TopologyError, match=r"bodies\[1\]\.mass.*positive"):
        topo.values({"bogie_mass": 0.0})


def test_unknown_vehicle_name_lists_builtins() -> None:
    with pytest.raises(TopologyError, match="pioneer-2d"):
        load_topology("no-such-vehicle")


def test_parse_topology_rejects_moving_load_with_bodies() -> None:
    text = load_topology("moving-load").text + '\n[[bodies]]\nname = "x"\ndofs = ["z"]\nmass = "car_length"\n'
    with pytest.raises(TopologyError, match="moving-load vehicle has no bodies"):
        parse_topology(text, "ml.toml")
