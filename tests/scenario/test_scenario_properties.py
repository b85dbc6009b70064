"""Property-based tests (hypothesis) of the scenario loader and of `svbi run` (issue 15).

Random scenario trees of *valid keys* with random values, sensible or wild (negative, zero, nan, inf,
huge, the wrong type), must end in a result or in an error that names its key, never a traceback,
and a run must never leave a partial or temporary file beside its results. Runs are kept tiny: the
keys that size a run (duration, time step, spans, elements, cars, speed, wavelength) draw either a
small valid value or an invalid one, never a large valid one.
"""

from __future__ import annotations

import math
import re
import tempfile
import warnings
from pathlib import Path
from typing import Any

import tomli_w
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from svbi.runtime.cli.app import _register, app
from svbi.runtime.scenario.schema import Scenario, ScenarioError, ScenarioWarning, validate_scenario

_register()
runner = CliRunner()

INTS = st.integers(min_value=-(2**63), max_value=2**63 - 1)
WILD = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    INTS,
    st.booleans(),
    st.text(max_size=6),
    st.lists(st.integers(-3, 3), max_size=3),
)
"""Any TOML value a user might type."""
BAD_NUMBER = st.one_of(
    st.sampled_from([0, -1, -1.0e-3, math.nan, math.inf, -math.inf, 0.0]), st.booleans(), st.text(max_size=4)
)
"""Invalid for every positive size key: runs stay small because a size key never gets a large valid value."""


def _table(fields: dict[str, st.SearchStrategy], required: tuple[str, ...] = ()) -> st.SearchStrategy:
    """A table holding the ``required`` fields and a random subset of the others."""
    return st.fixed_dictionaries(
        {k: fields[k] for k in required}, optional={k: v for k, v in fields.items() if k not in required}
    )


# (valid values, kind): "sized" keys get BAD_NUMBER as their invalid values, "free" keys WILD
BRIDGE = {
    "spans": (st.integers(1, 3), "sized"),
    "span_length": (st.floats(5.0, 40.0), "sized"),
    "mass_per_length": (st.floats(1.0e3, 5.0e4), "free"),
    "youngs_modulus": (st.floats(1.0e9, 5.0e10), "free"),
    "area": (st.floats(0.5, 10.0), "free"),
    "second_moment": (st.floats(0.1, 10.0), "free"),
    "damping_ratio": (st.floats(0.0, 0.1), "free"),
    "elements_per_span": (st.integers(1, 6), "sized"),
    "rail_height": (st.floats(-2.0, 2.0), "free"),
}
PARAMETERS = st.fixed_dictionaries(
    {},
    optional={
        "car_length": st.floats(1.0, 30.0),
        "stiffness": st.floats(0.0, 2.0e6),
        "carbody_mass": st.floats(1.0e3, 5.0e4),
        "axle_loads": st.lists(st.floats(1.0e4, 2.0e5), min_size=1, max_size=2),
        "unknown_parameter": st.floats(0.0, 1.0),
    },
)
TRAIN = {
    "vehicle": (st.sampled_from(["sprung-mass", "pioneer-2d", "moving-load"]), "free"),
    "cars": (st.integers(1, 2), "sized"),
    "speed_kmh": (st.floats(20.0, 300.0), "sized"),
    "speed": (st.floats(5.0, 80.0), "sized"),
    "start_position": (st.floats(-30.0, 10.0), "free"),
    "hslm": (st.sampled_from(["A1", "A5", "A10"]), "free"),
    "parameters": (PARAMETERS, "free"),
}
TRACK = {
    "irregularity": (st.sampled_from(["none", "german-low", "german-high"]), "free"),
    "seed": (st.integers(0, 100), "free"),
    "wavelength_min": (st.floats(0.5, 5.0), "sized"),
    "wavelength_max": (st.floats(5.0, 100.0), "sized"),
}
EARTHQUAKE = {
    "vertical": (st.sampled_from(["none", "synthetic", "missing-record.txt"]), "free"),
    "longitudinal": (st.sampled_from(["none", "synthetic"]), "free"),
    "scale": (st.floats(0.0, 2.0), "free"),
    "vertical_scale": (st.floats(0.0, 2.0), "free"),
    "longitudinal_scale": (st.floats(0.0, 2.0), "free"),
    "target_pga": (st.floats(0.1, 5.0), "free"),
    "arrival": (st.floats(0.0, 0.05), "free"),
    "apparent_velocity": (st.floats(100.0, 3000.0), "free"),
    "seed": (st.integers(0, 100), "free"),
    "record_dt": (st.floats(1.0e-3, 0.02), "free"),
}
CONTACT = {
    "creep": (st.booleans(), "free"),
    "friction": (st.floats(0.05, 0.5), "free"),
    "rail_head_radius": (st.floats(0.1, 1.0), "free"),
    "youngs_modulus": (st.floats(1.0e11, 3.0e11), "free"),
    "poisson_ratio": (st.floats(0.0, 0.5), "free"),
}
SOLVER = {
    "method": (st.sampled_from(["localized-dynamic", "coupled-dynamic", "coupled-classic"]), "free"),
    "backend": (st.sampled_from(["c", "numpy"]), "free"),
    "time_step": (st.floats(2.0e-4, 2.0e-3), "sized"),
    "duration": (st.floats(2.0e-3, 0.08), "sized"),
    "output_every": (st.integers(1, 5), "sized"),
    "constraint_kappa": (st.floats(0.0, 2.0), "free"),
    "constraint_zeta": (st.floats(0.0, 2.0), "free"),
    "contact_split": (st.floats(0.05, 0.95), "free"),
    "max_gap": (st.floats(1.0e-3, 1.0), "free"),
}
OUTPUT = {"force_filter_hz": (st.floats(1.0, 100.0), "free")}
TITLE = {"title": (st.text(max_size=10), "free")}


def _values(fields: dict[str, tuple[st.SearchStrategy, str]], wild: bool) -> dict[str, st.SearchStrategy]:
    """Each key's values: only valid ones, or valid and invalid ones mixed."""
    if not wild:
        return {k: valid for k, (valid, _) in fields.items()}
    return {
        k: st.one_of(valid, BAD_NUMBER if kind == "sized" else WILD) for k, (valid, kind) in fields.items()
    }


def _trees(wild: bool) -> st.SearchStrategy:
    required_bridge = ("span_length", "mass_per_length", "youngs_modulus", "area", "second_moment")
    return st.fixed_dictionaries(
        {
            "bridge": _table(_values(BRIDGE, wild), required_bridge),
            "train": _table(_values(TRAIN, wild), ("speed_kmh",)),
            "solver": _table(_values(SOLVER, wild), ("duration",)),
        },
        optional={
            "title": _values(TITLE, wild)["title"],
            "track": _table(_values(TRACK, wild)),
            "earthquake": _table(_values(EARTHQUAKE, wild)),
            "contact": _table(_values(CONTACT, wild)),
            "output": _table(_values(OUTPUT, wild)),
        },
    )


TREES = st.one_of(_trees(wild=False), _trees(wild=True))
"""Scenario trees of valid keys: half with valid values only (most of them run), half with wild ones
mixed in. ``solver.duration`` is always given, so that no run is a long crossing."""


# An error names its key: "<where>: <dotted.key>: <problem>" (scenario.Problem) or "<file>: line N"
_KEY_LINE = re.compile(r"^  \S.*?: (<toml>|<root>|<file>|[a-z_]+(\.[a-z_]+|\[\d+\])*( \(.*?\))?): \S")


def _toml(tree: dict[str, Any]) -> str | None:
    try:
        return tomli_w.dumps(tree)
    except (TypeError, ValueError):  # a value TOML cannot hold
        return None


@settings(
    max_examples=150,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(TREES)
def test_loader_gives_a_scenario_or_errors_that_name_their_keys(tree: dict[str, Any]) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ScenarioWarning)
        try:
            scenario = validate_scenario(tree, source="tree.toml")
        except ScenarioError as exc:
            event("invalid")
            assert exc.problems
            for problem in exc.problems:
                assert problem.key and problem.message, problem
                assert "\n" not in str(problem), problem
            return
    assert isinstance(scenario, Scenario)
    event("valid")
    # the normalised echo is itself a valid scenario
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ScenarioWarning)
        again = validate_scenario(scenario.to_dict(), source="echo.toml")
    assert again.to_dict() == scenario.to_dict()


def _check_run(tree: dict[str, Any], folder: Path) -> None:
    text = _toml(tree)
    if text is None:
        return
    scenario = folder / "s.toml"
    scenario.write_text(text)
    out = folder / "r.nc"
    result = runner.invoke(app, ["run", str(scenario), "-o", str(out), "-q"])
    output = result.output
    assert "Traceback" not in output, output
    assert result.exit_code in (0, 2, 3), (result.exit_code, output, result.exception)
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    left = sorted(p.name for p in folder.iterdir() if p.name != "s.toml")
    event(f"exit {result.exit_code}")
    if result.exit_code == 0:
        assert left == ["r.nc"], left
        import xarray as xr

        with xr.open_dataset(out) as ds:
            assert int(ds.attrs.get("complete", 1)) == 1
            assert float(ds.time[-1]) > 0.0
        out.unlink()
    elif result.exit_code == 2:
        assert left == [], left  # nothing written for an invalid scenario
        lines = [ln for ln in output.splitlines() if ln.strip() and not ln.startswith("warning:")]
        assert lines and lines[0].startswith("error: "), output
        for ln in lines[1:]:
            assert _KEY_LINE.match(ln), (ln, output)
    else:  # diverged: the results kept are marked incomplete, no temporary file survives
        assert left in (["r.nc"], ["r.incomplete.nc"]), left
        for name in left:
            (folder / name).unlink()


@settings(
    max_examples=50,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(TREES)
def test_run_ends_in_a_result_or_one_line_per_problem(tree: dict[str, Any]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        _check_run(tree, Path(tmp))
