"""The EN 1990 A2.4.4.2.1 deck acceleration of a long-form bridge reads the standard as for one span:
every mode of the structure up to fc = max(30 Hz, 1.5 f1, f3) counted in full with the code's
damping, f1 and f3 the first and third vertical modes of the deck, the envelope over each span's
nodes.

The truth is written here, independently of svbi: a girder continuous over two equal spans L has
closed-form modes, the antisymmetric ones ``sin(nπx/L)`` over both spans (each span a simply
supported beam, f = (nπ/L)²√(EI/m)/2π) and the symmetric ones, each span pinned at its end and
clamped over the pier, ``sin βx − (sin βL / sinh βL) sinh βx`` mirrored, with ``tan βL = tanh βL``
(βL = 3.9266, 7.0686, ...). Each mode's response to one unit load crossing the girder is
integrated by ``scipy.integrate.odeint``, the HSLM-A train is the sum of that response shifted by
each axle's delay (EN 1991-2 Table E.1 layout), evaluated at the model's node points of each span.
A reading that filters the midspan acceleration (what long forms had before) misses the
antisymmetric first mode, whose node is the pier, not midspan, and halves the mode at fc.
"""

from __future__ import annotations

import math
import warnings
from functools import cache

import numpy as np
import pytest
from scipy.integrate import odeint, quad
from scipy.optimize import brentq

import svbi
from svbi.runtime.model.hslm import HSLM_A
from svbi.runtime.scenario.schema import validate_scenario
from svbi.runtime.study import deck_modal
from svbi.runtime.study.metrics import compute_metrics

L = 20.0
SECTION = {"mass_per_length": 22.4e3, "youngs_modulus": 35.5e9, "area": 8.63, "second_moment": 6.58}
ZETA = 0.01
ELEMENTS = 16
BRIDGE = {**SECTION, "damping_ratio": ZETA, "elements_per_span": ELEMENTS, "girders": [{"spans": [L, L]}]}
TRAIN = "A3"
SPEED_KMH = 280.0


def axles(train: str) -> tuple[np.ndarray, np.ndarray]:
    """EN 1991-2 Table E.1 / Figure E.2 written out (as tests/study/test_deck_acceleration_en1990.py):
    axle loads (N) and offsets behind the first axle (m)."""
    row = HSLM_A[train]
    n, big, d = row.coaches, row.coach_length, row.bogie_spacing
    front = [3.0, 11.0, 3.0, 3.525, d, big - 1.5 * d - 3.525 / 2]
    gaps = front + [d] + [big - d, d] * n + front[::-1]
    offsets = np.concatenate([[0.0], np.cumsum(gaps)])
    return np.full(offsets.size, row.axle_load), offsets


def _c() -> float:
    return math.sqrt(SECTION["youngs_modulus"] * SECTION["second_moment"] / SECTION["mass_per_length"])


def symmetric_roots(count: int) -> list[float]:
    """βL of ``tan βL = tanh βL`` (a span pinned at one end, clamped at the other)."""
    return [
        brentq(lambda z: math.tan(z) - math.tanh(z), (k + 1) * math.pi + 0.1, (k + 1.5) * math.pi - 1e-9)
        for k in range(count)
    ]


def closed_form_modes() -> list[tuple[float, object]]:
    """``(omega, shape(x))`` of the two-span girder's vertical modes, ascending, x in [0, 2L]."""
    modes: list[tuple[float, object]] = []
    for n in range(1, 5):
        modes.append((_c() * (n * math.pi / L) ** 2, lambda x, n=n: np.sin(n * math.pi * np.asarray(x) / L)))
    for bl in symmetric_roots(4):
        beta = bl / L
        ratio = math.sin(bl) / math.sinh(bl)

        def shape(x, beta=beta, ratio=ratio):  # noqa: ANN001, ANN202
            x = np.asarray(x, dtype=float)
            s = np.where(x <= L, x, 2 * L - x)  # mirrored about the pier
            return np.sin(beta * s) - ratio * np.sinh(beta * s)

        modes.append((_c() * beta**2, shape))
    return sorted(modes, key=lambda m: m[0])


def kept_modes() -> tuple[list[tuple[float, object]], float]:
    modes = closed_form_modes()
    f = [w / (2 * math.pi) for w, _ in modes]
    fc = max(30.0, 1.5 * f[0], f[2])
    return [m for m in modes if m[0] / (2 * math.pi) <= fc], fc


@cache
def unit_response(speed: float, dt: float, duration: float) -> np.ndarray:
    """Modal acceleration of each kept mode (time x mode) under one unit load crossing both spans."""
    m = SECTION["mass_per_length"]
    modes, _ = kept_modes()
    t = np.arange(0.0, duration + dt / 2, dt)
    t_off = 2 * L / speed
    out = np.empty((t.size, len(modes)))
    for i, (w, shape) in enumerate(modes):
        mass = m * quad(lambda x, shape=shape: float(shape(x)) ** 2, 0.0, 2 * L, limit=200, points=[L])[0]

        def load(tau: float, shape=shape, mass=mass) -> float:  # noqa: ANN001
            return float(shape(speed * tau)) / mass if tau <= t_off else 0.0

        def rhs(y: np.ndarray, tau: float, w: float = w, load=load) -> list[float]:  # noqa: ANN001
            return [y[1], load(tau) - 2 * ZETA * w * y[1] - w * w * y[0]]

        y = odeint(rhs, [0.0, 0.0], t, tcrit=[t_off], rtol=1e-10, atol=1e-16, hmax=dt)
        out[:, i] = np.array([load(tau) for tau in t]) - 2 * ZETA * w * y[:, 1] - w * w * y[:, 0]
    return out


def independent_peaks(train: str, speed_kmh: float) -> np.ndarray:
    """Per span: max over time and the span's 17 node points of |Σ_n φ_n(x) Σ_k P_k q''_n(t - t_k)|."""
    loads, offsets = axles(train)
    v = speed_kmh / 3.6
    duration = (2 * L + offsets[-1]) / v + 0.5
    fine = 1.0e-4
    unit = unit_response(v, fine, duration)
    t_unit = np.arange(unit.shape[0]) * fine
    t = np.arange(0.0, duration, 2.5e-4)
    acc = np.zeros((t.size, unit.shape[1]))
    for p, off in zip(loads, offsets, strict=True):
        for i in range(unit.shape[1]):
            acc[:, i] += p * np.interp(t - off / v, t_unit, unit[:, i], left=0.0, right=unit[-1, i])
    modes, _ = kept_modes()
    peaks = []
    for span in range(2):
        x = span * L + np.linspace(0.0, L, ELEMENTS + 1)
        shapes = np.array([shape(x) for _, shape in modes])  # modes x points
        peaks.append(float(np.abs(acc @ shapes).max()))
    return np.array(peaks)


@pytest.fixture(scope="module")
def metrics():
    sc = validate_scenario(
        {
            "bridge": BRIDGE,
            "train": {"vehicle": "moving-load", "hslm": TRAIN, "speed_kmh": SPEED_KMH},
            "solver": {"time_step": 5e-4, "output_every": 1},
        }
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        ds = svbi.simulate(sc)
    return compute_metrics(ds)


def test_the_modes_kept_are_the_closed_form_ones_up_to_fc():
    modes = deck_modal.long_form_mode_set(BRIDGE)
    truth, fc = kept_modes()
    f_true = np.array([w / (2 * math.pi) for w, _ in truth])
    # the model keeps the girder's axial mode as well (below fc, no vertical share): the vertical
    # ones are the closed form's, within the mesh's discretisation error (16 Hermite elements a span)
    vertical = modes.frequencies_hz[
        [i for i, f in enumerate(modes.frequencies_hz) if np.min(abs(f - f_true)) < 0.01 * f]
    ]
    assert vertical.size == f_true.size, (modes.frequencies_hz, f_true)
    assert np.allclose(vertical, f_true, rtol=1e-3), (vertical, f_true)
    assert modes.f1 == pytest.approx(f_true[0], rel=1e-3) and modes.f3 == pytest.approx(f_true[2], rel=1e-3)
    assert modes.cutoff_hz == pytest.approx(fc, rel=1e-3)
    assert modes.frequencies_hz.size == f_true.size + 1  # the axial mode of the 40 m girder
    assert modes.damping_ratio == ZETA


def test_long_form_peaks_agree_with_the_closed_form_modal_solution(metrics):
    assert metrics.attrs["deck_acceleration_method"].startswith("modal truncation")
    got = np.asarray(metrics["peak_deck_acceleration"].values, dtype=float)
    truth = independent_peaks(TRAIN, SPEED_KMH)
    assert np.all(np.abs(got / truth - 1.0) < 0.01), (got, truth)  # measured 0.1 %


def test_a_bridge_beyond_the_dense_solve_falls_back_to_the_filtered_midspan_and_says_why(monkeypatch):
    monkeypatch.setattr(deck_modal, "LONG_FORM_DOF_LIMIT", 50)
    deck_modal._long_form_mode_set.cache_clear()
    with pytest.raises(ValueError, match="free DOFs, more than the 50"):
        deck_modal.long_form_mode_set(BRIDGE)
    sc = validate_scenario(
        {
            "bridge": BRIDGE,
            "train": {"vehicle": "moving-load", "hslm": TRAIN, "speed_kmh": SPEED_KMH},
            "solver": {"time_step": 2e-3, "output_every": 1},
        }
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        m = compute_metrics(svbi.simulate(sc))
    deck_modal._long_form_mode_set.cache_clear()
    assert m.attrs["deck_acceleration_method"].startswith("absolute midspan")
    assert "no modal envelope: the bridge has" in m["peak_deck_acceleration"].attrs["long_name"]
