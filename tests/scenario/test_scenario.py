"""Scenario files (docs/scenario.md): defaults, echo, overrides and every kind of bad input.

Each bad input must fail with the dotted path of the offending key and the file and line where it
was written.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

import svbi
from svbi.runtime.scenario.schema import ScenarioError, ScenarioWarning, load_scenario, loads_scenario

GOOD = """\
title = "one span"

[bridge]
spans = 1
span_length = 25.0
mass_per_length = 2303.0
youngs_modulus = 2.87e9
area = 1.0
second_moment = 2.9
elements_per_span = 4

[train]
vehicle = "sprung-mass"
speed_kmh = 100.0

[solver]
time_step = 2.0e-3
output_every = 5
"""


def write(tmp_path: Path, text: str, name: str = "scenario.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def replace(text: str, old: str, new: str) -> str:
    assert old in text
    return text.replace(old, new)


def problems(tmp_path: Path, text: str, overrides=None) -> list[str]:
    path = write(tmp_path, text)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path, overrides=overrides)
    return [str(p) for p in info.value.problems]


def line_of(text: str, needle: str) -> int:
    return next(i for i, line in enumerate(text.splitlines(), start=1) if needle in line)


def test_defaults_are_filled_in_and_echoed(tmp_path):
    sc = load_scenario(write(tmp_path, GOOD))
    assert sc.solver.method == "localized-dynamic"
    assert sc.solver.backend == "c"
    assert sc.solver.constraint_kappa == 1.0 and sc.solver.contact_split == 0.5
    assert sc.bridge.damping_ratio == 0.02 and sc.track.irregularity == "none"
    assert sc.earthquake is None and sc.output.force_filter_hz == 20.0
    assert sc.train.speed_ms == pytest.approx(100 / 3.6)
    again = loads_scenario(sc.to_toml())  # the normalised text is itself a valid scenario
    assert again.to_dict() == sc.to_dict()


def test_full_schema_is_accepted(tmp_path):
    text = (
        GOOD
        + """
[track]
irregularity = "german-low"
seed = 4
wavelength_min = 1.0
wavelength_max = 50.0

[earthquake]
vertical = "synthetic"
longitudinal = "none"
scale = 0.5
arrival = 1.0
apparent_velocity = 800.0

[output]
force_filter_hz = 30.0
"""
    )
    sc = load_scenario(write(tmp_path, text))
    assert sc.earthquake.apparent_velocity == 800.0 and sc.track.seed == 4
    hslm = replace(GOOD, 'vehicle = "sprung-mass"', 'vehicle = "moving-load"\nhslm = "A3"')
    assert load_scenario(write(tmp_path, hslm, "h.toml")).train.hslm == "A3"


@pytest.mark.parametrize(
    ("old", "new", "key", "needle"),
    [
        ("mass_per_length = 2303.0", "mass_per_length = 0.0", "bridge.mass_per_length", "mass_per_length"),
        ("span_length = 25.0", "span_length = -25.0", "bridge.span_length", "span_length"),
        ("time_step = 2.0e-3", "time_step = 0.0", "solver.time_step", "time_step"),
        ("speed_kmh = 100.0", "speed_kmh = 0.0", "train.speed_kmh", "speed_kmh"),
        ("output_every = 5", 'output_every = 5\nmethod = "fastest"', "solver.method", "fastest"),
        ("output_every = 5", 'output_every = 5\nbackend = "fortran"', "solver.backend", "fortran"),
        ("spans = 1", 'spans = 1\ncolour = "red"', "bridge.colour", "colour"),
        ("output_every = 5", "output_every = 5\nduration = 1.0e-3", "solver.duration", "duration"),
        ("elements_per_span = 4", "elements_per_span = 4.5", "bridge.elements_per_span", "elements_per"),
        (
            "speed_kmh = 100.0",
            "speed_kmh = 100.0\n[train.parameters]\nsprung_mass = -5750.0",
            "train.parameters.sprung_mass",
            "sprung_mass",
        ),
        (
            "speed_kmh = 100.0",
            "speed_kmh = 100.0\n[train.parameters]\nwheel_mass = 0.0",
            "train.parameters.wheel_mass",
            "wheel_mass",
        ),
        (
            "speed_kmh = 100.0",
            "speed_kmh = 100.0\n[train.parameters]\nwings = 2.0",
            "train.parameters.wings",
            "wings",
        ),
    ],
)
def test_bad_value_names_key_file_and_line(tmp_path, old, new, key, needle):
    text = replace(GOOD, old, new)
    found = problems(tmp_path, text)
    line = line_of(text, needle)
    assert any(f"scenario.toml:{line}: {key}:" in p for p in found), found


def test_unknown_table_and_top_level_key(tmp_path):
    text = GOOD + '\n[solverr]\nmethod = "coupled-dynamic"\n'
    found = problems(tmp_path, text)
    assert any(f":{line_of(text, '[solverr]')}: solverr: unknown key" in p for p in found), found


def test_missing_required_key_points_at_its_table(tmp_path):
    text = replace(GOOD, "second_moment = 2.9\n", "")
    found = problems(tmp_path, text)
    assert any(
        f":{line_of(text, '[bridge]')}: bridge.second_moment: required key is missing" in p for p in found
    ), found


def test_speed_given_twice_or_never(tmp_path):
    both = problems(tmp_path, replace(GOOD, "speed_kmh = 100.0", "speed_kmh = 100.0\nspeed = 27.0"))
    assert any("train:" in p and "exactly one" in p for p in both), both
    never = problems(tmp_path, replace(GOOD, "speed_kmh = 100.0", ""))
    assert any("exactly one" in p for p in never), never


def test_all_problems_are_reported_at_once(tmp_path):
    text = replace(replace(GOOD, "span_length = 25.0", "span_length = 0.0"), "area = 1.0", "area = -1.0")
    found = problems(tmp_path, text)
    assert len(found) == 2


def test_malformed_toml_names_the_line(tmp_path):
    text = replace(GOOD, "[solver]", "[solver")
    found = problems(tmp_path, text)
    assert found[0].startswith(f"{tmp_path / 'scenario.toml'}:{line_of(text, '[solver')}:"), found
    assert "malformed TOML" in found[0]


def test_unreadable_file(tmp_path):
    with pytest.raises(ScenarioError, match="cannot read"):
        load_scenario(tmp_path / "missing.toml")


def test_record_file_must_exist(tmp_path):
    text = GOOD + '\n[earthquake]\nvertical = "records/missing.at2"\n'
    found = problems(tmp_path, text)
    assert any("earthquake.vertical" in p and "missing.at2" in p for p in found), found


def test_coarse_time_step_warns_with_the_numbers(tmp_path):
    text = replace(GOOD, "time_step = 2.0e-3", "time_step = 2.0e-2")
    with pytest.warns(ScenarioWarning, match=r"steps per period") as record:
        load_scenario(write(tmp_path, text))
    message = str(record[0].message)
    assert "solver.time_step = 0.02" in message and "Hz" in message
    with warnings.catch_warnings():
        # only the time-step warning is under test (sprung-mass also warns that its wheel cannot creep)
        warnings.filterwarnings("error", message=".*steps per period", category=ScenarioWarning)
        load_scenario(write(tmp_path, GOOD, "fine.toml"))  # 2e-3 s is fine for this vehicle


def test_overrides_are_toml_literals_or_text(tmp_path):
    sc = load_scenario(
        write(tmp_path, GOOD),
        overrides=[
            "solver.method=coupled-dynamic",
            "solver.time_step=1e-3",
            "earthquake.vertical=synthetic",
            "train.parameters.sprung_mass=6000.0",
            'title="with spaces"',
        ],
    )
    assert sc.solver.method == "coupled-dynamic" and sc.solver.time_step == 1e-3
    assert sc.earthquake.vertical == "synthetic" and sc.train.parameters == {"sprung_mass": 6000.0}
    assert sc.title == "with spaces"
    found = problems(tmp_path, GOOD, overrides=["bridge.spans=0"])
    assert any(p.startswith("--set bridge.spans=0: bridge.spans:") for p in found), found


def test_casadi_backend_runs_and_agrees_with_numpy(tmp_path):
    """``backend = "casadi"`` evaluates the contact rows with the CasADi Functions (no fallback);
    the warn-once fallback of a backend that cannot run is in tests/backends/test_c_backend.py."""
    import svbi.runtime.run.simulate as sim

    sc = load_scenario(write(tmp_path, GOOD), overrides=["solver.backend=casadi", "solver.duration=0.02"])
    with warnings.catch_warnings():
        warnings.simplefilter("error", sim.BackendFallback)
        ds = svbi.simulate(sc)
    assert ds.attrs["backend"] == "casadi" and ds.attrs["backend_requested"] == "casadi"
    ref = svbi.simulate(
        load_scenario(write(tmp_path, GOOD), overrides=["solver.backend=numpy", "solver.duration=0.02"])
    )
    peak = float(abs(ref.contact_force).max())
    assert float(abs(ds.contact_force - ref.contact_force).max()) <= 1e-10 * peak


# --------------------------------------------------------------------------------------------------
# svbi run


def test_cli_run_writes_results_atomically(tmp_path):
    from svbi.runtime.cli.app import _register, app

    _register()
    scenario = write(tmp_path, GOOD)
    out = tmp_path / "results" / "run.nc"
    result = CliRunner().invoke(
        app,
        [
            "run",
            str(scenario),
            "-o",
            str(out),
            "-q",
            "--set",
            "solver.method=coupled-dynamic",
            "--set",
            "solver.duration=0.1",
        ],
    )
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.parent.iterdir()) == ["run.nc"]  # no temporary file left
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds.attrs["method"] == "coupled-dynamic" and ds.attrs["complete"] == 1
        assert 'method = "coupled-dynamic"' in ds.attrs["scenario"]
        assert ds.sizes["time"] == 11 and float(ds.time[-1]) == pytest.approx(0.1)
        for name in (
            "midspan_uz",
            "midspan_ux",
            "ground_uz",
            "ground_ux",
            "contact_force",
            "contact_force_filtered",
            "creep_force",
            "carbody_uz",
            "carbody_az",
            "carbody_pitch",
            "gap_vehicle",
            "gap_bridge",
            "gap_support",
        ):
            assert name in ds
        assert np.isfinite(ds.contact_force).all()


def test_cli_run_rejects_bad_scenario(tmp_path):
    from svbi.runtime.cli.app import _register, app

    _register()
    scenario = write(tmp_path, GOOD)
    out = tmp_path / "run.nc"
    result = CliRunner().invoke(app, ["run", str(scenario), "-o", str(out), "--set", "solver.time_step=-1"])
    assert result.exit_code == 2
    assert "solver.time_step" in result.output
    assert not out.exists()


class _Exploding:
    """A stepper that goes unstable after a few steps: exercises the divergence guard."""

    name = "localized-dynamic"

    def __init__(self, model, state):
        from svbi.runtime.methods.localized import LocalizedDynamic

        self.inner = LocalizedDynamic(model, state)
        self.contacts = None

    def step(self, n):
        st = self.inner.step(n)
        self.contacts = self.inner.contacts
        if n >= 12:
            st.P = st.P * np.nan
        return st


def test_cli_run_stops_a_diverging_run_and_keeps_what_it_had(tmp_path):
    import svbi.runtime.run.simulate as sim
    from svbi.runtime.backends import registry
    from svbi.runtime.cli.app import _register, app

    _register()
    sim.register_backend("casadi", {"localized-dynamic": _Exploding})
    try:
        scenario = write(tmp_path, GOOD)
        out = tmp_path / "run.nc"
        result = CliRunner().invoke(
            app,
            [
                "run",
                str(scenario),
                "-o",
                str(out),
                "-q",
                "--set",
                "solver.backend=casadi",
                "--set",
                "solver.output_every=1",
            ],
        )
    finally:
        registry.unregister_backend("casadi")
    assert result.exit_code == 3
    assert "diverged at t = 0.026 s" in result.output and "contact_force" in result.output
    assert "time step" in result.output  # the likely cause
    assert not out.exists()  # incomplete results never take the -o name (issue 15)
    with xr.open_dataset(tmp_path / "run.incomplete.nc", engine="h5netcdf") as ds:
        assert ds.attrs["complete"] == 0 and "diverged" in ds.attrs["incomplete"]
        assert ds.sizes["time"] == 13  # t = 0 and the 12 good steps
        assert np.isfinite(ds.contact_force).all() and np.isfinite(ds.contact_force_filtered).all()
