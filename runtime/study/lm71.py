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

A long-form bridge (continuous girders, piers, bearings) is loaded the same way on the whole
structure (:func:`long_form_deflections`): for every node of the deck, its influence line (by
Maxwell's reciprocity, the deflection line of a unit load at that node, from the run's assembled
stiffness, ground held) is loaded by the axle group at every 1/64 of the shortest span along the
whole bridge and by the distributed load wherever it deflects the node downwards (EN 1991-2
6.3.2(1): "applied ... where unfavourable"), outside 0.8 m of the outer axles; the largest
deflection over a span's nodes is that span's. Φ takes each girder's determinant length (EN 1991-2
Table 6.2, case 5.1 and 5.2): its span if simply supported, ``k L_m`` over ``n`` continuous spans
(``k`` = 1.2, 1.3, 1.4, 1.5 for 2, 3, 4, 5 or more spans, ``L_m`` their mean), at least its longest
span.

The same deflection with α = 1 is the δ of the passenger-comfort criterion of EN 1990 A2.4.4.3.2.
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
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


CONTINUOUS_LPHI_FACTOR = {2: 1.2, 3: 1.3, 4: 1.4}
"""EN 1991-2 Table 6.2 case 5.2: LΦ = k L_m for a girder continuous over n spans (k = 1.5 for 5+)."""


def determinant_length(spans: tuple[float, ...]) -> float:
    """EN 1991-2 Table 6.2, cases 5.1 and 5.2: LΦ of a girder over ``spans`` (m)."""
    if len(spans) == 1:
        return float(spans[0])
    k = CONTINUOUS_LPHI_FACTOR.get(len(spans), 1.5)
    return max(k * float(np.mean(spans)), float(max(spans)))


@dataclass(frozen=True)
class SpanDeflections:
    """LM71's static deflection of every span of a long-form bridge (α = 1, without Φ)."""

    deflection: np.ndarray
    """Largest deflection (m, downwards positive) over each span's nodes."""
    span_length: np.ndarray
    determinant_length: np.ndarray
    """LΦ of the girder each span belongs to (m)."""
    continuous_spans: np.ndarray
    """How many spans the girder of each span is continuous over (1: simply supported)."""


def long_form_deflections(bridge: Mapping[str, Any]) -> SpanDeflections:
    """LM71 on a long-form ``[bridge]`` (module docstring); cached per bridge table."""
    return _long_form_deflections(json.dumps(bridge, sort_keys=True, default=str))


@functools.lru_cache(maxsize=16)
def _long_form_deflections(key: str) -> SpanDeflections:
    import scipy.sparse.linalg as spla  # noqa: PLC0415 - only for a long form's check

    from .deck_modal import deck_values, long_form_bridge  # noqa: PLC0415 - not needed above

    b = long_form_bridge(json.loads(key))
    free = b.free_global
    K = b.K_global.tocsc()
    lu = spla.splu(K[free][:, free].tocsc())
    ne = b.elements
    nodes = np.concatenate([b.global_dof[s][1::3] for s in range(b.spans)])  # deck w, span by span
    rhs = np.zeros((b.nglobal, nodes.size))
    rhs[nodes, np.arange(nodes.size)] = 1.0
    G = np.zeros((b.nglobal, nodes.size))
    G[free] = lu.solve(rhs[free])  # column j: the deflection line of a unit upward load at node j

    def eta(x: np.ndarray) -> np.ndarray:
        """Downward deflection of every node per unit downward load at ``x`` (points x nodes)."""
        return deck_values(b, x, G, include_end=True)

    gx, gw = np.polynomial.legendre.leggauss(4)
    edges = np.concatenate(
        [b.span_starts[s] + b.span_element_length[s] * np.arange(ne) for s in range(b.spans)]
    )
    edges = np.append(edges, b.length)

    def udl_from_start(x: np.ndarray) -> np.ndarray:
        """∫_0^x q max(η, 0) dx for every node (points x nodes): whole elements, then the part of the
        element ``x`` falls in, each by 4-point Gauss."""
        lo_e = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, edges.size - 2)
        whole = np.concatenate([np.zeros((1, nodes.size)), np.cumsum(element_integrals, axis=0)])[lo_e]
        a, c = edges[lo_e], np.clip(x, 0.0, b.length)
        pts = 0.5 * (a + c)[:, None] + 0.5 * (c - a)[:, None] * gx[None, :]
        vals = np.maximum(eta(pts.ravel()), 0.0).reshape(x.size, gx.size, nodes.size)
        return whole + LM71_UNIFORM * np.einsum("pgn,g,p->pn", vals, gw, 0.5 * (c - a))

    mids = 0.5 * (edges[:-1] + edges[1:])
    halves = 0.5 * np.diff(edges)
    pts = mids[:, None] + halves[:, None] * gx[None, :]
    vals = np.maximum(eta(pts.ravel()), 0.0).reshape(mids.size, gx.size, nodes.size)
    element_integrals = LM71_UNIFORM * np.einsum("egn,g,e->en", vals, gw, halves)
    total = element_integrals.sum(axis=0)
    half = 1.5 * LM71_SPACING + LM71_CLEAR
    reach = b.length + 3.0 * LM71_SPACING  # the group's centre from its first axle on to its last off
    count = int(np.ceil(reach * GROUP_POSITIONS / float(b.span_lengths.min()))) + 1
    centres = np.linspace(-1.5 * LM71_SPACING, b.length + 1.5 * LM71_SPACING, count)  # <= L_min / 64 apart
    best = np.zeros(nodes.size)
    for chunk in np.array_split(centres, max(1, centres.size // 64)):
        axles = (chunk[:, None] + LM71_SPACING * np.array([-1.5, -0.5, 0.5, 1.5])[None, :]).ravel()
        on_deck = (axles >= 0.0) & (axles <= b.length)
        group = LM71_AXLE * (eta(np.where(on_deck, axles, 0.0)) * on_deck[:, None]).reshape(chunk.size, 4, -1)
        window = udl_from_start(chunk + half) - udl_from_start(chunk - half)
        best = np.maximum(best, (group.sum(axis=1) + total - window).max(axis=0))
    per_span = best.reshape(b.spans, ne + 1).max(axis=1)
    girder_of = b.span_girder
    lphi = np.array([determinant_length(b.girders[g].spans) for g in girder_of])
    continuous = np.array([len(b.girders[g].spans) for g in girder_of])
    return SpanDeflections(per_span, b.span_lengths.copy(), lphi, continuous)
