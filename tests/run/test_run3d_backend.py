"""Which loop a 3D run steps on (runtime/run/simulate3d.py, ``stepper3d``): ``solver.backend = "c"``
runs localized-dynamic on the compiled 3D loop, and its results are the NumPy run's; every other
method or backend steps on NumPy and says so with a BackendFallback warning.

The case: the short 3D span of tests/cases.py (one sprung wheelset on a 10 m span of four elements,
three ground components from t = 0, unilateral contact), 40 steps. The two loops solve the same
equations with different linear algebra: their results agree to 1e-10 of each variable's peak (the
round-off of another summation order, amplified by the interface iteration; measured below 1e-12).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import svbi
from svbi.runtime.backends.base import BackendFallback
from svbi.runtime.scenario.schema import load_scenario
from tests.cases import write_short_span_3d

SCALES = {
    # each variable against the peak of the response of its kind: the lateral response of this short
    # window is small (car-body a_y 5e-6 m/s^2, the deck's twist at round-off with the track on the
    # girder's axis), so its own peak is no fair scale for the round-off of the vertical response
    "contact_force": "contact_force",
    "wheel_lateral_force": "contact_force",
    "flange_force": "contact_force",
    "midspan_uz": "midspan_uz",
    "midspan_uy": "midspan_uz",
    "wheel_rail_lateral_displacement": "midspan_uz",
    "carbody_az": "carbody_az",
    "carbody_ay": "carbody_az",
}


def _run(tmp_path, **overrides):
    sc = load_scenario(write_short_span_3d(tmp_path), overrides={"solver.duration": 0.04, **overrides})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ds = svbi.simulate(sc)
    return ds, [w for w in caught if issubclass(w.category, BackendFallback)]


def test_localized_dynamic_runs_on_the_c_loop_with_the_numpy_results(tmp_path) -> None:
    c, fell = _run(tmp_path, **{"solver.backend": "c"})
    assert not fell and c.attrs["backend"] == "c" and c.attrs["complete"] == 1
    ref, _ = _run(tmp_path, **{"solver.backend": "numpy"})
    assert ref.attrs["backend"] == "numpy" and c.attrs["steps"] == ref.attrs["steps"] == 40
    for name, kind in SCALES.items():
        peak = float(np.abs(ref[kind].values).max())
        assert peak > 0.0
        assert np.abs(c[name].values - ref[name].values).max() <= 1e-10 * peak, name
    assert (c.contact_state.values == ref.contact_state.values).all()


@pytest.mark.parametrize(
    ("method", "backend", "why"),
    [
        ("coupled-dynamic", "c", "solver.backend = 'c': the C loop has localized-dynamic only; "),
        ("coupled-classic", "c", "solver.backend = 'c': the C loop has localized-dynamic only; "),
        ("localized-dynamic", "casadi", "the casadi backend has no 3D step"),
    ],
)
def test_other_methods_and_backends_step_on_numpy_and_say_so(tmp_path, method, backend, why) -> None:
    ds, fell = _run(tmp_path, **{"solver.method": method, "solver.backend": backend, "solver.duration": 0.01})
    assert ds.attrs["backend"] == "numpy" and ds.attrs["backend_requested"] == backend
    assert (
        len(fell) == 1
        and why in str(fell[0].message)
        and "steps on the NumPy backend" in str(fell[0].message)
    )
    if backend == "c":  # the c backend has a 3D step, for localized-dynamic
        assert "no 3D step" not in str(fell[0].message), fell[0].message
