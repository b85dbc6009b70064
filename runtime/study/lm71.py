"""The static deflection EN 1990 A2.4.4.2.3(1) limits: Load Model 71 times its dynamic factor.

* LM71 (EN 1991-2 6.3.2): four axles of 250 kN, 1.6 m apart, and 80 kN/m on either side beyond
  0.8 m from the outer axles, over any length; multiplied by the classification factor α
  (6.3.2(3)P, 1 unless the line is classified otherwise) and by the dynamic factor Φ;
* Φ (EN 1991-2 6.4.5.2): Φ2 = 1.44 / (√LΦ - 0.2) + 0.82 (1.00 ... 1.67) for carefully maintained
  track, Φ3 = 2.16 / (√LΦ - 0.2) + 0.73 (1.00 ... 2.00) for standard maintenance (Φ3 where none is
  specified); LΦ the span of a simply supported girder (Table 6.2);
* the deflection: the span's generated stiffness matrix (supports held, as in a run), loaded by
  the group placed at every 1/64 of the span, the uniform load over the rest of the span; the
  largest nodal deflection.

The same deflection with α = 1 is the δ of the passenger-comfort criterion of EN 1990 A2.4.4.3.2.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..model.kernels import frame2d
from ..model.modes import span_matrices, span_support_dofs

LM71_AXLE = 250.0e3
"""N, each of the four concentrated loads of LM71."""
LM71_SPACING = 1.6
"""m between the four axles."""
LM71_UNIFORM = 80.0e3
"""N/m, the distributed load on either side of the axle group."""
LM71_CLEAR = 0.8
"""m from an outer axle to the start of the distributed load."""
GROUP_POSITIONS = 64
"""Positions of the axle group along the span (every L / 64) scanned for the largest deflection."""


def dynamic_factor(determinant_length: float, maintenance: str = "standard") -> float:
    """EN 1991-2 6.4.5.2: Φ2 (``careful``) or Φ3 (``standard``) for the determinant length LΦ (m)."""
    root = math.sqrt(determinant_length) - 0.2
    if maintenance == "careful":
        return min(max(1.44 / root + 0.82, 1.0), 1.67)
    if maintenance == "standard":
        return min(max(2.16 / root + 0.73, 1.0), 2.0)
    raise ValueError(f"track maintenance {maintenance!r}: expected careful or standard")


def _consistent_load(length: float, elements: int, points: np.ndarray, forces: np.ndarray) -> np.ndarray:
    """Nodal load vector ``(u, w, theta)`` per node of point forces (N, downwards) at ``points``."""
    le = length / elements
    n0 = np.asarray(frame2d().shape_coefficients(le, 0.0)[0], dtype=float)
    f = np.zeros(3 * (elements + 1))
    s = np.asarray(points, dtype=float) / le
    e = np.clip(np.floor(s).astype(np.int64), 0, elements - 1)
    xi = s - e
    rows = np.stack([np.ones_like(xi), xi, xi * xi, xi**3], axis=-1) @ n0
    for k in range(xi.size):
        f[3 * e[k] : 3 * e[k] + 6] -= forces[k] * rows[k]  # z up, the load down
    return f


def lm71_deflection(bridge: Mapping[str, Any], alpha: float = 1.0) -> float:
    """Largest static deflection (m, downwards positive) of one simply supported span of the
    ``[bridge]`` shorthand under α LM71 (without Φ)."""
    return alpha * _deflection(
        float(bridge["span_length"]),
        int(bridge.get("elements_per_span", 16)),
        float(bridge["youngs_modulus"]),
        float(bridge["area"]),
        float(bridge["second_moment"]),
        float(bridge["mass_per_length"]),
    )


@functools.lru_cache(maxsize=64)
def _deflection(length: float, elements: int, e: float, area: float, inertia: float, mu: float) -> float:
    """LM71's largest deflection of one span (cached: every run of a study has the same bridge)."""
    _, k = span_matrices(length, elements, e, area, inertia, mu)
    free = np.setdiff1d(np.arange(k.shape[0]), span_support_dofs(elements))
    kff = k[np.ix_(free, free)]
    # Gauss-Legendre points for the distributed load (4 per element: exact for the cubic shapes)
    gx, gw = np.polynomial.legendre.leggauss(4)
    le = length / elements
    half = 1.5 * LM71_SPACING + LM71_CLEAR  # from the group's centre to the distributed load
    loads = []
    for c in np.linspace(0.0, length, GROUP_POSITIONS + 1):
        axles = c + LM71_SPACING * np.array([-1.5, -0.5, 0.5, 1.5])
        axles = axles[(axles >= 0.0) & (axles <= length)]
        pts, frc = [axles], [np.full(axles.size, LM71_AXLE)]
        for a, b in ((0.0, c - half), (c + half, length)):
            if b <= a:
                continue
            for e in range(elements):
                lo, hi = max(a, e * le), min(b, (e + 1) * le)
                if hi > lo:
                    pts.append(0.5 * (lo + hi) + 0.5 * (hi - lo) * gx)
                    frc.append(LM71_UNIFORM * 0.5 * (hi - lo) * gw)
        loads.append(_consistent_load(length, elements, np.concatenate(pts), np.concatenate(frc)))
    f = np.array(loads).T[free]
    u = np.linalg.solve(kff, f)
    w = np.zeros((k.shape[0], u.shape[1]))
    w[free] = u
    return float(np.max(-w[1::3]))
