"""The results' post-processing: the filtered contact force and the background import of the
modules the results need after the loop (``svbi.runtime.run.results``)."""

from __future__ import annotations

import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from svbi.runtime.run import results
from svbi.runtime.run.results import ImportAhead, Recorder
from svbi.runtime.run.simulate import build_model, validate_scenario

SCENARIO = {
    "bridge": dict(
        spans=2,
        span_length=20.0,
        mass_per_length=1.0e4,
        youngs_modulus=3.0e10,
        area=5.0,
        second_moment=2.0,
        elements_per_span=4,
    ),
    "train": dict(vehicle="pioneer-2d", cars=2, speed=20.0, start_position=-1.0),
    "solver": dict(backend="numpy", time_step=1e-3, duration=2.0, output_every=7),
    "output": dict(force_filter_hz=20.0),
}


def test_filtered_force_is_the_zero_phase_butterworth_of_every_column(monkeypatch) -> None:
    """``contact_force_filtered``: a 4th-order Butterworth low-pass at 20 Hz applied forwards and
    backwards over the full-rate forces (results docstring), then every ``output_every``-th step.
    The recorder filters a few contacts at a time (FILTER_BLOCK, forced small here so that the eight
    contacts take four blocks); each column is filtered alone, so the blocks give the same bits as
    one call over all columns."""
    model = build_model(validate_scenario(SCENARIO))
    rec = Recorder(model)
    n = model.settings.steps + 1
    assert rec.forces.shape == (n, 8)
    t = np.arange(n) * model.dt
    rng = np.random.default_rng(3)
    rec.forces[:] = (
        1e5 + np.sin(2 * np.pi * 3.0 * t)[:, None] * 1e3 + rng.normal(0.0, 500.0, rec.forces.shape)
    )
    rec.steps_done = n - 1
    rec.count = rec.nout
    monkeypatch.setattr(results, "FILTER_BLOCK", 2 * n)
    got = rec._filtered(rec.count)
    sos = signal.butter(4, 20.0, btype="low", fs=1.0 / model.dt, output="sos")
    ref = signal.sosfiltfilt(sos, rec.forces, axis=0)[:: model.settings.output_every]
    assert got.shape == (rec.nout, 2, 4) and ref.shape[0] == rec.nout
    np.testing.assert_array_equal(got.reshape(rec.nout, -1), ref)


def test_import_ahead_imports_in_its_own_thread(tmp_path: Path, monkeypatch) -> None:
    (tmp_path / "svbi_ahead_probe.py").write_text(
        "import threading\nTHREAD = threading.current_thread().name\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "svbi_ahead_probe", raising=False)
    ahead = ImportAhead(["svbi_ahead_probe"])
    ahead.join()
    assert sys.modules["svbi_ahead_probe"].THREAD == "svbi-import-ahead"


@pytest.mark.parametrize(
    ("body", "error"),
    [(None, ModuleNotFoundError), ("raise RuntimeError('broken module')\n", RuntimeError)],
)
def test_import_ahead_reraises_in_the_caller(tmp_path: Path, monkeypatch, body, error) -> None:
    """An import that fails in the background fails the caller's ``join``, with its own exception."""
    name = "svbi_ahead_missing" if body is None else "svbi_ahead_broken"
    if body is not None:
        (tmp_path / f"{name}.py").write_text(textwrap.dedent(body))
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, name, raising=False)
    ahead = ImportAhead(["json", name])
    with pytest.raises(error):
        ahead.join()
    ahead.join()  # raised once: a second join has nothing left to report


def test_a_writer_that_cannot_load_loses_no_run(tmp_path: Path, monkeypatch) -> None:
    """The writer's modules are imported ahead as a head start only: a broken netCDF4 neither fails
    the run after its loop nor the write, which falls back to h5netcdf (the same NetCDF-4 file)."""
    import xarray as xr

    from svbi.runtime.run.simulate import simulate

    (tmp_path / "svbi_broken_writer.py").write_text("raise ImportError('broken writer')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "svbi_broken_writer", raising=False)
    ahead = ImportAhead(["json"], optional=["svbi_broken_writer", "textwrap"])
    ahead.join()  # nothing to report: the optional import's error is dropped
    c_run = {
        **SCENARIO,
        "solver": {**SCENARIO["solver"], "backend": "c", "duration": 0.3},
        "contact": {"creep": False},
    }
    ds = simulate(validate_scenario(c_run), import_ahead=("svbi_broken_writer",))
    monkeypatch.setitem(sys.modules, "netCDF4", None)  # `import netCDF4` raises ImportError
    assert results.netcdf_engine() == "h5netcdf"
    path = results.write_netcdf(ds, tmp_path / "run.nc")
    with xr.open_dataset(path, engine="h5netcdf") as back:
        np.testing.assert_array_equal(back["contact_force"].values, ds["contact_force"].values)


def test_modules_after_loop_follow_the_filter_setting(tmp_path: Path, monkeypatch) -> None:
    from svbi.runtime.run import force_filter as zero_phase

    monkeypatch.setenv("SVBI_CACHE_DIR", str(tmp_path))  # no filter designed yet on this "machine"
    model = build_model(validate_scenario(SCENARIO))
    assert Recorder(model).modules_after_loop()[:2] == ["scipy.signal", "xarray"]
    # once SciPy has designed the filter (stored in the cache) and the compiled filter is built, a
    # run filters without importing scipy.signal
    zero_phase.design(4, model.settings.force_filter_hz, 1.0 / model.dt)
    expected = ["xarray"] if zero_phase.compiled() else ["scipy.signal", "xarray"]
    assert Recorder(model).modules_after_loop()[: len(expected)] == expected
    # a cutoff at or above Nyquist is refused by the scenario; a model built in code may still hold one
    model.settings.force_filter_hz = 600.0  # above Nyquist (500 Hz): nothing to filter
    assert Recorder(model).modules_after_loop()[0] == "xarray"
