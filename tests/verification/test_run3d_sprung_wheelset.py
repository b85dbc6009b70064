"""A 3D run (``svbi.simulate`` of a 3D scenario) against svbi's 2D run, in the vertical plane.

One symmetric car (``SPRUNG_WHEELSET_3D``: the sprung-mass benchmark's 5750 kg on 1595 kN/m over a
500 kg wheelset, on cones of conicity 0.1) crossing a simply supported 25 m span at 100 km/h, on the
track's axis: nothing moves sideways, and the vertical plane is the 2D model (docs/three-d.md). The
2D run of ``sprung-mass`` with the same span, dt, elements, kappa and zeta is the independent truth:

* the midspan deflection, to round-off of its peak, for both 3D methods;
* the vertical wheel forces ``Q`` of the two wheels (results3d's track-axes force, from the normal
  forces and the contact angle the run records) sum to the 2D contact force;
* the static wheel loads are half the 2D static axle load, ``(m_s + m_w) g / 2``;
* on cones of slope ``λ`` the normal leans by ``atan λ``: ``Y/Q = tan(atan λ) = λ`` on both wheels,
  and the two outward pushes cancel in ``ΣY``;
* nothing lateral: sway, twist, the wheelset's lateral displacement, the car body's lateral
  acceleration and roll.

Also the deck's lateral displacement under a wheelset (the frame element's shape functions of the
run module) against the generated flange-gap kernel, ``y_w - y_r = c_f - g_F,left``, and the static
wheel loads of ``manchester-3d`` against its weight.
"""

from __future__ import annotations

import numpy as np
import pytest

import svbi
from svbi.runtime.model.bridge import Girder, Section
from svbi.runtime.model.bridge3d import bridge3d
from svbi.runtime.model.system3d import ContactKernel3D, Track3D, Wheelset, vehicle3d
from svbi.runtime.run.simulate3d import deck_rows, rigid_track_statics
from svbi.runtime.scenario.schema import validate_scenario
from tests.cases import SPRUNG_WHEELSET_3D

L, E, IY, MU = 25.0, 2.87e9, 2.9, 2303.0
V = 100.0 / 3.6
DT, STEPS, ELEMENTS = 2e-3, 200, 8
LAM = 0.1
G = 9.81


def bridge() -> dict:
    return dict(
        spans=1,
        span_length=L,
        mass_per_length=MU,
        youngs_modulus=E,
        area=1.0,
        second_moment=IY,
        damping_ratio=0.0,
        elements_per_span=ELEMENTS,
    )


def solver(method: str) -> dict:
    return dict(method=method, backend="numpy", time_step=DT, duration=STEPS * DT, output_every=1)


@pytest.fixture(scope="module")
def topology(tmp_path_factory: pytest.TempPathFactory) -> str:
    path = tmp_path_factory.mktemp("sw3d") / "sprung-wheelset-3d.toml"
    path.write_text(SPRUNG_WHEELSET_3D, encoding="utf-8")
    return str(path)


@pytest.fixture(scope="module")
def run2d():
    scenario = validate_scenario(
        {
            "bridge": bridge(),
            "train": dict(
                vehicle="sprung-mass",
                speed=V,
                parameters=dict(sprung_mass=5750.0, stiffness=1.595e6, wheel_mass=500.0, damping=0.0),
            ),
            "contact": dict(creep=False),
            "solver": solver("coupled-dynamic"),
        }
    )
    return svbi.simulate(scenario)


@pytest.fixture(scope="module", params=["coupled-dynamic", "localized-dynamic"])
def run3d(request: pytest.FixtureRequest, topology: str):
    scenario = validate_scenario(
        {
            "bridge": bridge() | dict(lateral_second_moment=10.0, torsion_constant=5.0),
            "train": dict(vehicle=topology, speed=V),
            "contact": dict(creep=False, normal="bilateral", conicity=LAM),
            "solver": solver(request.param),
        }
    )
    return svbi.simulate(scenario)


def test_midspan_deflection_is_the_2d_run(run3d, run2d) -> None:
    w2 = run2d.midspan_uz.values[:, 0]
    w3 = run3d.midspan_uz.values[:, 0]
    peak = np.abs(w2).max()
    assert w3.shape == w2.shape == (STEPS + 1,)
    assert peak > 1e-3  # the wheel has loaded the span
    assert np.abs(w3 - w2).max() < 1e-11 * peak  # measured 1.5e-13 (coupled) of the peak
    assert run3d.attrs["steps"] == STEPS and run3d.attrs["complete"] == 1


def test_vertical_wheel_forces_are_the_2d_contact_force(run3d, run2d) -> None:
    p2 = run2d.contact_force.values.reshape(STEPS + 1, -1)[:, 0]
    q = run3d.contact_force.transpose("time", "car", "wheel", "side").values[:, 0, 0, :]
    assert np.abs(q[:, 0] - q[:, 1]).max() < 1e-11 * p2.max()  # a symmetric car: equal wheels
    assert np.abs(q.sum(axis=1) - p2).max() < 1e-11 * p2.max()  # measured 2e-13
    q0 = run3d.static_wheel_load.values[0, 0]
    assert q0 == pytest.approx([(5750.0 + 500.0) * G / 2] * 2, rel=1e-12)


def test_the_cones_lean_the_normals_and_nothing_moves_sideways(run3d) -> None:
    yq = run3d.derailment_quotient.values
    assert np.nanmax(np.abs(yq - LAM)) < 1e-9  # Y/Q = tan(atan λ), the filtered forces
    angle = run3d.contact_angle.values
    assert np.abs(angle - np.arctan(LAM)).max() < 1e-14
    peak_q = run3d.contact_force.values.max()
    assert np.abs(run3d.axle_lateral_force.values).max() < 1e-11 * peak_q
    for name in (
        "midspan_uy",
        "midspan_twist",
        "wheel_rail_lateral_displacement",
        "carbody_ay",
        "carbody_roll",
    ):
        assert np.abs(run3d[name].values).max() < 1e-14, name
    for name in ("creep_force", "lateral_creep_force", "flange_force"):
        assert not run3d[name].values.any(), name  # the 3D step has none yet
    assert run3d.attrs["flange_contacts"] == 0


@pytest.mark.parametrize(
    ("spans", "lengths"),
    [((L,), {L / 8}), ((10.0, 16.0), {10.0 / 8, 16.0 / 8})],
    ids=["span", "unequal-spans"],
)
def test_the_deck_under_a_wheelset_is_the_flange_kernels(spans: tuple, lengths: set) -> None:
    """``y_w - y_r`` of the run module (shape functions at the element's own length,
    ``y_r = v - h_t phi_d``) against the generated flange gap ``g_F,left = c_f - (y_w - y_r)`` on
    displaced, twisted elements, the kernel at each element's length: every element of one span,
    and of a girder continuous over a 10 m and a 16 m span (elements of two lengths); two rail
    heights separate the sway from the twist."""
    deck = Section(mass_per_length=MU, youngs_modulus=E, area=1.0, second_moment=IY, damping_ratio=0.0)
    b = bridge3d([Girder(spans, deck)], ELEMENTS, [dict(lateral_second_moment=10.0, torsion_constant=5.0)])
    assert set(b.deck_element_length.tolist()) == lengths
    rng = np.random.default_rng(3)
    ws = Wheelset("ws", np.arange(4), 0.0, 0.46, 0.75)
    c_f = 0.007
    for h_t in (0.0, 1.3):
        kernel = ContactKernel3D(ws, Track3D(conicity=LAM, rail_height=h_t), 1.0, V, 0, 0, c_f)
        for e in range(len(b.deck_element_length)):
            kernel.element_length = float(b.deck_element_length[e])
            xi = float(rng.uniform())
            u = np.zeros(b.ndof)
            u[b.free] = 1e-3 * rng.standard_normal(b.free.size)
            q = 1e-3 * rng.standard_normal(4)
            rows = deck_rows(b, e, xi)
            dofs, rv = rows["v"]
            _, rphi = rows["phi"]
            y_r = rv @ u[dofs] - h_t * (rphi @ u[dofs])
            g_left = kernel.flange_gap(np.concatenate([q, u[dofs]]), xi)[0]
            assert q[0] - y_r == pytest.approx(c_f - g_left, abs=1e-16)


def test_static_wheel_loads_carry_the_car() -> None:
    car = vehicle3d("manchester-3d")
    _, q0 = rigid_track_statics(car)
    weight = (32000.0 + 2 * 2615.0 + 4 * 1813.0) * G
    assert q0.sum() == pytest.approx(weight, rel=1e-12)
    assert np.allclose(q0, q0[0], rtol=1e-12)  # a symmetric car, its pitch balanced: every wheel alike


def test_a_measured_vertical_profile_is_the_2d_runs(tmp_path, topology: str, run2d) -> None:
    """The rail's vertical profile under the wheelset (a measured profile file: a 1 mm cosine dip
    4 m to 14 m along the span, level at the start) enters the 3D contact as the 2D run's: the midspan
    deflection and the wheel forces are the 2D run's with the same file to round-off, and the dip
    shows in them (the run differs from one on level track)."""
    xs = np.linspace(-5.0, 40.0, 451)
    dip = np.where((xs > 4.0) & (xs < 14.0), -0.5e-3 * (1 - np.cos(2 * np.pi * (xs - 4.0) / 10.0)), 0.0)
    profile = tmp_path / "dip.txt"
    profile.write_text("".join(f"{x:.6f} {r:.12e}\n" for x, r in zip(xs, dip, strict=True)), encoding="utf-8")
    track = dict(irregularity=str(profile))
    two = validate_scenario(
        {
            "bridge": bridge(),
            "train": dict(
                vehicle="sprung-mass",
                speed=V,
                parameters=dict(sprung_mass=5750.0, stiffness=1.595e6, wheel_mass=500.0, damping=0.0),
            ),
            "track": track,
            "contact": dict(creep=False),
            "solver": solver("coupled-dynamic"),
        }
    )
    three = validate_scenario(
        {
            "bridge": bridge() | dict(lateral_second_moment=10.0, torsion_constant=5.0),
            "train": dict(vehicle=topology, speed=V),
            "track": track,
            "contact": dict(creep=False, normal="bilateral", conicity=LAM),
            "solver": solver("localized-dynamic"),
        }
    )
    r2, r3 = svbi.simulate(two), svbi.simulate(three)
    w2, w3 = r2.midspan_uz.values[:, 0], r3.midspan_uz.values[:, 0]
    p2 = r2.contact_force.values.reshape(STEPS + 1, -1)[:, 0]
    q3 = r3.contact_force.transpose("time", "car", "wheel", "side").values[:, 0, 0, :].sum(axis=1)
    peak = np.abs(w2).max()
    assert np.abs(w3 - w2).max() < 1e-11 * peak
    assert np.abs(q3 - p2).max() < 1e-11 * p2.max()
    level = run2d.contact_force.values.reshape(STEPS + 1, -1)[:, 0]  # the same run on level track
    assert np.abs(q3 - level).max() > 0.01 * level.max()  # the dip shows (measured 3 %)


def test_a_run_from_the_approach_under_an_earthquake_is_the_2d_run(topology: str) -> None:
    """The train starts 10 m before the span (approach track), the ground shakes vertically and
    longitudinally (the synthetic record, its wave passing at 300 m/s): the 3D run's vertical plane
    is the 2D run with the same scenario, through ``svbi.simulate``; a lateral component added, the
    ground's sway reaches the span (its motion relative to the ground is what is left of it)."""
    quake = dict(
        vertical="synthetic", longitudinal="synthetic", scale=0.5, apparent_velocity=300.0, arrival=0.1
    )
    common = dict(contact=dict(creep=False), earthquake=quake)
    steps = 600
    sol = dict(method="localized-dynamic", backend="numpy", time_step=DT, duration=steps * DT, output_every=1)
    two = svbi.simulate(
        validate_scenario(
            {
                "bridge": bridge() | dict(spans=2),
                "train": dict(
                    vehicle="sprung-mass",
                    speed=V,
                    start_position=-10.0,
                    parameters=dict(sprung_mass=5750.0, stiffness=1.595e6, wheel_mass=500.0, damping=0.0),
                ),
                "solver": sol,
            }
            | common
        )
    )
    three_d = {
        "bridge": bridge() | dict(spans=2, lateral_second_moment=10.0, torsion_constant=5.0),
        "train": dict(vehicle=topology, speed=V, start_position=-10.0),
        "solver": sol,
    } | common
    three_d["contact"] = dict(creep=False, normal="bilateral", conicity=LAM)
    three = svbi.simulate(validate_scenario(three_d))
    assert three.attrs["complete"] == 1
    for name in ("midspan_uz", "midspan_uz_rel", "midspan_ux"):
        a, b = two[name].values, three[name].values
        peak = np.abs(a).max()
        assert peak > 0 and np.abs(a - b).max() < 1e-10 * peak, (name, np.abs(a - b).max() / peak)
    p2 = two.contact_force.values.reshape(steps + 1, -1)[:, 0]
    q = three.contact_force.transpose("time", "car", "wheel", "side").values[:, 0, 0, :]
    assert np.abs(q.sum(axis=1) - p2).max() < 1e-9 * p2.max()
    assert np.abs(three.ground_uz.values - two.ground_uz.values.reshape(steps + 1, -1)[:, 0]).max() == 0.0
    # the lateral component: the span sways with the ground; its motion relative to the ground is
    # the absolute one less the mean of its supports' (the same synthetic record, here synchronous)
    three_d["earthquake"] = dict(lateral="synthetic", scale=0.5)
    sway = svbi.simulate(validate_scenario(three_d))
    uy, rel = sway.midspan_uy.values, sway.midspan_uy_rel.values
    assert np.abs(uy).max() > 10 * np.abs(rel).max() > 0  # a stiff span rides with its supports
