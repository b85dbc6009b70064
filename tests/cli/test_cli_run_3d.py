"""`svbi run` of a 3D scenario: the results file (the names and dimensions docs/scenario.md lists for a
3D run), `svbi metrics`, `svbi check` and `svbi plot` of it, the backend fallback, and the one-line
refusals (exit status 2, nothing written) of what the 3D run cannot do yet."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest
import xarray as xr
from typer.testing import CliRunner

from svbi.runtime.cli.app import _register, app
from tests.cases import SPRUNG_WHEELSET_3D

_register()
runner = CliRunner()

SCENARIO = """\
title = "a sprung wheelset over two spans on a pier, the track off the deck's axis"
[bridge]
mass_per_length = 2303.0
youngs_modulus = 2.87e9
area = 1.0
second_moment = 2.9
lateral_second_moment = 10.0
torsion_constant = 5.0
damping_ratio = 0.02
elements_per_span = 8
rail_height = 1.0
track_eccentricity = 0.3
[[bridge.girders]]
spans = [25.0]
[[bridge.girders]]
spans = [25.0]
[[bridge.piers]]
support = 1
height = 8.0
mass_per_length = 3.0e4
youngs_modulus = 3.2e10
area = 9.0
second_moment = 6.0
[train]
vehicle = "sw3d.toml"
speed_kmh = 100.0
start_position = 20.0
[contact]
normal = "bilateral"
creep = false
[solver]
method = "localized-dynamic"
backend = "numpy"
time_step = 2e-3
duration = 0.4
output_every = 2
"""

WHEEL = ("time", "car", "wheel", "side")
AXLE = ("time", "car", "wheel")
NAMES = {  # docs/scenario.md, "Results of a 3D run"
    "contact_force": WHEEL,
    "contact_force_filtered": WHEEL,
    "normal_contact_force": WHEEL,
    "contact_angle": WHEEL,
    "creep_force": WHEEL,
    "lateral_creep_force": WHEEL,
    "flange_force": WHEEL,
    "flange_contact": WHEEL,
    "wheel_lateral_force": WHEEL,
    "wheel_lateral_force_filtered": WHEEL,
    "derailment_quotient": WHEEL,
    "derailment_quotient_2m": WHEEL,
    "axle_lateral_force": AXLE,
    "axle_lateral_force_filtered": AXLE,
    "axle_lateral_force_2m": AXLE,
    "unloading_ratio": WHEEL,
    "static_wheel_load": ("car", "wheel", "side"),
    "wheel_rail_lateral_displacement": AXLE,
    "carbody_ay": ("time", "car"),
    "carbody_roll": ("time", "car"),
    "midspan_uy": ("time", "span"),
    "midspan_uy_rel": ("time", "span"),
    "midspan_twist": ("time", "span"),
    "midspan_twist_rel": ("time", "span"),
    "pier_top_uy": ("time", "pier"),
    "pier_top_uy_rel": ("time", "pier"),
    # the vertical variables of the 2D results that the 3D model gives
    "midspan_uz": ("time", "span"),
    "midspan_uz_rel": ("time", "span"),
    "deck_acceleration": ("time", "span"),
    "end_rotation": ("time", "span", "end"),
    "carbody_az": ("time", "car"),
    "pier_drift": ("time", "pier"),
    "normal_gap": WHEEL,
    "wheelset_position": AXLE,
}


def write(folder: Path, text: str = SCENARIO) -> Path:
    (folder / "sw3d.toml").write_text(SPRUNG_WHEELSET_3D, encoding="utf-8")
    path = folder / "scenario.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    folder = tmp_path_factory.mktemp("run3d")
    out = folder / "out.nc"
    result = runner.invoke(app, ["run", str(write(folder)), "-o", str(out), "-q"])
    assert result.exit_code == 0, result.output
    return out, result.output


def test_the_results_file_has_the_3d_names_and_dimensions(results) -> None:
    out, _ = results
    with xr.open_dataset(out) as ds:
        for name, dims in NAMES.items():
            assert name in ds.variables, name
            assert ds[name].dims == dims, name
        assert list(ds["side"].values) == ["left", "right"]
        assert ds.sizes["time"] == 101 and ds.sizes["span"] == 2 and ds.sizes["pier"] == 1
        assert ds.attrs["dimensions"] == 3 and ds.attrs["complete"] == 1
        assert ds.attrs["backend"] == "numpy" and ds.attrs["method"] == "localized-dynamic"
        assert "flange_contacts" in ds.attrs and "peak_derailment_quotient" in ds.attrs
        # 200 steps stored every 2nd; the eccentric track twists the deck under the car
        assert abs(ds["midspan_twist"].values).max() > 1e-6
        assert (ds["wheelset_position"].values[:, 0, 0] >= 20.0).all()


def test_metrics_and_check_read_the_3d_results(results) -> None:
    out, _ = results
    metrics = runner.invoke(app, ["metrics", str(out)])
    assert metrics.exit_code == 0, metrics.output
    for name in (
        "peak_derailment_quotient",
        "peak_axle_lateral_force",
        "peak_midspan_twist",
        "peak_pier_top_uy",
    ):
        assert name in metrics.output, name
    check = runner.invoke(app, ["check", str(out)])
    assert (
        "Traceback" not in check.output and check.exception is None or isinstance(check.exception, SystemExit)
    )
    assert "wheel unloading" in check.output and "deck acceleration" in check.output


def test_another_backend_runs_on_numpy_with_a_warning(tmp_path: Path) -> None:
    """The C loop has the localized-dynamic step only: coupled-dynamic with backend c steps on NumPy
    and the run says so."""
    out = tmp_path / "out.nc"
    sets = [
        "--set",
        "solver.backend=c",
        "--set",
        "solver.method=coupled-dynamic",
        "--set",
        "solver.duration=0.02",
    ]
    result = runner.invoke(app, ["run", str(write(tmp_path)), "-o", str(out), "-q", *sets])
    assert result.exit_code == 0, result.output
    assert (
        "the C loop has localized-dynamic" in result.output and "steps on the NumPy backend" in result.output
    )
    with xr.open_dataset(out) as ds:
        assert ds.attrs["backend"] == "numpy" and ds.attrs["backend_requested"] == "c"


def test_a_spectral_irregularity_moves_the_wheelset_sideways(tmp_path: Path) -> None:
    """``german-low`` gives the 3D run its alignment and cross-level too: the wheelset moves
    relative to the track, the car body sways, the contact angle varies about ``atan λ``."""
    out = tmp_path / "out.nc"
    sets = ["--set", "track.irregularity=german-low", "--set", "solver.duration=0.8"]
    result = runner.invoke(app, ["run", str(write(tmp_path)), "-o", str(out), "-q", *sets])
    assert result.exit_code == 0, result.output
    with xr.open_dataset(out) as ds:
        assert ds.attrs["complete"] == 1
        assert abs(ds["wheel_rail_lateral_displacement"].values).max() > 1e-4  # measured 2.1 mm
        assert abs(ds["carbody_ay"].values).max() > 1e-2  # measured 0.35 m/s^2
        angle = ds["contact_angle"].values
        assert abs(angle - 0.1).max() > 1e-4 and abs(angle - 0.1).max() < 0.01


EARTHQUAKE = """
[earthquake]
vertical = "synthetic"
longitudinal = "synthetic"
lateral = "synthetic"
arrival = 0.2
"""


def test_an_earthquake_and_the_approach_track_run(tmp_path: Path) -> None:
    """Three ground components and a train that starts before the deck: the run completes, the
    ground moves under it, the deck sways with it."""
    scenario = write(tmp_path, SCENARIO + textwrap.dedent(EARTHQUAKE))
    out = tmp_path / "out.nc"
    sets = ["--set", "train.start_position=-5.0", "--set", "solver.duration=0.6"]
    result = runner.invoke(app, ["run", str(scenario), "-o", str(out), *sets])
    assert result.exit_code == 0, result.output
    with xr.open_dataset(out) as ds:
        assert ds.attrs["complete"] == 1
        assert abs(ds["ground_uz"].values).max() > 0 and abs(ds["ground_ux"].values).max() > 0
        assert abs(ds["midspan_uy"].values).max() > 0
        assert float(ds["wheelset_position"].values.min()) < 0.0  # on the approach track at first


@pytest.mark.parametrize(
    ("sets", "extra", "key"),
    [
        (["train.initial=rigid-track"], "", "train.initial: 'rigid-track': a 3D run starts from the static"),
        (["train.acceleration=-1.0"], "", "train.acceleration: the 3D step runs trains at constant speed"),
    ],
)
def test_what_the_3d_run_cannot_do_is_one_line_and_exit_2(
    tmp_path: Path, sets: list[str], extra: str, key: str
) -> None:
    scenario = write(tmp_path, SCENARIO + textwrap.dedent(extra))
    out = tmp_path / "out.nc"
    args = [x for s in sets for x in ("--set", s)]
    result = runner.invoke(app, ["run", str(scenario), "-o", str(out), *args])
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    # refused with the scenario: its file, then one line naming where the key was set and the key
    assert len(lines) == 2 and lines[0] == f"error: invalid scenario {scenario}:", result.output
    assert lines[1].startswith(f"  --set {sets[0]}: {key}"), lines[1]
    assert "Traceback" not in result.output and not out.exists()


def test_what_the_3d_run_cannot_do_names_the_line_of_the_file(tmp_path: Path) -> None:
    text = SCENARIO.replace("[train]\n", "[train]\nacceleration = 0.5\n", 1)
    assert text != SCENARIO
    scenario = write(tmp_path, text)
    line = next(n for n, t in enumerate(text.splitlines(), 1) if t.startswith("acceleration = 0.5"))
    result = runner.invoke(app, ["run", str(scenario), "-o", str(tmp_path / "out.nc")])
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 2 and lines[0] == f"error: invalid scenario {scenario}:", result.output
    assert lines[1].startswith(
        f"  {scenario}:{line}: train.acceleration: the 3D step runs trains at constant"
    ), lines


def test_plot_draws_the_3d_results(results, tmp_path: Path) -> None:
    out, _ = results
    figures = tmp_path / "figures"
    result = runner.invoke(app, ["plot", str(out), "-o", str(figures)])
    assert result.exit_code == 0, result.output
    assert (figures / "lateral_running_safety.png").is_file()
    assert (figures / "fig4a_midspan_uz.png").is_file()


def test_a_measured_profile_that_does_not_cover_the_run_is_one_problem(tmp_path: Path) -> None:
    """Refused with the scenario, as in 2D: the scenario's file, then one line naming the --set, the
    key and the stretch the wheels run over."""
    profile = tmp_path / "short.txt"
    profile.write_text("".join(f"{x:.1f} 0.0\n" for x in range(0, 30)), encoding="utf-8")
    scenario = write(tmp_path)
    out = tmp_path / "out.nc"
    sets = ["--set", f"track.irregularity={profile.name}", "--set", "train.start_position=25.0"]
    result = runner.invoke(app, ["run", str(scenario), "-o", str(out), *sets])
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 2 and lines[0] == f"error: invalid scenario {scenario}:", lines
    assert lines[1].startswith(f"  --set track.irregularity={profile.name}: track.irregularity: "), lines
    assert "the wheels run over x = 25 .. " in lines[1] and "extend the profile" in lines[1], lines
    assert not out.exists()


def test_unilateral_contact_and_creep_reach_the_results(tmp_path: Path) -> None:
    """The default contact of a 3D run: unilateral, flange, creep. On the symmetric wheelset the
    cones' spin creepage ``-+lam/r0`` loads the two wheels with opposite lateral creep forces (they
    cancel on the wheelset): both non-zero and opposite, carried into the results; the flanges stay
    clear and every tread on its rail."""
    text = SCENARIO.replace('normal = "bilateral"\ncreep = false', 'normal = "unilateral"\ncreep = true')
    text = text.replace("time_step = 2e-3", "time_step = 2e-4").replace("duration = 0.4", "duration = 0.02")
    text = text.replace("track_eccentricity = 0.3", "track_eccentricity = 0.0")  # symmetric: equal loads
    scenario = write(tmp_path, text)
    out = tmp_path / "out.nc"
    result = runner.invoke(app, ["run", str(scenario), "-o", str(out)])
    assert result.exit_code == 0, result.output
    with xr.open_dataset(out) as ds:
        assert (
            "unilateral normal contact" in ds.attrs["contact_model"] and "Kalker" in ds.attrs["contact_model"]
        )
        t_y = ds["lateral_creep_force"]
        left, right = t_y.sel(side="left").values, t_y.sel(side="right").values
        assert abs(left).min() > 1.0, left  # N: the spin creep of the cones
        assert abs(left + right).max() <= 1e-9 * abs(left).max(), (left, right)
        assert not ds["flange_contact"].values.any() and float(abs(ds["flange_force"]).max()) == 0.0
        assert ds["contact_state"].values.all()


def test_track_twist_from_the_deck_twist_and_its_check(results) -> None:
    """EN 1990 A2.4.4.2.2: the track twist over 3 m at gauge 1.435 m, from the deck's twist at every
    node (linear between nodes, as the element's torsion), recomputed here by brute force (every
    3 m base starting on a 1 cm grid, ``np.interp``); on the eccentric track the wheel loads twist
    the deck. Its traffic check row takes Table A2.7's limit at the line speed (100 km/h: 4.5 mm/3m)."""
    import numpy as np

    from svbi.runtime.study.en1990 import en1990_checks
    from svbi.runtime.study.metrics import compute_metrics, scenario_table

    out, _ = results
    with xr.open_dataset(out) as ds:
        ds.load()
    phi = ds["deck_twist"].values
    x = ds["deck_node_x"].values
    span = ds["deck_node_span"].values
    truth = []
    for s in (1, 2):
        xs, ph = x[span == s], phi[:, span == s]
        starts = np.arange(xs[0], xs[-1] - 3.0 + 1e-9, 0.01)
        best = 0.0
        for row in ph:
            best = max(
                best, float(np.abs(np.interp(starts + 3.0, xs, row) - np.interp(starts, xs, row)).max())
            )
        truth.append(1e3 * 1.435 * best)
    m = compute_metrics(ds)
    got = m["peak_track_twist"].values
    assert min(truth) > 1e-4  # mm/3m: the eccentric track twists the deck
    # the grids differ (a tenth of an element, the nodes, the span's end against 1 cm): the peak of a
    # piecewise-linear function of the base's start lies on a node, which both grids contain
    np.testing.assert_allclose(got, truth, rtol=1e-6)
    rows = {r.name: r for r in en1990_checks(m, table=scenario_table(ds))}
    twist = rows["deck twist (A2.4.4.2.2)"]  # the traffic set: the scenario has no earthquake
    assert twist.limit == 4.5 and twist.value == pytest.approx(max(truth), rel=1e-6)
    assert twist.passed is True
