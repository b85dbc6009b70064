"""`svbi sweep` of a 3D scenario (docs/three-d.md, "3D runs"; docs/sweep.md): a study of a 3D
scenario loads into its runs, and a sweep worker that keeps no history builds the variables that the
3D metrics read (``METRIC_INPUTS``), so that its metrics are those of the full results: ``svbi sweep``
and ``svbi run`` + ``svbi metrics`` give the same numbers. The sweep itself, from the command line,
is in ``tests/cli/test_cli_sweep_3d.py``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

import svbi
from svbi.runtime.study.metrics import METRIC_INPUTS, compute_metrics
from svbi.runtime.study.sweep import load_study
from tests.cases import write_short_span_3d


def test_a_study_of_a_3d_scenario_loads_into_its_runs(tmp_path: Path) -> None:
    write_short_span_3d(tmp_path)
    study = tmp_path / "study.toml"
    study.write_text('scenario = "base.toml"\n[axes]\n"train.speed_kmh" = [80.0, 100.0]\n', encoding="utf-8")
    st = load_study(study)
    assert st.dims == ["speed_kmh"] and [r.overrides for r in st.runs] == [
        {"train.speed_kmh": 80.0},
        {"train.speed_kmh": 100.0},
    ]


def test_the_metric_inputs_give_a_3d_run_its_full_metrics(tmp_path: Path) -> None:
    scenario = svbi.load_scenario(write_short_span_3d(tmp_path))
    full = compute_metrics(svbi.simulate(scenario))
    lean = compute_metrics(svbi.simulate(scenario, variables=METRIC_INPUTS))
    assert "peak_track_twist" in full and "peak_derailment_quotient" in full
    assert sorted(lean.data_vars) == sorted(full.data_vars)
    for name in full.data_vars:
        xr.testing.assert_identical(lean[name], full[name])
    # the deck acceleration of a traffic run (no earthquake) comes from the modal envelope, which
    # needs the wheelsets' positions: the same number both ways
    traffic = svbi.load_scenario(write_short_span_3d(tmp_path, "traffic.toml", earthquake=False))
    a = compute_metrics(svbi.simulate(traffic))
    b = compute_metrics(svbi.simulate(traffic, variables=METRIC_INPUTS))
    assert np.array_equal(a.peak_deck_acceleration.values, b.peak_deck_acceleration.values)
    assert a.peak_deck_acceleration.attrs == b.peak_deck_acceleration.attrs
