"""A measured rail profile: ``[track] irregularity = "profile.txt"`` (issue 13 item 4).

* the file is checked when the scenario loads (exists, two numeric columns, x strictly increasing),
  errors naming ``track.irregularity``, the file and the line;
* every wheel's path over the run must lie inside the profile (nothing is extrapolated);
* the profile is used as given: no onset ramp, the recorded ``irregularity`` is the cubic spline of
  the measured points at each wheel from t = 0 on;
* a sprung mass running over a measured bump on the approach track against an independent
  solution of its equation of motion (``solve_ivp``), on the C loop; C = NumPy with a measured
  profile on a bridge (the NumPy backend's 25,000 steps over the bump took most of this file's time).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import c_compiler_works
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

from svbi.runtime.run.output import OutputPathError, check_output, run_inputs
from svbi.runtime.run.simulate import build_model, simulate
from svbi.runtime.scenario.schema import ScenarioError, load_scenario

M_S, K_S = 5750.0, 1.595e6  # sprung-mass defaults (codegen/vehicles/sprung-mass.toml)

SCENARIO = """\
[bridge]
spans = 1
span_length = 25.0
mass_per_length = 2303.0
youngs_modulus = 2.87e9
area = 1.0
second_moment = 2.9
elements_per_span = 8

[train]
vehicle = "sprung-mass"
speed = 20.0
start_position = -60.0

[track]
irregularity = "profile.txt"

[contact]
creep = false

[solver]
time_step = 1.0e-4
duration = 2.5
output_every = 10
"""

BUMP_START, BUMP_LENGTH, BUMP_HEIGHT = -50.0, 10.0, 2.0e-3


def bump(x: np.ndarray) -> np.ndarray:
    """A C2 bump (sin^4: value, slope and curvature vanish at both ends) on flat track."""
    s = np.clip((x - BUMP_START) / BUMP_LENGTH, 0.0, 1.0)
    return BUMP_HEIGHT * np.sin(np.pi * s) ** 4


def write_profile(folder: Path, x: np.ndarray, r: np.ndarray, name: str = "profile.txt") -> Path:
    path = folder / name
    np.savetxt(path, np.column_stack([x, r]), header="x (m)  r (m)")
    return path


def scenario_file(folder: Path, text: str = SCENARIO) -> Path:
    path = folder / "scenario.toml"
    path.write_text(text, encoding="utf-8")
    return path


def problems(path: Path, overrides: list[str] | None = None) -> list[str]:
    with pytest.raises(ScenarioError) as info:
        load_scenario(path, overrides=overrides)
    return [str(p) for p in info.value.problems]


# --------------------------------------------------------------------------------------------------
# the file and its coverage


def test_missing_or_malformed_profile_names_the_key_file_and_line(tmp_path: Path) -> None:
    sc = scenario_file(tmp_path)
    found = problems(sc)
    assert any("track.irregularity" in p and "profile.txt" in p for p in found), found

    path = tmp_path / "profile.txt"
    path.write_text("# x r\n0.0 0.0\n1.0 abc\n2.0 0.0\n3.0 0.0\n", encoding="utf-8")
    found = problems(sc)
    assert any("track.irregularity" in p and f"{path}: line 3: not a number" in p for p in found), found

    path.write_text("0.0 0.0\n1.0 0.0\n1.0 0.0\n2.0 0.0\n3.0 0.0\n", encoding="utf-8")
    found = problems(sc)
    assert any("track.irregularity" in p and "line 3" in p and "increas" in p for p in found), found


def test_profile_must_cover_every_wheel_path(tmp_path: Path) -> None:
    x = np.arange(-55.0, 0.0, 0.05)  # the wheel starts at -60 m and ends at -60 + 20 x 2.5 = -10 m
    write_profile(tmp_path, x, bump(x))
    found = problems(scenario_file(tmp_path))
    assert any(
        "track.irregularity" in p and "-55 .. -0.05 m" in p and "-60 .. -10 m" in p and "extend" in p
        for p in found
    ), found
    x = np.linspace(-60.0, -9.0, 1021)
    write_profile(tmp_path, x, bump(x))
    load_scenario(scenario_file(tmp_path))  # covers -60 .. -9: accepted
    found = problems(scenario_file(tmp_path), ["solver.duration=2.6"])  # to -8 m
    assert any("track.irregularity" in p and "solver.duration" in p for p in found), found


def test_profile_is_an_input_the_results_may_not_overwrite(tmp_path: Path) -> None:
    x = np.arange(-70.0, 0.0, 0.05)
    path = write_profile(tmp_path, x, bump(x), "profile.nc")  # a profile may be called anything
    sc = load_scenario(scenario_file(tmp_path, SCENARIO.replace("profile.txt", "profile.nc")))
    assert run_inputs(sc)["track.irregularity"] == path
    with pytest.raises(OutputPathError, match="track.irregularity"):
        check_output(str(path), run_inputs(sc))


# --------------------------------------------------------------------------------------------------
# the run


@pytest.fixture(scope="module")
def bump_runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict, np.ndarray, np.ndarray]:
    folder = tmp_path_factory.mktemp("bump")
    x = np.arange(-70.0, 0.0, 0.02)
    write_profile(folder, x, bump(x))
    sc = scenario_file(folder)
    runs = {"c": simulate(load_scenario(sc, overrides=["solver.backend=c"]))}
    assert runs["c"].attrs["backend"] == ("c" if c_compiler_works() else "numpy")
    return runs, x, np.loadtxt(folder / "profile.txt")[:, 1]


def test_irregularity_is_the_profile_under_the_wheel_from_the_start(bump_runs) -> None:
    runs, x, r = bump_runs
    spline = CubicSpline(x, r, bc_type="not-a-knot")  # the interpolant the file's points define
    for ds in runs.values():
        t = ds.time.values
        wheel = -60.0 + 20.0 * t
        recorded = ds.irregularity.values[:, 0, 0]
        np.testing.assert_allclose(recorded, spline(wheel), rtol=0, atol=1e-12 * np.abs(r).max())


def test_sprung_mass_over_a_measured_bump_against_its_equation_of_motion(bump_runs) -> None:
    """The wheel follows the rigid approach track: w(t) = r(x(t)); the sprung mass obeys
    M z'' = -K (z - w) (no damping), from rest in equilibrium on the flat track before the bump."""
    runs, x, r = bump_runs
    spline = CubicSpline(x, r, bc_type="not-a-knot")

    def rhs(t: float, y: np.ndarray) -> list[float]:
        return [y[1], -K_S / M_S * (y[0] - float(spline(-60.0 + 20.0 * t)))]

    t = runs["c"].time.values
    ref = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-11, atol=1e-14, method="DOP853")
    z0 = 0.0
    peak = np.abs(ref.y[0] - z0).max()
    assert peak > 1e-3  # the bump moves the car body by millimetres
    for name, run in runs.items():
        z = run.carbody_uz.values[:, 0]
        # Newmark (average acceleration) at dt = 1e-4 s on a 2.6 Hz oscillator: period error
        # (w dt)^2 / 12 ~ 2e-7, i.e. ~1e-5 of the peak after the 13 periods of the run
        np.testing.assert_allclose(z, ref.y[0], rtol=0, atol=1e-4 * peak, err_msg=name)


def test_c_equals_numpy_with_a_measured_profile_on_a_bridge(tmp_path: Path) -> None:
    x = np.arange(-60.0, 120.0, 0.05)
    write_profile(tmp_path, x, 1e-3 * np.sin(2 * np.pi * x / 7.3) + 5e-4 * np.sin(2 * np.pi * x / 2.1 + 0.3))
    text = (
        SCENARIO.replace('vehicle = "sprung-mass"', 'vehicle = "pioneer-2d"')
        .replace("speed = 20.0", "speed_kmh = 100.0")
        .replace("start_position = -60.0", "start_position = -20.0")
        .replace("spans = 1", "spans = 2")
        .replace("creep = false", 'normal = "bilateral"')
        .replace("duration = 2.5", "duration = 1.5")
        .replace("time_step = 1.0e-4", "time_step = 2.0e-4")
    )
    sc = scenario_file(tmp_path, text)
    runs = {b: simulate(load_scenario(sc, overrides=[f"solver.backend={b}"])) for b in ("numpy", "c")}
    assert runs["c"].attrs["backend"] == "c"
    # 1.5 s at 100 km/h, from 20 m before the bridge: every wheel has run onto the first span over
    # the profile (the whole crossing, 3.5 s, only repeated the same steps further on)
    wheels = build_model(load_scenario(sc)).train.positions(float(runs["c"].time[-1]))
    assert 0.0 < wheels.min() and wheels.max() < 25.0, wheels
    # t = 0: the leading wheel stands on the profile as measured (no onset ramp takes it to zero)
    first = runs["numpy"].irregularity.values[0, 0, 0]
    assert first == pytest.approx(float(CubicSpline(x, np.loadtxt(tmp_path / "profile.txt")[:, 1])(-20.0)))
    assert abs(first) > 1e-4
    for name in ("midspan_uz", "contact_force", "irregularity", "carbody_az"):
        ref = runs["numpy"][name].values
        np.testing.assert_allclose(runs["c"][name].values, ref, rtol=0, atol=1e-10 * np.abs(ref).max())
