"""Sweep pictures of a 3D store: a per-wheel metric of a 3D run has a ``side`` dimension (left and
right wheel of each wheelset) beside ``car`` and ``wheel``; its worst value per run, its curve against
an axis and its fragility take the worst over all three (docs/sweep.md)."""

from __future__ import annotations

import json

import numpy as np
import xarray as xr

from svbi.runtime.plots.study import fragility, plot_store, worst


def store_3d() -> tuple[xr.Dataset, np.ndarray]:
    """Y/Q per run (4 scales x 3 seeds) and per car, wheelset and side; only one wheel of each run
    carries the run's value, the others a tenth of it."""
    rng = np.random.default_rng(11)
    scales = np.array([0.5, 1.0, 2.0, 4.0])
    seeds = np.array([1.0, 2.0, 3.0])
    run_value = scales[:, None] * rng.uniform(0.2, 0.6, (scales.size, seeds.size))
    yq = np.broadcast_to(0.1 * run_value[..., None, None, None], (4, 3, 2, 2, 2)).copy()
    for i in range(scales.size):
        for j in range(seeds.size):
            yq[i, j, (i + j) % 2, j % 2, i % 2] = run_value[i, j]  # a different wheel each time
    dims = ("earthquake.scale", "earthquake.seed", "car", "wheel", "side")
    return xr.Dataset(
        {
            "peak_derailment_quotient": (dims, yq, {"units": "1"}),
            "status": (dims[:2], np.full((4, 3), "ok", dtype=object)),
        },
        coords={
            "earthquake.scale": scales,
            "earthquake.seed": seeds,
            "car": [1, 2],
            "wheel": [1, 2],
            "side": ["left", "right"],
        },
        attrs={"svbi_sweep": 1, "axes": json.dumps(["earthquake.scale", "earthquake.seed"]), "title": "3D"},
    ), run_value


def test_worst_and_fragility_of_a_per_side_metric(tmp_path):
    store, run_value = store_3d()
    w = worst(store, "peak_derailment_quotient")
    assert w.dims == ("earthquake.scale", "earthquake.seed")
    np.testing.assert_array_equal(w.values, run_value)
    limit = 0.5
    fr = fragility(store, "peak_derailment_quotient", "earthquake.scale", limit)
    assert fr.trials.tolist() == [3, 3, 3, 3]
    assert fr.exceed.tolist() == (run_value > limit).sum(axis=1).tolist()
    written, _ = plot_store(store, tmp_path / "figs", "peak_derailment_quotient", limit=limit)
    assert [p.name for p in written] == [
        "peak_derailment_quotient_vs_earthquake.scale.png",
        "fragility_peak_derailment_quotient.png",
    ]
