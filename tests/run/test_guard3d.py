"""The divergence guard of a 3D run (runtime/run/simulate3d.py, ``divergence3d``): as in 2D, a normal
gap of a wheel in contact beyond ``solver.max_gap`` stops the run, says why and keeps the steps up to
the one that stopped it.

The case: the short 3D span of tests/cases.py (one sprung wheelset on a 10 m span, three ground
components from t = 0), 60 steps. coupled-classic's gaps drift linearly (measured 3.3e-6 m after 5
steps, 3.9e-5 m after 60); localized-dynamic's stay below 4.4e-7 m (the start on the deck under
the earthquake), 2e-10 m after it. A limit of 1e-5 m lies between the two with a margin of 20 on
the dynamic side.
"""

from __future__ import annotations

import warnings

import numpy as np

import svbi
from svbi.runtime.run.simulate import SimulationIncomplete
from svbi.runtime.scenario.schema import load_scenario
from tests.cases import write_short_span_3d

LIMIT = 1e-5


def _run(tmp_path, method: str):
    sc = load_scenario(
        write_short_span_3d(tmp_path),
        overrides={
            "solver.method": method,
            "solver.duration": 0.06,
            "solver.output_every": 1,
            "solver.max_gap": LIMIT,
        },
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ds = svbi.simulate(sc)
    return ds, [w for w in caught if issubclass(w.category, SimulationIncomplete)]


def test_classic_drift_stops_a_3d_run_at_max_gap(tmp_path) -> None:
    ds, caught = _run(tmp_path, "coupled-classic")
    assert ds.attrs["complete"] == 0
    message = ds.attrs["incomplete"]
    assert "beyond solver.max_gap = 1e-05 m" in message and "coupled-classic imposes" in message
    assert caught and str(caught[0].message) == message
    gaps = np.abs(ds.normal_gap.values).max(axis=(1, 2, 3))
    # recorded up to the step that stopped it: the last row beyond the limit, every one before within
    assert gaps[-1] > LIMIT and (gaps[:-1] <= LIMIT).all()
    assert ds.attrs["steps"] < 60


def test_localized_dynamic_stays_within_the_same_limit(tmp_path) -> None:
    ds, caught = _run(tmp_path, "localized-dynamic")
    assert ds.attrs["complete"] == 1 and not caught and ds.attrs["steps"] == 60
    assert float(np.abs(ds.normal_gap).max()) < LIMIT / 20
