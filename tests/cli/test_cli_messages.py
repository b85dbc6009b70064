"""Command-line messages a user can act on.

* library warnings (SciPy's LinAlgWarning, NumPy's All-NaN slice, Dask's port warning) are one
  translated line or silenced, never a source line;
* a diverged run whose partial results cannot be written reports both;
* ``svbi check`` fails a quantity with NaN samples as invalid (it used to say "n/a" and pass);
* ``svbi modes`` refuses a degenerate span instead of printing 0 Hz modes;
* a file of another kind (a sweep store to ``svbi metrics``, a scenario to ``svbi derive``) is
  told what it is;
* the run summary names a pier by its results number and its scenario entry.
"""

from __future__ import annotations

import errno
import os
import warnings
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = REPO / "examples"

GOOD = """\
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

[contact]
creep = false
"""


def _app():
    from svbi.runtime.cli.app import _register, app

    _register()
    return app


def _invoke(*args: str):
    return CliRunner().invoke(_app(), list(args))


def _lines(output: str) -> list[str]:
    return [line for line in output.splitlines() if line.strip()]


# --------------------------------------------------------------------------------------------------
# library warnings


ILL_CONDITIONED = "Ill-conditioned matrix (rcond=1e-20): result may not be accurate."


def test_a_linalg_warning_is_one_translated_line(capsys: pytest.CaptureFixture[str]) -> None:
    from scipy.linalg import LinAlgWarning

    from svbi.runtime.cli import messages

    messages._SHOWN.clear()
    with warnings.catch_warnings():
        messages.install()
        warnings.simplefilter("always")
        for _ in range(2):
            warnings.warn(ILL_CONDITIONED, LinAlgWarning, stacklevel=1)
    err = _lines(capsys.readouterr().err)
    assert len(err) == 1
    head = "warning: a linear system of the model is ill-conditioned"
    assert err[0].startswith(f"{head} ({ILL_CONDITIONED[:-1]})")
    assert "unit slip" in err[0]


def test_an_all_nan_slice_is_translated_and_a_dask_port_warning_silenced(
    capsys: pytest.CaptureFixture[str],
) -> None:
    from svbi.runtime.cli import messages

    messages._SHOWN.clear()
    with warnings.catch_warnings():
        messages.install()
        warnings.simplefilter("always")
        np.nanmax(np.array([np.nan, np.nan]))
        warnings.warn(
            "Port 8787 is already in use.\nPerhaps you already have a cluster running?\nHosting the HTTP "
            "server on port 41234 instead",
            UserWarning,
            stacklevel=1,
        )
    err = _lines(capsys.readouterr().err)
    assert err == [
        "warning: a quantity is NaN (not a number) everywhere it was looked at: its peak is NaN; the run's "
        "values or the results file are not valid numbers"
    ]
    assert all(reason for _, reason in messages.SILENCED)


def test_svbi_plot_of_an_all_nan_file_prints_one_translated_line_not_numpys(tmp_path: Path) -> None:
    import xarray as xr

    out = tmp_path / "r.nc"
    scenario = tmp_path / "s.toml"
    scenario.write_text(GOOD, encoding="utf-8")
    assert _invoke("run", str(scenario), "-o", str(out), "-q").exit_code == 0
    ds = xr.load_dataset(out)
    for name in ds.data_vars:
        if "time" in ds[name].dims and ds[name].dtype.kind == "f":
            ds[name].values[...] = np.nan
    bad = tmp_path / "nan.nc"
    ds.to_netcdf(bad)
    result = _invoke("plot", str(bad), "-o", str(tmp_path / "figures"))
    assert result.exit_code == 0, result.output
    assert "RuntimeWarning" not in result.output and "All-NaN" not in result.output, result.output
    warned = [line for line in result.output.splitlines() if line.startswith("warning:")]
    assert warned == [
        "warning: a quantity is NaN (not a number) everywhere it was looked at: its peak is NaN; the run's "
        "values or the results file are not valid numbers"
    ]


# --------------------------------------------------------------------------------------------------
# a divergence whose partial file cannot be written


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


def test_a_divergence_whose_partial_file_cannot_be_written_reports_both(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import svbi.runtime.run.results as results
    import svbi.runtime.run.simulate as sim
    from svbi.runtime.backends import registry

    def full(path, write):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(results, "write_atomic", full)
    scenario = tmp_path / "s.toml"
    scenario.write_text(GOOD, encoding="utf-8")
    sim.register_backend("casadi", {"localized-dynamic": _Exploding})
    try:
        result = _invoke(
            "run",
            str(scenario),
            "-o",
            str(tmp_path / "run.nc"),
            "-q",
            "--set",
            "solver.backend=casadi",
            "--set",
            "solver.output_every=1",
        )
    finally:
        registry.unregister_backend("casadi")
    assert result.exit_code == 4
    (line,) = _lines(result.output)
    assert "diverged" in line and "No space left on device" in line
    assert str(tmp_path / "run.incomplete.nc") in line


# --------------------------------------------------------------------------------------------------
# svbi check with NaN samples


@pytest.fixture(scope="module")
def results_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("check")
    scenario = folder / "s.toml"
    scenario.write_text(GOOD, encoding="utf-8")
    out = folder / "r.nc"
    assert _invoke("run", str(scenario), "-o", str(out), "-q").exit_code == 0
    return out


def _with_nan(src: Path, dst: Path, variable: str, rows: slice) -> Path:
    import xarray as xr

    ds = xr.load_dataset(src)
    values = ds[variable].values.copy()
    values[rows] = np.nan
    ds[variable].values = values
    ds.to_netcdf(dst)
    return dst


def test_svbi_check_fails_a_quantity_with_nan_samples(results_file: Path, tmp_path: Path) -> None:
    good = _invoke("check", str(results_file))
    # the run's deck acceleration passes (its deflection under LM71 may not: the row read here)
    row = next(line for line in good.output.splitlines() if line.startswith("deck acceleration"))
    assert " pass " in f" {row} ", good.output
    bad = _with_nan(results_file, tmp_path / "nan.nc", "deck_acceleration", slice(5, 8))
    result = _invoke("check", str(bad))
    assert result.exit_code == 3, result.output
    row = next(line for line in result.output.splitlines() if line.startswith("deck acceleration"))
    assert "FAIL" in row and "invalid: 3 NaN sample(s) in deck_acceleration" in row
    assert "1 check(s) invalid: NaN values in the results" in result.output


def test_svbi_check_fails_the_unloading_rows_when_the_wheel_force_has_nan(
    results_file: Path, tmp_path: Path
) -> None:
    bad = _with_nan(results_file, tmp_path / "nan.nc", "contact_force_filtered", slice(5, 6))
    result = _invoke("check", str(bad))
    assert result.exit_code == 3
    rows = [line for line in result.output.splitlines() if line.startswith("wheel unloading")]
    assert len(rows) == 1  # the traffic set's 0.6 (the seismic set has the 0.8 of short transients)
    assert all("FAIL" in r and "NaN sample(s) in contact_force_filtered" in r for r in rows)


# --------------------------------------------------------------------------------------------------
# svbi modes of a degenerate span


@pytest.mark.parametrize(
    "sets", [["youngs_modulus=1e-300"], ["span_length=1e6", "elements_per_span=1"]], ids=["E", "length"]
)
def test_svbi_modes_refuses_a_degenerate_span(sets: list[str]) -> None:
    args = ["modes", "moving-load"]
    for s in sets:
        args += ["--set", s]
    result = _invoke(*args)
    assert result.exit_code == 2
    (line,) = _lines(result.output)
    assert line.startswith("error: --set ")
    assert "degenerate span" in line and "0 Hz" in line


def test_svbi_modes_of_a_scenario_with_a_degenerate_span_names_the_file() -> None:
    result = _invoke("modes", str(EXAMPLES / "hslm-span.toml"), "--set", "bridge.youngs_modulus=1e-10")
    assert result.exit_code == 2
    error = [line for line in _lines(result.output) if line.startswith("error:")]
    assert len(error) == 1 and str(EXAMPLES / "hslm-span.toml") in error[0] and "degenerate" in error[0]


def test_svbi_modes_of_a_sound_span_is_unchanged() -> None:
    result = _invoke("modes", "moving-load", "--json")
    assert result.exit_code == 0


# --------------------------------------------------------------------------------------------------
# a file of another kind


def test_a_sweep_store_given_to_metrics_is_told_what_it_is(tmp_path: Path) -> None:
    import xarray as xr

    store = tmp_path / "study.nc"
    xr.Dataset({"complete": ("run", np.ones(2))}, attrs={"svbi_sweep": 1}).to_netcdf(store)
    result = _invoke("metrics", str(store))
    assert result.exit_code == 2
    (line,) = _lines(result.output)
    assert "this is a sweep store" in line and "svbi plot" in line and "svbi check" in line
    # `svbi check` takes a store: this one lacks what svbi sweep writes, and says so in one line
    result = _invoke("check", str(store))
    assert result.exit_code == 2
    (line,) = _lines(result.output)
    assert "no 'status' variable" in line


def test_a_scenario_given_to_metrics_or_derive_is_told_what_it_is() -> None:
    path = EXAMPLES / "hslm-span.toml"
    for args in (["metrics", str(path)], ["derive", str(path)]):
        result = _invoke(*args)
        assert result.exit_code == 2
        (line,) = _lines(result.output)
        assert "this is a scenario file" in line and "svbi run" in line, line


def test_a_study_given_to_run_is_told_what_it_is(tmp_path: Path) -> None:
    result = _invoke("run", str(EXAMPLES / "hslm-sweep.toml"), "-o", str(tmp_path / "r.nc"))
    assert result.exit_code == 2
    assert "this is a study file" in result.output and "svbi sweep" in result.output
    assert "unknown key" not in result.output


# --------------------------------------------------------------------------------------------------
# pier numbering


PIER = """\
[bridge]
mass_per_length = 22.4e3
youngs_modulus = 35.5e9
area = 8.63
second_moment = 6.58
elements_per_span = 4

[[bridge.girders]]
spans = [10.0]
[[bridge.girders]]
spans = [10.0]

[[bridge.piers]]
support = 1
height = 8.0
mass_per_length = 20.0e3
youngs_modulus = 34.0e9
area = 8.0
second_moment = 5.0

[train]
vehicle = "moving-load"
parameters = { axle_loads = [100e3], axle_offsets = [0.0], car_length = 1.0 }
speed_kmh = 100.0

[earthquake]
longitudinal = "synthetic"

[solver]
time_step = 2.0e-3
output_every = 5
"""


def test_the_run_summary_names_a_pier_by_its_number_and_its_scenario_entry(tmp_path: Path) -> None:
    scenario = tmp_path / "pier.toml"
    scenario.write_text(PIER, encoding="utf-8")
    result = _invoke("run", str(scenario), "-o", str(tmp_path / "r.nc"))
    assert result.exit_code == 0, result.output
    line = next(line for line in result.output.splitlines() if line.startswith("pier drift"))
    assert "(pier 1 = bridge.piers[0], on support line 1," in line
