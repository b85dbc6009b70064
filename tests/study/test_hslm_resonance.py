"""HSLM trains on a single span: resonance where EN 1991-2 and beam theory put it, and cancellation.

A train of equal loads D apart excites a span's first bending mode resonantly at v = f1 D (each
coach adds one cycle of free vibration in phase). The free vibration one axle leaves behind is
proportional to |cos(π L / D)| at that speed (ERRI D214; Museros et al. 2002, J. Sound Vib. 254),
so where L / D = i - 1/2 the resonance is cancelled. Here:

* HSLM-A4 (D = 21 m) on a 20 m span (L/D = 0.95) and HSLM-A1 (D = 18 m) on the same span
  (L/D = 1.11): the speed of the peak filtered deck acceleration (``svbi.runtime.study.metrics``) lies
  within 3 % of f1 D (f1 of the model, from the generated span matrices);
* HSLM-A4 on a 31.5 m span (L/D = 1.5, cancelled) against a 21 m span (L/D = 1.0, the strongest
  resonance) of the same first frequency and mass: at v = f1 D the cancelled span's deck
  acceleration is a small fraction of the other's.

The spans are given EI so that f1 = 5 Hz (Euler-Bernoulli); the C backend and 2 ms steps keep it
fast (f1 has 100 steps per period).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import svbi
from svbi.runtime.model.hslm import HSLM_A
from svbi.runtime.scenario.schema import validate_scenario
from svbi.runtime.study.metrics import compute_metrics, span_frequencies

MASS = 15.0e3
F1 = 5.0


def bridge(length: float) -> dict:
    ei = (2 * F1 * length**2 / math.pi) ** 2 * MASS  # f1 = π/(2L²) √(EI/m)
    return dict(
        spans=1,
        span_length=length,
        mass_per_length=MASS,
        youngs_modulus=35.0e9,
        area=6.0,
        second_moment=ei / 35.0e9,
        damping_ratio=0.01,
        elements_per_span=8,
    )


def peak_acceleration(length: float, train: str, speed: float) -> float:
    sc = validate_scenario(
        {
            "bridge": bridge(length),
            "train": {"vehicle": "moving-load", "hslm": train, "speed": speed},
            "solver": {"time_step": 2e-3, "output_every": 1},
        }
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        ds = svbi.simulate(sc)
    return float(compute_metrics(ds).peak_deck_acceleration.max())


@pytest.mark.parametrize(("train", "length"), [("A4", 20.0), ("A1", 20.0)])
def test_peak_deck_acceleration_at_the_resonance_speed(train, length):
    f1 = span_frequencies(bridge(length)).f1
    coach = HSLM_A[train].coach_length
    assert abs(math.cos(math.pi * length / coach)) > 0.8  # far from cancellation
    v_res = f1 * coach
    speeds = v_res * np.linspace(0.88, 1.12, 13)  # 2 % steps
    acc = np.array([peak_acceleration(length, train, v) for v in speeds])
    k = int(np.argmax(acc))
    assert 0 < k < speeds.size - 1, acc  # a peak inside the scan, not at its edge
    # vertex of the parabola through the peak and its neighbours
    y0, y1, y2 = acc[k - 1 : k + 2]
    h = speeds[1] - speeds[0]
    v_peak = speeds[k] + 0.5 * h * (y0 - y2) / (y0 - 2 * y1 + y2)
    assert abs(v_peak / v_res - 1.0) < 0.03, (v_peak, v_res)
    assert acc[k] > 1.5 * min(acc[0], acc[-1])  # a resonance, not a trend


def test_cancellation_where_span_is_one_and_a_half_coaches():
    coach = HSLM_A["A4"].coach_length
    cancelled, resonant = 1.5 * coach, 1.0 * coach
    a_cancel = peak_acceleration(cancelled, "A4", span_frequencies(bridge(cancelled)).f1 * coach)
    a_reson = peak_acceleration(resonant, "A4", span_frequencies(bridge(resonant)).f1 * coach)
    assert a_cancel < 0.2 * a_reson, (a_cancel, a_reson)
