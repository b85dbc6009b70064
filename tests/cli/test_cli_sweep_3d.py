"""`svbi sweep` of a 3D study from the command line (docs/sweep.md, docs/three-d.md): the sweep runs
(one worker), its store carries the 3D metrics (Y/Q, ΣY, ΔQ/Q, flange contacts, track twist, the
deck's sway and twist) equal to those of the same runs through ``svbi.simulate`` and
``compute_metrics``; `svbi check` of the store gives the seismic running-safety rows of a 3D run, and
`svbi plot` draws a per-wheel metric against the intensity axis with its fragility curve."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

import svbi
from svbi.runtime.scenario.schema import load_scenario
from svbi.runtime.study.metrics import METRIC_DIMS, compute_metrics
from svbi.runtime.study.sweep import read_store
from tests.cases import write_short_span_3d

SCALES = (0.5, 1.0)
THREE_D = (
    "peak_derailment_quotient",
    "peak_derailment_quotient_2m",
    "peak_wheel_lateral_force",
    "peak_axle_lateral_force",
    "max_unloading_ratio",
    "flange_contacts",
    "peak_carbody_ay",
    "peak_midspan_uy",
    "peak_midspan_twist",
    "peak_track_twist",
)


def cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "svbi.runtime.cli", *args],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=cwd,
    )


def test_sweep_of_a_3d_study(tmp_path: Path) -> None:
    base = write_short_span_3d(tmp_path)
    study = tmp_path / "study.toml"
    study.write_text('scenario = "base.toml"\n[axes]\n"earthquake.scale" = [0.5, 1.0]\n', encoding="utf-8")
    out = tmp_path / "out.nc"
    r = cli("sweep", str(study), "-o", str(out), "-w", "1", "-q", cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "2 runs (2 ok)" in r.stdout
    store = read_store(out)
    assert store.status.values.tolist() == ["ok", "ok"]
    assert list(store.peak_derailment_quotient.dims) == ["scale", "car", "wheel", "side"]
    for scale in SCALES:
        ref = compute_metrics(svbi.simulate(load_scenario(base, overrides={"earthquake.scale": scale})))
        point = store.sel(scale=scale)
        for name in THREE_D:
            assert name in ref, name
        compared = 0
        for name in METRIC_DIMS:
            for var in (name, f"{name}_time"):
                if var in ref:
                    np.testing.assert_allclose(point[var].values, ref[var].values, rtol=1e-12, err_msg=var)
                    compared += 1
        assert compared > 40
    # the store's checks: the seismic set with the lateral running-safety rows of a 3D run
    r = cli("check", str(out), cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "seismic set" in r.stdout
    for row in ("derailment quotient Y/Q <= 1.34", "(Y/Q)_2m <= 0.8", "track-shift force (sum Y)_2m"):
        assert row in r.stdout, row
    # a per-wheel metric against the intensity axis and its fragility (worst over car, wheel, side)
    figures = tmp_path / "figures"
    limit = float(store.peak_derailment_quotient.sel(scale=1.0).max()) * 0.5
    r = cli(
        "plot",
        str(out),
        "-o",
        str(figures),
        "--metric",
        "peak_derailment_quotient",
        "--limit",
        f"{limit}",
        cwd=tmp_path,
    )
    assert r.returncode == 0, r.stdout + r.stderr
    assert (figures / "peak_derailment_quotient_vs_scale.png").is_file()
    assert (figures / "fragility_peak_derailment_quotient.png").is_file()
