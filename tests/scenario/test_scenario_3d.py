"""3D scenarios: a 3D vehicle makes a scenario 3D, its bridge and contact keys, the lateral
earthquake component, and the one-line refusals of misuse (docs/scenario.md, "3D scenarios")."""

from __future__ import annotations

import shutil
import textwrap
import warnings
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from svbi.runtime.excitation.ground import ground_motion
from svbi.runtime.excitation.synthetic import synthetic_motion
from svbi.runtime.model.ground import ground_from_scenario
from svbi.runtime.scenario.build import (
    build_model,
    distinct_spans_3d,
    piers_3d,
    section3d,
    track_geometry_3d,
)
from svbi.runtime.scenario.schema import ScenarioError, ScenarioWarning, load_scenario, loads_scenario

REPO = Path(__file__).resolve().parents[2]
EXAMPLE_3D = REPO / "examples" / "paper-2020-3d.toml"
EXAMPLE_2D = REPO / "examples" / "paper-2020.toml"

BRIDGE_3D = """\
[bridge]
spans = 2
span_length = 30.0
mass_per_length = 2.0e4
youngs_modulus = 3.0e10
area = 8.0
second_moment = 6.0
lateral_second_moment = 80.0
torsion_constant = 15.0
"""


def scenario_text(vehicle: str = "manchester-3d", bridge: str = BRIDGE_3D, extra: str = "") -> str:
    return (
        bridge
        + textwrap.dedent(
            f"""
        [train]
        vehicle = "{vehicle}"
        speed_kmh = 200.0
        """
        )
        + textwrap.dedent(extra)
    )


def load(tmp_path: Path, text: str, name: str = "s.toml"):  # noqa: ANN201
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ScenarioWarning)
        return load_scenario(path)


def line_of(text: str, start: str) -> int:
    """The line number (from 1) of the first line of ``text`` that starts with ``start``."""
    return next(n for n, line in enumerate(text.splitlines(), 1) if line.startswith(start))


def problems(tmp_path: Path, text: str) -> list[str]:
    with pytest.raises(ScenarioError) as info:
        load(tmp_path, text)
    return [str(p) for p in info.value.problems]


# --------------------------------------------------------------------------------------------------
# which scenarios are 3D


def test_the_3d_example_loads_as_a_3d_scenario() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error", ScenarioWarning)  # inside every plausibility band
        sc = load_scenario(EXAMPLE_3D)
    assert sc.dimensions == 3
    assert sc.train.vehicle == "crh380a-3d" and sc.train.cars == 10 and sc.train.speed_kmh == 300.0
    assert sc.bridge.lateral_second_moment == 85.86 and sc.bridge.torsion_constant == 15.21
    eq = sc.earthquake  # the three-component synthetic earthquake
    assert eq is not None and (eq.vertical, eq.longitudinal, eq.lateral) == ("synthetic",) * 3
    # the paper example's bridge, number for number
    paper = load_scenario(EXAMPLE_2D).bridge
    for key in ("spans", "span_length", "mass_per_length", "youngs_modulus", "area", "second_moment"):
        assert getattr(sc.bridge, key) == getattr(paper, key), key


def test_2d_scenarios_stay_2d_and_echo_no_3d_key() -> None:
    sc = load_scenario(EXAMPLE_2D)
    assert sc.dimensions == 2
    echo = sc.to_dict()
    for key in (
        "lateral_second_moment",
        "torsion_constant",
        "poisson_ratio",
        "shear_modulus",
        "torsional_mass_per_length",
        "track_eccentricity",
    ):
        assert key not in echo["bridge"], key
    assert "conicity" not in echo["contact"] and "flange_clearance" not in echo["contact"]
    assert "lateral" not in echo["earthquake"] and "lateral_scale" not in echo["earthquake"]


def test_crh380a_and_a_3d_topology_file_make_a_3d_scenario(tmp_path: Path) -> None:
    assert load(tmp_path, scenario_text("crh380a-3d")).dimensions == 3
    source = resources.files("svbi.codegen.vehicles3d").joinpath("manchester-3d.toml")
    with resources.as_file(source) as file:
        shutil.copy(file, tmp_path / "my-car.toml")
    sc = load(tmp_path, scenario_text("my-car.toml"))
    assert sc.dimensions == 3
    assert track_geometry_3d(sc).conicity == 0.1


def test_a_broken_3d_topology_file_is_one_problem_naming_train_vehicle(tmp_path: Path) -> None:
    (tmp_path / "car.toml").write_text(
        'dimensions = 3\nname = "car"\n[[bodies]]\nname = 1\n', encoding="utf-8"
    )
    found = problems(tmp_path, scenario_text("car.toml"))
    assert len(found) == 1 and "train.vehicle" in found[0] and "s.toml:" in found[0]


def test_an_unknown_parameter_of_a_3d_vehicle_is_refused(tmp_path: Path) -> None:
    found = problems(
        tmp_path,
        scenario_text(extra="[train.parameters]\nwheel_mass = 1.0\n"),
    )
    assert any("train.parameters.wheel_mass" in p and "has no parameter" in p for p in found), found


# --------------------------------------------------------------------------------------------------
# defaults of the 3D keys


def test_section_defaults_shear_modulus_and_torsional_inertia(tmp_path: Path) -> None:
    sc = load(tmp_path, scenario_text())
    s = section3d(sc)
    assert (s.E, s.A, s.I_y, s.I_z, s.J, s.mass_per_length) == (3.0e10, 8.0, 6.0, 80.0, 15.0, 2.0e4)
    assert s.shear == pytest.approx(3.0e10 / (2 * 1.2), rel=1e-15)  # Poisson's ratio 0.2
    assert s.polar_inertia == pytest.approx(2.0e4 * (6.0 + 80.0) / 8.0, rel=1e-15)  # mu (I_y + I_z) / A
    given = load(
        tmp_path,
        scenario_text(bridge=BRIDGE_3D + "shear_modulus = 1.1e10\ntorsional_mass_per_length = 3.0e5\n"),
    )
    s = section3d(given)
    assert s.shear == 1.1e10 and s.polar_inertia == 3.0e5
    nu = load(tmp_path, scenario_text(bridge=BRIDGE_3D + "poisson_ratio = 0.25\n"))
    assert section3d(nu).shear == pytest.approx(3.0e10 / 2.5, rel=1e-15)


def test_track_geometry_defaults_and_given_values(tmp_path: Path) -> None:
    geometry = track_geometry_3d(load(tmp_path, scenario_text()))
    assert (geometry.conicity, geometry.flange_clearance, geometry.eccentricity, geometry.rail_height) == (
        0.1,
        0.005,
        0.0,
        0.0,
    )
    text = scenario_text(
        bridge=BRIDGE_3D + "track_eccentricity = 0.3\nrail_height = 1.8\n",
        extra="[contact]\nconicity = 0.15\nflange_clearance = 0.008\n",
    )
    geometry = track_geometry_3d(load(tmp_path, text))
    assert (geometry.conicity, geometry.flange_clearance, geometry.eccentricity, geometry.rail_height) == (
        0.15,
        0.008,
        0.3,
        1.8,
    )


LONG_FORM_3D = """\
[bridge]
mass_per_length = 2.0e4
youngs_modulus = 3.0e10
area = 8.0
second_moment = 6.0
lateral_second_moment = 80.0
torsion_constant = 15.0
shear_modulus = 1.2e10

[[bridge.girders]]
spans = [30.0, 30.0]

[[bridge.girders]]
spans = [25.0]
torsion_constant = 9.0
poisson_ratio = 0.3

[[bridge.piers]]
support = 1
height = 12.0
mass_per_length = 3.0e4
youngs_modulus = 3.0e10
area = 10.0
second_moment = 4.0
bearing_stiffness_lateral = 2.0e9
"""


def test_long_form_girders_inherit_and_override_the_3d_section(tmp_path: Path) -> None:
    sc = load(tmp_path, scenario_text(bridge=LONG_FORM_3D))
    first, second = section3d(sc, 0), section3d(sc, 1)
    assert first.J == 15.0 and first.shear == 1.2e10 and first.I_z == 80.0
    assert second.J == 9.0 and second.I_z == 80.0
    assert second.shear == pytest.approx(3.0e10 / 2.6, rel=1e-15)  # its own Poisson's ratio
    spans = distinct_spans_3d(sc)
    assert [(s.length, s.spans) for s in spans] == [(30.0, (0, 1)), (25.0, (2,))]
    (pier,) = piers_3d(sc)
    assert pier.support == 1 and pier.bearing_stiffness_lateral == 2.0e9
    assert pier.section.I_y == 4.0 and pier.section.I_z == 4.0  # the second plane defaults to the first
    assert pier.section.J == 8.0  # the polar moment
    assert pier.section.shear == pytest.approx(3.0e10 / 2.4, rel=1e-15)


def test_a_3d_scenario_is_not_built_into_a_2d_model(tmp_path: Path) -> None:
    sc = load(tmp_path, scenario_text())
    with pytest.raises(
        ScenarioError, match="the 2D model does not take it; `svbi.simulate` and `svbi run .*` run it"
    ):
        build_model(sc)


# --------------------------------------------------------------------------------------------------
# misuse: one problem, naming file, line and key


def test_a_3d_key_in_a_2d_scenario_names_its_line(tmp_path: Path) -> None:
    text = scenario_text("pioneer-2d")
    found = problems(tmp_path, text)
    assert len(found) == 2
    assert found[0].startswith(
        f"{tmp_path / 's.toml'}:{line_of(text, 'lateral_second_moment')}: bridge.lateral_second_moment: "
        "a key of 3D scenarios"
    )
    assert found[1].startswith(
        f"{tmp_path / 's.toml'}:{line_of(text, 'torsion_constant')}: bridge.torsion_constant: a key"
    )
    assert "'pioneer-2d' is a 2D vehicle" in found[0]


def test_contact_and_pier_3d_keys_in_a_2d_scenario_are_refused(tmp_path: Path) -> None:
    two_d = LONG_FORM_3D.replace(
        "lateral_second_moment = 80.0\ntorsion_constant = 15.0\nshear_modulus = 1.2e10\n", ""
    )
    two_d = two_d.replace("torsion_constant = 9.0\npoisson_ratio = 0.3\n", "")
    found = problems(tmp_path, scenario_text("pioneer-2d", two_d, "[contact]\nconicity = 0.1\n"))
    keys = [p.split(": ")[1] for p in found]
    assert keys == ["bridge.piers[0].bearing_stiffness_lateral", "contact.conicity"], found


def test_both_poisson_ratio_and_shear_modulus_is_one_problem(tmp_path: Path) -> None:
    text = scenario_text(bridge=BRIDGE_3D + "poisson_ratio = 0.2\nshear_modulus = 1.2e10\n")
    found = problems(tmp_path, text)
    assert len(found) == 1
    assert found[0] == (
        f"{tmp_path / 's.toml'}:{line_of(text, 'shear_modulus')}: bridge.shear_modulus: give "
        "bridge.poisson_ratio or bridge.shear_modulus, not both (G = E / (2 (1 + nu)))"
    )


def test_missing_torsion_constant_of_a_3d_scenario(tmp_path: Path) -> None:
    found = problems(tmp_path, scenario_text(bridge=BRIDGE_3D.replace("torsion_constant = 15.0\n", "")))
    assert len(found) == 1
    assert found[0].startswith(f"{tmp_path / 's.toml'}:1: bridge.torsion_constant: required in a 3D scenario")
    assert "'manchester-3d' is a 3D vehicle" in found[0]
    # the long form: every girder that gives none of its own needs [bridge]'s
    long_form = LONG_FORM_3D.replace("torsion_constant = 15.0\n", "")
    assert any(
        "bridge.torsion_constant: required" in p for p in problems(tmp_path, scenario_text(bridge=long_form))
    )
    both = long_form.replace("spans = [30.0, 30.0]\n", "spans = [30.0, 30.0]\ntorsion_constant = 12.0\n")
    assert section3d(load(tmp_path, scenario_text(bridge=both)), 0).J == 12.0


def test_a_lateral_earthquake_on_a_2d_scenario_is_refused(tmp_path: Path) -> None:
    text = scenario_text(
        "pioneer-2d", BRIDGE_3D.replace("lateral_second_moment = 80.0\ntorsion_constant = 15.0\n", "")
    )
    text += '\n[earthquake]\nvertical = "synthetic"\nlateral = "synthetic"\n'
    found = problems(tmp_path, text)
    assert len(found) == 1
    assert found[0].startswith(
        f"{tmp_path / 's.toml'}:{line_of(text, 'lateral =')}: earthquake.lateral: the transverse ground "
        "motion"
    )
    assert "'pioneer-2d' is a 2D vehicle" in found[0]
    # the same through --set names the --set
    with pytest.raises(ScenarioError) as info:
        load_scenario(EXAMPLE_2D, overrides=["earthquake.lateral=synthetic"])
    assert str(info.value.problems[0]).startswith("--set earthquake.lateral=synthetic: earthquake.lateral:")


def test_the_lateral_list_must_have_one_entry_per_support(tmp_path: Path) -> None:
    found = problems(tmp_path, scenario_text(extra='[earthquake]\nlateral = ["synthetic", "none"]\n'))
    assert (
        len(found) == 1
        and "earthquake.lateral: one record per support needs bridge.spans + 1 = 3" in found[0]
    )


def test_3d_values_outside_their_bands_warn(tmp_path: Path) -> None:
    text = scenario_text(bridge=BRIDGE_3D.replace("torsion_constant = 15.0", "torsion_constant = 1.5e13"))
    path = tmp_path / "w.toml"
    path.write_text(text + "[contact]\nflange_clearance = 5.0\n", encoding="utf-8")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        load_scenario(path)
    messages = [str(w.message) for w in caught if issubclass(w.category, ScenarioWarning)]
    assert any("bridge.torsion_constant = 1.5e+13 m⁴ is outside" in m and "mm⁴" in m for m in messages)
    assert any("contact.flange_clearance = 5 m is outside" in m and "millimetres?" in m for m in messages)


# --------------------------------------------------------------------------------------------------
# the lateral ground motion


def test_the_synthetic_lateral_motion_is_processed_as_the_others_and_independent(tmp_path: Path) -> None:
    sc = load(
        tmp_path,
        scenario_text(
            extra='[earthquake]\nlongitudinal = "synthetic"\nlateral = "synthetic"\n'
            "lateral_scale = 0.5\narrival = 1.0\n"
        ),
    )
    ground = ground_from_scenario(sc, duration=15.0)
    expected = synthetic_motion("lateral", 1, scale=0.5, arrival=1.0)
    t = np.linspace(0.0, 25.0, 501)
    for got, want in zip(ground.source.motion("lateral", t), expected.evaluate(t), strict=True):
        np.testing.assert_array_equal(got, want)
    lateral = ground.source.motion("lateral", t)[2]
    longitudinal = ground.source.motion("longitudinal", t)[2]
    # the horizontal model, a peak of 0.5 x 0.35 g, and noise of its own
    assert np.max(np.abs(expected.accel)) == pytest.approx(0.5 * 0.35 * 9.81, rel=1e-12)
    assert abs(np.corrcoef(lateral, longitudinal)[0, 1]) < 0.3
    # the 2D components are unchanged by the lateral one
    alone = ground_motion(longitudinal="synthetic", arrival=1.0, duration=15.0)
    np.testing.assert_array_equal(
        alone.motion("longitudinal", t)[0], ground.source.motion("longitudinal", t)[0]
    )


def test_the_lateral_motion_travels_with_the_wave_passage_delay(tmp_path: Path) -> None:
    extra = (
        '[earthquake]\nvertical = "synthetic"\nlateral = "synthetic"\n'
        "apparent_velocity = 500.0\narrival = 2.0\n"
    )
    sc = load(tmp_path, scenario_text(extra=extra))
    ground = ground_from_scenario(sc, duration=15.0)
    history = synthetic_motion("lateral", 1, arrival=2.0)
    supports = np.array(sc.bridge.line_positions())
    for x in supports:
        for got, want in zip(
            ground.lateral(7.3, np.array([x])), history.evaluate(np.array([7.3 - x / 500.0])), strict=True
        ):
            np.testing.assert_array_equal(got, want)
    q, q1, q2 = ground.under_lateral(7.3, supports, speed=50.0)
    base = history.evaluate(7.3 - supports / 500.0)
    np.testing.assert_allclose(q1, (1 - 50.0 / 500.0) * base[1], rtol=1e-15)


def test_one_lateral_record_per_support_line(tmp_path: Path) -> None:
    sc = load(
        tmp_path,
        scenario_text(extra='[earthquake]\nlateral = ["synthetic", "none", "synthetic"]\nseed = 3\n'),
    )
    ground = ground_from_scenario(sc, duration=15.0)
    history = synthetic_motion("lateral", 3)
    t = 6.0
    q, qd, qdd = ground.lateral(t, np.array([0.0, 30.0, 60.0]))
    want = history.evaluate(np.array(t))
    assert (q[0], qd[0], qdd[0]) == (want[0], want[1], want[2])
    assert (q[1], qd[1], qdd[1]) == (0.0, 0.0, 0.0)  # "none": the pier at rest
    assert (q[2], qd[2], qdd[2]) == (want[0], want[1], want[2])


def test_lateral_records_of_the_tabas_pair(tmp_path: Path, shared_dir: Path) -> None:
    """The Tabas record's two horizontals: fault-parallel along the track, fault-normal across it."""
    folder = shared_dir / "data" / "ground-motions"
    for name in ("tabasFN.txt", "tabasFP.txt"):
        shutil.copy(folder / name, tmp_path / name)
    extra = '[earthquake]\nlongitudinal = "tabasFP.txt"\nlateral = "tabasFN.txt"\nrecord_dt = 0.02\n'
    sc = load(tmp_path, scenario_text(extra=extra))
    motion = ground_from_scenario(sc, duration=40.0).source
    peak = np.max(np.abs(motion.lateral.histories[0].accel))
    assert peak == pytest.approx(0.900 * 9.81, rel=0.02)  # the README's PGA, after the processing
    assert np.max(np.abs(motion.longitudinal.histories[0].accel)) == pytest.approx(0.977 * 9.81, rel=0.02)


def test_loads_scenario_from_text_knows_builtin_3d_vehicles() -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ScenarioWarning)
        sc = loads_scenario(scenario_text())
    assert sc.dimensions == 3


def test_3d_vehicle_parameters_are_checked(tmp_path: Path) -> None:
    text = scenario_text(extra="[train.parameters]\ncarbody_mass = -1.0\n")
    found = problems(tmp_path, text)
    assert found == [
        f"{tmp_path / 's.toml'}:{line_of(text, 'carbody_mass')}: train.parameters.carbody_mass: "
        "must not be negative (got -1.0)"
    ]
    sc = load(tmp_path, text.replace("-1.0", "40000.0"))
    assert sc.train.parameters == {"carbody_mass": 40000.0}


def test_conicity_and_flange_clearance_default_to_the_vehicles_parameters(tmp_path: Path) -> None:
    source = resources.files("svbi.codegen.vehicles3d").joinpath("manchester-3d.toml")
    with resources.as_file(source) as file:
        text = Path(file).read_text(encoding="utf-8")
    text += (
        '\n[parameters.conicity]\nvalue = 0.2\nunit = "-"\ndescription = "equivalent conicity"\n'
        '\n[parameters.flange_clearance]\nvalue = 0.009\nunit = "m"\ndescription = "flange clearance"\n'
    )
    (tmp_path / "car.toml").write_text(text, encoding="utf-8")
    geometry = track_geometry_3d(load(tmp_path, scenario_text("car.toml")))
    assert (geometry.conicity, geometry.flange_clearance) == (0.2, 0.009)
    given = load(tmp_path, scenario_text("car.toml", extra="[contact]\nconicity = 0.05\n"))
    assert track_geometry_3d(given).conicity == 0.05  # [contact] first, then the vehicle, then 0.1


@pytest.mark.parametrize(
    ("broken", "problem"),
    [
        ("dimensions = 3\nname = 'car'\nx = 1.0.0\n", "malformed TOML"),
        ("dimensions = 4\nname = 'car'\n", "dimensions: must be 2 or 3 (got 4)"),
    ],
    ids=["malformed", "dimensions-4"],
)
def test_an_unreadable_vehicle_file_is_one_problem_not_a_2d_vehicle(
    tmp_path: Path, broken: str, problem: str
) -> None:
    """A topology file that cannot be read says why, once: its 3D scenario's keys are not refused
    as keys of a 2D vehicle (the file's dimensions are unknown)."""
    (tmp_path / "car.toml").write_text(broken, encoding="utf-8")
    found = problems(tmp_path, scenario_text("car.toml"))
    assert len(found) == 1, found
    assert "train.vehicle" in found[0] and problem in found[0], found
    assert "2D vehicle" not in found[0] and "runs take 2D vehicles only" not in found[0]


def test_a_zero_mass_of_a_3d_vehicle_is_refused_naming_its_parameter(tmp_path: Path) -> None:
    """A body of no mass (or inertia) makes the vehicle's mass matrix singular: refused in one line
    naming the parameter, not a 'Singular matrix' from the run's set-up."""
    for name in ("carbody_mass", "bogie_roll_inertia"):
        found = problems(tmp_path, scenario_text(extra=f"[train.parameters]\n{name} = 0.0\n"))
        assert len(found) == 1, found
        assert f"train.parameters.{name}: " in found[0] and "must be > 0" in found[0], found


def test_overlapping_3d_cars_are_refused_naming_car_length(tmp_path: Path) -> None:
    """With more than one car, car_length must exceed the car's leading-to-last-axle distance
    (manchester-3d: 2 x 9.5 + 2 x 1.28 = 21.56 m), as for 2D trains."""
    from svbi.runtime.model.system3d import vehicle3d

    offsets = [w.offset for w in vehicle3d("manchester-3d", {}).wheelsets]
    extent = max(offsets) - min(offsets)
    found = problems(tmp_path, scenario_text(extra="cars = 3\n[train.parameters]\ncar_length = 20.0\n"))
    assert len(found) == 1, found
    assert "train.parameters.car_length: " in found[0] and "overlap" in found[0]
    assert f"({extent:g} m from its leading to its last axle)" in found[0], found
    assert (
        load(tmp_path, scenario_text(extra="cars = 3\n[train.parameters]\ncar_length = 21.6\n")).train.cars
        == 3
    )
    # one car: its car_length places no other car
    assert load(tmp_path, scenario_text(extra="[train.parameters]\ncar_length = 1.0\n")).train.cars == 1


def test_a_standing_3d_train_with_creep_is_refused(tmp_path: Path) -> None:
    """The creepages are relative to the rolling speed: a train standing still with creep forces is
    refused naming train.speed_kmh (it divided by zero in the run's set-up); without creep it runs."""
    text = scenario_text(extra="[solver]\nduration = 0.01\n").replace("speed_kmh = 200.0", "speed_kmh = 0.0")
    found = problems(tmp_path, text)
    assert len(found) == 1, found
    assert "train.speed_kmh: " in found[0] and "contact.creep" in found[0], found
    assert load(tmp_path, text + "[contact]\ncreep = false\n").train.speed_kmh == 0.0


@pytest.mark.parametrize(
    ("extra", "key", "problem"),
    [
        ("[contact]\nfriction = 50.0\n", "contact.friction", "above the limit of 10"),
        ("[solver]\nduration = 1.0e7\n", "solver.duration", "steps, above the limit"),
        ("[output]\nforce_filter_hz = 1.0e6\n", "output.force_filter_hz", "not below the Nyquist"),
        ("[output]\nforce_filter_hz = 0.001\n", "output.force_filter_hz", "below 1e-05 of the Nyquist"),
        ("[solver]\nconstraint_kappa = 1.0e9\n", "solver.constraint_kappa", "above the limit"),
        ("[solver]\nduration = 0.01\noutput_every = 1000\n", "solver.output_every", "only t = 0"),
        ("[contact]\nrail_head_radius = 1.0e-5\n", "contact.rail_head_radius", "no Hertz contact ellipse"),
    ],
    ids=["friction", "steps", "filter-high", "filter-low", "kappa", "output-every", "rail-head"],
)
def test_the_size_limits_of_2d_scenarios_hold_in_3d(
    tmp_path: Path, extra: str, key: str, problem: str
) -> None:
    """Every limit of a run's size and of the solver's and contact's values is checked in a 3D
    scenario as in a 2D one (they were skipped: a 3D scenario of 1e11 steps was accepted)."""
    found = problems(tmp_path, scenario_text(extra=extra))
    assert len(found) == 1, found
    assert f"{key}: " in found[0] and problem in found[0], found


def test_a_3d_deck_of_no_mass_is_refused(tmp_path: Path) -> None:
    bridge = BRIDGE_3D.replace("mass_per_length = 2.0e4", "mass_per_length = 1.0e-300")
    found = problems(tmp_path, scenario_text(bridge=bridge))
    assert len(found) == 1 and "bridge.mass_per_length: " in found[0] and "not a finite" in found[0], found
