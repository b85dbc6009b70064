"""The ground of a model given from Python (``model.ground = FunctionGround(...)``, streamed to the
C loop step by step): the C run records the same ``ground_uz`` / ``ground_ux`` as the NumPy run.

Both loops take the recorded ground from ``Ground.recorded`` (one value at x = 0 for a uniform
ground): the C loop's copy must sit where its recording reads it. The case: a Pioneer car standing
on one 32 m span whose ground moves longitudinally (a smooth 1 cm step) and vertically (2 mm).
"""

from __future__ import annotations

import warnings

import numpy as np

import svbi
from svbi.examples import paper_section_keys
from svbi.runtime.model.system import FunctionGround
from svbi.runtime.run.simulate import build_model
from svbi.runtime.scenario.schema import validate_scenario


def _step(a: float):
    def f(t, x, T: float = 0.05):
        s = np.clip((t - 0.02) / T, 0.0, 1.0) + 0.0 * np.asarray(x, dtype=float)
        return (
            a * s**3 * (10 - 15 * s + 6 * s * s),
            30 * a * s**2 * (1 - s) ** 2 / T,
            60 * a * s * (1 - s) * (1 - 2 * s) / T**2,
        )

    return f


def _run(backend: str):
    sc = validate_scenario(
        {
            "bridge": dict(spans=1, span_length=32.0, **paper_section_keys(), elements_per_span=4),
            "train": dict(vehicle="pioneer-2d", speed_kmh=0.0, start_position=10.0),
            "solver": dict(backend=backend, time_step=1e-3, duration=0.1, output_every=1),
        }
    )
    model = build_model(sc)
    model.ground = FunctionGround(vertical=_step(0.002), longitudinal=_step(0.01))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return svbi.simulate(sc, model=model)


def test_the_c_loop_records_a_python_ground_as_numpy_does() -> None:
    c, ref = _run("c"), _run("numpy")
    assert c.attrs["backend"] == "c"
    for name in ("ground_ux", "ground_uz"):
        assert float(np.abs(ref[name]).max()) > 1e-3, name  # the ground moves
        assert np.array_equal(c[name].values, ref[name].values), name
