"""LM71's static deflection on a long-form bridge: the influence line of every deck node loaded by the
axle group where it is worst and by the distributed load where it deflects the node downwards
(EN 1991-2 6.3.2: "where unfavourable").

The truth is written here, independently of svbi: a girder continuous over two equal spans by the
force method (the simply supported beam of length 2L with the pier's reaction chosen so that the
pier does not move), its influence lines in closed form, the load scanned on a fine grid.
"""

from __future__ import annotations

import numpy as np
import pytest

from svbi.runtime.study import lm71

L = 20.0
EI = 35.5e9 * 6.58
BRIDGE = {
    "mass_per_length": 22.4e3,
    "youngs_modulus": 35.5e9,
    "area": 8.63,
    "second_moment": 6.58,
    "damping_ratio": 0.01,
    "elements_per_span": 16,
    "girders": [{"spans": [L, L]}],
}


def simply_supported(x: np.ndarray, a: np.ndarray, length: float) -> np.ndarray:
    """Downward deflection at ``x`` of a simply supported beam under a unit downward load at ``a``."""
    x, a = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(a, dtype=float))
    lo, hi = np.minimum(x, a), np.maximum(x, a)
    return lo * (length - hi) * (2 * length * hi - hi**2 - lo**2) / (6 * EI * length)


def continuous(x: np.ndarray, a: np.ndarray) -> np.ndarray:
    """The same over two spans with the pier at ``L`` held (force method)."""
    reaction = simply_supported(L, a, 2 * L) / simply_supported(L, L, 2 * L)
    return simply_supported(x, a, 2 * L) - reaction * simply_supported(x, L, 2 * L)


def worst_deflection(node_x: float) -> float:
    grid = np.linspace(0.0, 2 * L, 40001)
    eta = continuous(node_x, grid)
    q = lm71.LM71_UNIFORM * np.maximum(eta, 0.0)
    best = 0.0
    for c in np.arange(-2.4, 2 * L + 2.4, 0.02):
        axles = c + 1.6 * np.array([-1.5, -0.5, 0.5, 1.5])
        axles = axles[(axles >= 0.0) & (axles <= 2 * L)]
        outside = np.abs(grid - c) >= 3.2
        value = lm71.LM71_AXLE * continuous(node_x, axles).sum() + np.trapezoid(q * outside, grid)
        best = max(best, value)
    return best


def test_continuous_girder_deflection_against_the_force_method():
    got = lm71.long_form_deflections(BRIDGE)
    nodes = np.linspace(0.0, L, 17)
    truth = max(worst_deflection(x) for x in nodes[6:11])  # the worst node is near 0.42 L
    assert got.deflection.shape == (2,)
    assert got.deflection[0] == pytest.approx(got.deflection[1], rel=1e-9)  # symmetric girder
    # the scans' grids differ (L/64 against 0.02 m, a trapezoid of 40,000 points): 0.1 % covers them
    assert got.deflection[0] == pytest.approx(truth, rel=1e-3), (got.deflection, truth)


def test_unfavourable_parts_only():
    """Loading the whole girder would lift the loaded span: the other span's load is left off."""
    got = lm71.long_form_deflections(BRIDGE).deflection[0]
    grid = np.linspace(0.0, 2 * L, 40001)
    node = 0.4375 * L
    everywhere = lm71.LM71_UNIFORM * np.trapezoid(continuous(node, grid), grid)
    unfavourable = lm71.LM71_UNIFORM * np.trapezoid(np.maximum(continuous(node, grid), 0.0), grid)
    assert unfavourable > 1.1 * everywhere  # the far span's load lifts the node by 10 % and more
    assert got > everywhere


def test_simply_supported_long_form_is_the_shorthand():
    single = {**BRIDGE, "girders": [{"spans": [32.0]}]}
    shorthand = {k: v for k, v in BRIDGE.items() if k != "girders"} | {"span_length": 32.0}
    got = lm71.long_form_deflections(single)
    assert got.deflection[0] == pytest.approx(lm71.lm71_deflection(shorthand), rel=1e-4)
    assert got.determinant_length[0] == 32.0


@pytest.mark.parametrize(
    ("spans", "expected"),
    [((20.0,), 20.0), ((20.0, 20.0), 24.0), ((20.0, 30.0, 20.0), 30.333333333333336), ((10.0,) * 6, 15.0)],
)
def test_determinant_length_of_continuous_girders(spans, expected):
    # EN 1991-2 Table 6.2 case 5.2: k = 1.2, 1.3, 1.4, 1.5 for 2, 3, 4, >= 5 spans, at least the longest
    assert lm71.determinant_length(spans) == pytest.approx(expected)


def test_check_rows_of_a_continuous_girder():
    import math
    import warnings

    import svbi
    from svbi.runtime.study.en1990 import CheckOptions, en1990_checks
    from svbi.runtime.study.metrics import compute_metrics

    table = {
        "bridge": BRIDGE,
        "train": {"vehicle": "moving-load", "hslm": "A1", "speed_kmh": 160.0},
        "solver": {"time_step": 2e-3, "output_every": 1},
    }
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        m = compute_metrics(svbi.simulate(table))
    delta = lm71.long_form_deflections(BRIDGE).deflection
    phi3 = 2.16 / (math.sqrt(1.2 * L) - 0.2) + 0.73  # L_Phi = 1.2 L_m over two continuous spans
    opts = CheckOptions(alpha=1.33, comfort="very-good", comfort_l_over_delta=2000.0)
    rows = {r.name: r for r in en1990_checks(m, moving_load=True, table=table, options=opts)}
    row = rows["vertical deflection, LM71 x alpha x Phi (A2.4.4.2.3(1))"]
    assert row.value == pytest.approx(1.33 * phi3 * delta.max()) and row.limit == pytest.approx(L / 600)
    assert row.where in ("span 1", "span 2") and "L_Phi = 24 m" in row.note and row.passed is True
    comfort = rows["comfort, deflection delta/L (very-good, A2.4.4.3.2)"]
    # two continuous spans: Figure A2.3's L/δ x 0.7, / b_v (1.0 for very good)
    assert comfort.limit == pytest.approx(L / 1400.0) and comfort.value == pytest.approx(phi3 * delta.max())
