"""Sweep pictures: the lognormal fragility fit recovers a known median and β from synthetic counts,
and `svbi plot` draws a store (metric against an axis, fragility) from a store built here."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from scipy.stats import norm

from svbi.runtime.plots.study import fit_lognormal, fragility
from svbi.runtime.run.results import write_netcdf


def test_fit_recovers_median_and_beta_from_synthetic_counts():
    rng = np.random.default_rng(7)
    theta, beta = 1.7, 0.45
    levels = np.geomspace(0.5, 5.0, 12)
    trials = np.full(levels.size, 400)
    exceed = rng.binomial(trials, norm.cdf(np.log(levels / theta) / beta))
    t, b = fit_lognormal(levels, trials, exceed)
    # 4800 trials: standard errors of about 1.5 % (θ) and 4 % (β); allow three of them
    assert t == pytest.approx(theta, rel=0.05)
    assert b == pytest.approx(beta, rel=0.12)

    # the fit maximises the binomial likelihood: no better point nearby
    def ll(tt: float, bb: float) -> float:
        p = norm.cdf(np.log(levels / tt) / bb)
        return float(np.sum(exceed * np.log(p) + (trials - exceed) * np.log1p(-p)))

    best = ll(t, b)
    for dt, db in ((1.01, 1), (0.99, 1), (1, 1.02), (1, 0.98)):
        assert ll(t * dt, b * db) < best


def test_fit_refuses_counts_without_information():
    with pytest.raises(ValueError, match="every run exceeds"):
        fit_lognormal(np.array([1.0, 2.0]), np.array([5, 5]), np.array([0, 0]))


def synthetic_store(tmp_path):
    """A store as `svbi sweep` writes it: 6 scales x 50 seeds, metric lognormal around scale."""
    rng = np.random.default_rng(3)
    scales = np.array([0.5, 1.0, 1.5, 2.0, 3.0, 4.0])
    seeds = np.arange(1, 51)
    # capacity C lognormal (median 2, beta 0.3); the metric exceeds 1 when scale > C
    capacity = 2.0 * np.exp(0.3 * rng.standard_normal((1, seeds.size, 1)))
    metric = scales[:, None, None] / capacity
    status = np.full((scales.size, seeds.size), "ok", dtype=object)
    status[0, 0] = "failed"
    metric[0, 0] = np.nan
    ds = xr.Dataset(
        {
            "peak_carbody_az": (("earthquake.scale", "earthquake.seed", "car"), metric, {"units": "m/s^2"}),
            "status": (("earthquake.scale", "earthquake.seed"), status),
        },
        coords={"earthquake.scale": scales, "earthquake.seed": seeds.astype(float), "car": [1]},
        attrs={"svbi_sweep": 1, "axes": json.dumps(["earthquake.scale", "earthquake.seed"]), "title": "t"},
    )
    path = tmp_path / "store.nc"
    write_netcdf(ds, path)
    return ds, path


def test_fragility_of_a_store_and_svbi_plot(tmp_path):
    ds, path = synthetic_store(tmp_path)
    fr = fragility(ds, "peak_carbody_az", "earthquake.scale", 1.0)
    assert fr.trials.tolist() == [49, 50, 50, 50, 50, 50]  # the failed run is left out
    assert fr.exceed[0] == 0 and fr.exceed[-1] >= 45
    assert fr.theta == pytest.approx(2.0, rel=0.15) and 0.15 < fr.beta < 0.5
    # `svbi plot` is `plot_store` on the store read back, its files listed and its text printed: the
    # figures are drawn once, through the command (the fragility's bootstrap band is seconds of work)
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "svbi.runtime.cli",
            "plot",
            str(path),
            "-o",
            str(tmp_path / "cli"),
            "--metric",
            "peak_carbody_az",
            "--limit",
            "1.0",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0, r.stderr
    written = [line.removeprefix("wrote ") for line in r.stdout.splitlines() if line.startswith("wrote ")]
    assert [Path(p).name for p in written] == [
        "peak_carbody_az_vs_earthquake.scale.png",
        "fragility_peak_carbody_az.png",
        "summary.txt",
    ]
    assert f"median {fr.theta:.4g}" in r.stdout
    assert (tmp_path / "cli" / "fragility_peak_carbody_az.png").stat().st_size > 10_000
    assert math.isclose(float(r.stdout.split("median ")[1].split(",")[0]), fr.theta, rel_tol=1e-3)
    r = subprocess.run(
        [sys.executable, "-m", "svbi.runtime.cli", "plot", str(path), "--metric", "nonsense"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 2 and "nonsense" in r.stderr
