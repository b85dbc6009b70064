"""Piecewise polynomials as the solver's tables hold them, and Horner's rule on them.

The layout is ``scipy.interpolate.PPoly``'s: breaks ``x`` (n + 1) and coefficients ``c``
((k + 1) x n) of ``(x - x_i)^(k - m)``, so a ``CubicSpline`` is one too. The rail's quintic table
(``irregularity.quintic_hermite``) and a record's integrated displacement (``processing``) are built
here rather than as ``PPoly`` objects because importing ``scipy.interpolate`` (which imports
``scipy.optimize``) costs about 0.08 s of every fresh ``svbi run``, and a run with a spectral
profile and a record needs nothing else of it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

Triple = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]


class Pieces(Protocol):
    """A piecewise polynomial in ``scipy.interpolate.PPoly``'s layout: breaks ``x`` (n + 1) and
    coefficients ``c`` ((k + 1) x n) of ``(x - x_i)^(k - m)``. ``CubicSpline`` is one."""

    x: NDArray[np.float64]
    c: NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class PiecewisePolynomial:
    """A table the solver evaluates: breaks and coefficients (:class:`Pieces`), evaluated by
    :func:`horner` as the C loop does."""

    x: NDArray[np.float64]
    c: NDArray[np.float64]

    def __call__(self, x: ArrayLike, nu: int = 0) -> NDArray[np.float64]:
        """The value (``nu = 0``) or first or second derivative at x (inside the breaks)."""
        return horner(self, np.asarray(x, dtype=float))[nu]


def horner(pp: Pieces, x: NDArray[np.float64]) -> Triple:
    """Value, first and second derivative of a piecewise polynomial at x (inside its breaks).

    The piece is the one with ``x_i <= x < x_{i+1}`` (the last one at the right end); each value is
    Horner's rule in ``s = x - x_i`` on the coefficients ``c[m, i]`` of ``s^(k - m)`` and on their
    derivatives, the same arithmetic as the C loop's ``ppoly_eval``.
    """
    breaks, c = pp.x, pp.c
    k, n = c.shape[0] - 1, c.shape[1]
    i = np.clip(np.searchsorted(breaks, x, side="right") - 1, 0, n - 1)
    s = x - breaks[i]
    v0 = np.zeros_like(s)
    v1 = np.zeros_like(s)
    v2 = np.zeros_like(s)
    for m in range(k + 1):
        cm = c[m, i]
        v0 = v0 * s + cm
        if m < k:
            v1 = v1 * s + (k - m) * cm
        if m < k - 1:
            v2 = v2 * s + ((k - m) * (k - m - 1)) * cm
    return v0, v1, v2
