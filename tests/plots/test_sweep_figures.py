"""Figures of a sweep store: axes named with their units, the limit labelled with value, unit and
clause, the envelope of the HSLM trains, the axes maximised over stated, and the fragility curve
with its counts, Wilson intervals and bootstrap band over the levels run; and the command that
``examples/fragility.toml`` suggests, on a scaled-down copy of its study."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from matplotlib.collections import PolyCollection

from svbi.runtime.plots.study import (
    fragility,
    plot_fragility,
    plot_metric_vs_axis,
    wilson_interval,
)

REPO = Path(__file__).resolve().parents[2]


def hslm_store() -> xr.Dataset:
    """A store as `svbi sweep` writes it: 3 trains x 4 speeds x 2 damping ratios x 2 spans."""
    rng = np.random.default_rng(1)
    trains, speeds, damping = ["A1", "A2", "A3"], [200.0, 250.0, 300.0, 350.0], [0.01, 0.02]
    acc = rng.uniform(0.5, 5.0, (3, 4, 2, 2))
    status = np.full((3, 4, 2), "ok", dtype=object)
    keys = {"hslm": "train.hslm", "speed_kmh": "train.speed_kmh", "damping_ratio": "bridge.damping_ratio"}
    return xr.Dataset(
        {
            "peak_deck_acceleration": (
                ("hslm", "speed_kmh", "damping_ratio", "span"),
                acc,
                {"units": "m/s^2", "long_name": "max |deck_acceleration|"},
            ),
            "status": (("hslm", "speed_kmh", "damping_ratio"), status),
        },
        coords={
            "hslm": ("hslm", trains, {"long_name": "HSLM-A train", "scenario_key": "train.hslm"}),
            "speed_kmh": (
                "speed_kmh",
                speeds,
                {"units": "km/h", "long_name": "train speed", "scenario_key": "train.speed_kmh"},
            ),
            "damping_ratio": (
                "damping_ratio",
                damping,
                {"units": "1", "long_name": "damping ratio", "scenario_key": "bridge.damping_ratio"},
            ),
            "span": [1, 2],
        },
        attrs={
            "svbi_sweep": 1,
            "axes": json.dumps(list(keys)),
            "axis_keys": json.dumps(keys),
            "title": "t",
            "scenario": '[bridge]\ntrack_form = "ballasted"\n',
        },
    )


def test_metric_figure_units_limit_envelope_and_what_is_maximised():
    store = hslm_store()
    fig = plot_metric_vs_axis(store, "peak_deck_acceleration", "train.speed_kmh", "hslm", limit=3.5)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "train speed (km/h)"
    assert ax.get_ylabel() == "peak_deck_acceleration (m/s²)"
    texts = [t.get_text() for t in ax.texts]
    assert any("3.5 m/s²" in t and "EN 1990 A2.4.4.2.1(4)" in t for t in texts), texts
    envelope = [line for line in ax.lines if line.get_label().startswith("envelope of the 3 HSLM trains")]
    assert len(envelope) == 1
    expected = store.peak_deck_acceleration.max(("span", "damping_ratio", "hslm")).values
    np.testing.assert_array_equal(envelope[0].get_ydata(), expected)
    assert "max over span, damping_ratio (2 values)" in ax.get_title()


def fragility_store(target_pga: float | None) -> xr.Dataset:
    """6 scales x 50 seeds, the metric exceeding 1 when the scale exceeds a lognormal capacity."""
    rng = np.random.default_rng(3)
    scales = np.array([0.5, 1.0, 1.5, 2.0, 3.0, 4.0])
    capacity = 2.0 * np.exp(0.3 * rng.standard_normal((1, 50, 1)))
    metric = scales[:, None, None] / capacity
    scenario = f"[earthquake]\ntarget_pga = {target_pga}\n" if target_pga else ""
    keys = {"scale": "earthquake.scale", "seed": "earthquake.seed"}
    return xr.Dataset(
        {
            "peak_carbody_az": (("scale", "seed", "car"), metric, {"units": "m/s^2"}),
            "status": (("scale", "seed"), np.full((6, 50), "ok", dtype=object)),
        },
        coords={"scale": scales, "seed": np.arange(1, 51), "car": [1]},
        attrs={
            "svbi_sweep": 1,
            "axes": json.dumps(list(keys)),
            "axis_keys": json.dumps(keys),
            "scenario": scenario,
        },
    )


def test_fragility_in_pga_with_counts_intervals_and_band_over_the_data():
    store = fragility_store(target_pga=2.0)
    fr = fragility(store, "peak_carbody_az", "earthquake.scale", 1.0)
    np.testing.assert_array_equal(fr.levels, 2.0 * store.scale.values)  # PGA = scale x target_pga
    assert fr.theta == pytest.approx(4.0, rel=0.15)  # the capacity's median scale 2, in PGA
    fig = plot_fragility(fr, "peak_carbody_az", "scale", 1.0, xlabel="PGA (m/s²)")
    ax = fig.axes[0]
    assert ax.get_xlabel() == "PGA (m/s²)"
    counts = [t.get_text() for t in ax.texts]
    assert [f"{k}/{n}" for k, n in zip(fr.exceed, fr.trials, strict=True)] == counts
    fit = [line for line in ax.lines if line.get_label().startswith("lognormal fit")][0]
    x = fit.get_xdata()
    assert x.min() == pytest.approx(fr.levels.min()) and x.max() == pytest.approx(fr.levels.max())
    assert any(isinstance(c, PolyCollection) for c in ax.collections)  # the bootstrap band


def test_wilson_interval_against_its_closed_form():
    # 3 of 10: centre (0.3 + z²/20) / (1 + z²/10), half width z √(0.021 + z²/400) / (1 + z²/10)
    z = 1.959964
    lo, hi = wilson_interval(np.array([3]), np.array([10]))
    centre = (0.3 + z * z / 20) / (1 + z * z / 10)
    half = z * np.sqrt(0.3 * 0.7 / 10 + z * z / 400) / (1 + z * z / 10)
    assert lo[0] == pytest.approx(centre - half, rel=1e-12) and hi[0] == pytest.approx(
        centre + half, rel=1e-12
    )
    assert lo[0] == pytest.approx(0.1078, abs=1e-4) and hi[0] == pytest.approx(0.6032, abs=1e-4)


def test_the_command_suggested_in_the_fragility_example_runs(tmp_path):
    """`svbi sweep examples/fragility.toml` then `svbi plot ... --metric peak_carbody_az --limit 1.0`,
    the base scenario scaled down with --set (one short span, a coarse step, half a second)."""
    scaled = [
        "--set=bridge.spans=1",
        "--set=bridge.elements_per_span=4",
        "--set=solver.time_step=1e-3",
        "--set=solver.duration=0.5",
        "--set=train.start_position=-5.0",
        "--set=earthquake.arrival=0.0",
        "--set=track.irregularity=none",
    ]
    study = REPO / "examples" / "fragility.toml"
    cli = [sys.executable, "-m", "svbi.runtime.cli"]
    r = subprocess.run(
        [*cli, "sweep", str(study), "-o", "fragility.nc", "-q", "-w", "2", *scaled],
        capture_output=True, text=True, timeout=600, cwd=tmp_path,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    r = subprocess.run(
        [*cli, "plot", "fragility.nc", "-o", "fragility-figures", "--metric", "peak_carbody_az"]
        + ["--limit", "1.0"],
        capture_output=True, text=True, timeout=300, cwd=tmp_path,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "fragility-figures" / "fragility_peak_carbody_az.png").stat().st_size > 10_000
    assert "PGA (m/s²)" in r.stdout and r.stdout.count("/5 exceed") == 8, r.stdout
