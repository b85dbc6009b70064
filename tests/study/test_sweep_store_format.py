"""The sweep store as xarray users expect it: dimension names a user can type, units and long names,
CF attributes, the EN 1990 cutoff of each run, NaN where a metric does not apply, integer counts,
zlib compression in NetCDF, and the same store as Zarr (``-o study.zarr``)."""

from __future__ import annotations

import math
import re
import shutil

import h5py
import numpy as np
import pytest
import xarray as xr

import svbi
from svbi.runtime.study.store import dim_names
from svbi.runtime.study.sweep import RESERVED_NAMES, load_study, read_store, run_sweep

EI, MASS = 35.0e9 * 1.5, 15.0e3
BASE = f"""[bridge]
spans = 1
span_length = 20.0
mass_per_length = {MASS}
youngs_modulus = 35.0e9
area = 6.0
second_moment = 1.5
elements_per_span = 8
[train]
vehicle = "moving-load"
hslm = "A4"
speed_kmh = 200.0
[solver]
time_step = 1.0e-3
duration = 1.0
"""


def test_dimension_names_are_the_keys_last_parts_made_unique():
    names = dim_names(["train.speed_kmh", "earthquake.seed", "track.seed", "a.b.span"], RESERVED_NAMES)
    assert names == {
        "train.speed_kmh": "speed_kmh",
        "earthquake.seed": "earthquake_seed",
        "track.seed": "track_seed",
        "a.b.span": "b_span",  # `span` is the store's own dimension
    }
    assert dim_names(["span"], RESERVED_NAMES) == {"span": "span_2"}  # the whole key cannot help


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    """One tiny sweep (two spans x two speeds, moving loads), assembled as NetCDF and as Zarr."""
    tmp = tmp_path_factory.mktemp("store")
    (tmp / "base.toml").write_text(BASE, encoding="utf-8")
    (tmp / "s.toml").write_text(
        'scenario = "base.toml"\ntitle = "tiny"\n[axes]\n"bridge.span_length" = [15.0, 20.0]\n'
        '"train.speed_kmh" = [200.0, 300.0]\n',
        encoding="utf-8",
    )
    study = load_study(tmp / "s.toml")
    nc = tmp / "s.nc"
    run_sweep(study, nc, workers=1, progress=False)
    shutil.copytree(str(nc) + ".parts", str(tmp / "s.zarr") + ".parts")
    report = run_sweep(study, tmp / "s.zarr", workers=1, progress=False)  # every run found finished
    assert report.ran == 0
    return tmp, nc, tmp / "s.zarr"


def test_a_user_selects_by_typed_names_and_reads_units(stores):
    _, nc, _ = stores
    with xr.open_dataset(nc) as ds:
        ds = ds.load()
    point = ds.sel(speed_kmh=300, span_length=20.0)
    assert point.status.item() == "ok"
    assert ds.speed_kmh.attrs["units"] == "km/h" and ds.speed_kmh.attrs["scenario_key"] == "train.speed_kmh"
    assert ds.span_length.attrs["units"] == "m" and ds.span_length.attrs["long_name"]
    assert "end" in ds.coords and ds.end.values.tolist() == ["left", "right"]
    for name, var in ds.variables.items():
        assert var.attrs.get("long_name"), name
        if var.dtype.kind in "iuf" and name not in ("started", "ended"):
            assert var.attrs.get("units"), name
    assert ds.started.dtype.kind == "M"  # CF times: dates for a plain reader
    assert ds.attrs["Conventions"].startswith("CF-")
    assert "svbi sweep" in ds.attrs["history"] and ds.attrs["svbi_version"] == svbi.__version__


def test_the_cutoff_is_each_runs_own(stores):
    """max(30 Hz, 1.5 f1, f3) per run: f3 of a simply supported span, 9 π / (2 L²) √(EI / m), is the
    cutoff of both spans here (the finite elements' f3 is within 1 % of it with 8 elements)."""
    _, nc, _ = stores
    ds = read_store(nc)
    cutoff = ds.deck_acceleration_cutoff_hz
    assert cutoff.dims == ("span_length", "speed_kmh")
    for length in (15.0, 20.0):
        f3 = 9 * math.pi / (2 * length**2) * math.sqrt(EI / MASS)
        np.testing.assert_allclose(cutoff.sel(span_length=length).values, f3, rtol=1e-2)
    assert float(cutoff.sel(span_length=15.0)[0]) > 1.5 * float(cutoff.sel(span_length=20.0)[0])
    # the metric's description names the variable, not one run's figure
    assert not re.search(r"\d Hz", ds.peak_deck_acceleration.attrs["long_name"])


def test_metrics_that_do_not_apply_are_nan_and_counts_are_integers(stores):
    _, nc, _ = stores
    with xr.open_dataset(nc) as ds:
        assert np.isnan(ds.max_unloading_ratio.values).all()  # a moving load's force is prescribed
        assert np.isnan(ds.peak_carbody_az.values).all()
        assert ds.complete.dtype.kind == "i" and (ds.complete.values == 1).all()
        assert ds.worker_pid.dtype.kind == "i"
    with h5py.File(nc, "r") as f:
        assert f["peak_deck_acceleration"].compression == "gzip"


def test_zarr_store_is_a_zarr_folder_with_the_same_content(stores):
    tmp, nc, zarr = stores
    assert zarr.is_dir() and (zarr / "zarr.json").is_file()
    assert not [p for p in tmp.iterdir() if p.name.startswith(".s.zarr")]  # no temporary left
    a, b = read_store(nc), read_store(zarr)
    assert list(a.status.dims) == list(b.status.dims)
    for name in ("peak_deck_acceleration", "peak_midspan_uz", "deck_acceleration_cutoff_hz"):
        np.testing.assert_array_equal(a[name].values, b[name].values)
    assert b.status.values.tolist() == a.status.values.tolist()
    with xr.open_zarr(zarr) as z:
        assert z.sel(speed_kmh=300).speed_kmh.attrs["units"] == "km/h"


def test_zarr_store_written_by_the_command(stores, tmp_path):
    import subprocess
    import sys

    src, _, _ = stores
    for name in ("base.toml", "s.toml"):
        shutil.copy(src / name, tmp_path / name)
    shutil.copytree(str(src / "s.nc") + ".parts", str(tmp_path / "study.zarr") + ".parts")
    r = subprocess.run(
        [sys.executable, "-m", "svbi.runtime.cli", "sweep", "s.toml", "-o", "study.zarr", "-q"],
        capture_output=True, text=True, timeout=300, cwd=tmp_path,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "study.zarr").is_dir() and not h5py.is_hdf5(tmp_path / "study.zarr" / "zarr.json")
    r = subprocess.run(  # a second sweep replaces the store in one step
        [sys.executable, "-m", "svbi.runtime.cli", "sweep", "s.toml", "-o", "study.zarr", "-q"],
        capture_output=True, text=True, timeout=300, cwd=tmp_path,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert read_store(tmp_path / "study.zarr").sizes["speed_kmh"] == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "base.toml", "s.toml", "study.zarr", "study.zarr.parts",
    ]  # fmt: skip
