"""Kalker's linear creep coefficients C11, C22, C23 for the lateral contact of the 3D model.

A building block of the 3D model, not yet used by runs (docs/three-d.md). Kalker (1990), Table E.3,
as in the CONTACT code's ``linrol``: rows ``g = 0.1, 0.2, ..., 1.0`` with ``g = a/b`` for ``a <= b`` and
``g = b/a`` for ``a > b`` (``a`` the semi-axis along the rolling direction), columns Poisson's ratio
``nu = 0, 0.25, 0.5``. Between rows the coefficients are interpolated linearly in ``g``; between columns
``1/C`` quadratically in ``nu`` (as CONTACT does), exactly as :func:`svbi.runtime.model.creep_law.kalker_c11`
does for C11. The creep coefficients of the wheelset model (``svbi.codegen.wheelset3d``) are
``f11 = G a b C11``, ``f22 = G a b C22``, ``f23 = G (a b)^(3/2) C23``. C33 (spin) is not carried.
"""

from __future__ import annotations

import numpy as np

from .creep_law import kalker_c11

_G = np.linspace(0.1, 1.0, 10)
_NU = (0.0, 0.25, 0.5)
_C22_A_LE_B = np.array(
    [
        [2.51, 2.52, 2.53],
        [2.59, 2.63, 2.66],
        [2.68, 2.75, 2.81],
        [2.78, 2.88, 2.98],
        [2.88, 3.01, 3.14],
        [2.98, 3.14, 3.31],
        [3.09, 3.28, 3.48],
        [3.19, 3.41, 3.65],
        [3.29, 3.54, 3.82],
        [3.40, 3.67, 3.98],
    ]
)
_C22_A_GT_B = np.array(
    [
        [10.7, 12.8, 16.0],
        [6.96, 8.14, 9.79],
        [5.57, 6.40, 7.51],
        [4.84, 5.48, 6.31],
        [4.37, 4.90, 5.56],
        [4.06, 4.50, 5.04],
        [3.82, 4.21, 4.67],
        [3.65, 3.99, 4.39],
        [3.51, 3.81, 4.16],
        [3.40, 3.67, 3.98],
    ]
)
_C23_A_LE_B = np.array(
    [
        [0.334, 0.473, 0.731],
        [0.483, 0.603, 0.809],
        [0.607, 0.715, 0.889],
        [0.720, 0.823, 0.977],
        [0.827, 0.929, 1.07],
        [0.930, 1.03, 1.18],
        [1.03, 1.14, 1.29],
        [1.13, 1.25, 1.40],  # 1.25 at nu = 0.25: some copies carry a typo 1.15 (the row is monotone)
        [1.23, 1.36, 1.51],
        [1.33, 1.47, 1.63],
    ]
)
_C23_A_GT_B = np.array(
    [
        [12.2, 14.6, 18.0],
        [5.72, 6.63, 7.89],
        [3.79, 4.32, 5.01],
        [2.88, 3.24, 3.70],
        [2.35, 2.62, 2.96],
        [2.01, 2.23, 2.50],
        [1.76, 1.95, 2.18],
        [1.58, 1.75, 1.94],
        [1.44, 1.59, 1.77],
        [1.33, 1.47, 1.63],
    ]
)


def _interpolate(a_over_b: float, nu: float, small: np.ndarray, large: np.ndarray) -> float:
    if not 0.0 <= nu <= 0.5:
        raise ValueError(f"Poisson's ratio {nu} outside Kalker's table (0 to 0.5)")
    if not a_over_b > 0:
        raise ValueError(f"contact ellipse ratio a/b must be positive, got {a_over_b!r}")
    g, table = (a_over_b, small) if a_over_b <= 1.0 else (1.0 / a_over_b, large)
    if g < _G[0] - 1e-12:
        raise ValueError(f"contact ellipse ratio a/b = {a_over_b:.4g} outside Kalker's table (0.1 to 10)")
    by_nu = [float(np.interp(g, _G, table[:, j])) for j in range(3)]
    n0, n1, n2 = _NU
    weights = (
        (nu - n1) * (nu - n2) / ((n0 - n1) * (n0 - n2)),
        (nu - n0) * (nu - n2) / ((n1 - n0) * (n1 - n2)),
        (nu - n0) * (nu - n1) / ((n2 - n0) * (n2 - n1)),
    )
    return 1.0 / sum(w / c for w, c in zip(weights, by_nu, strict=True))


def kalker_coefficients(a_over_b: float, nu: float) -> tuple[float, float, float]:
    """``(C11, C22, C23)`` for a contact ellipse of semi-axis ratio ``a/b`` and Poisson's ratio ``nu``."""
    return (
        kalker_c11(a_over_b, nu),
        _interpolate(a_over_b, nu, _C22_A_LE_B, _C22_A_GT_B),
        _interpolate(a_over_b, nu, _C23_A_LE_B, _C23_A_GT_B),
    )
