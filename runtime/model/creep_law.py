"""Numeric creep forces for the NumPy backend (paper Eqs. 15-16), vectorised over wheels.

The law is the SymPy expression of :mod:`svbi.codegen.creep`, evaluated through its generated NumPy
kernels (``generated/frame2d/numpy_kernels.py``: ``creep_force``, ``kalker_f33`` and the split
``creep_split_coefficients`` / ``creep_split_force`` that the C loop links too); nothing is re-typed
here. This module adds the numbers: the
default material and geometry (:class:`CreepParameters`) and the two geometry-dependent
coefficients the symbolic law takes as parameters, computed rather than looked up by hand:

* the Hertz coefficients m, n, from the curvature ratio B/A by solving Hertz's equations with
  complete elliptic integrals (``scipy.special.ellipk/ellipe``, Timoshenko & Goodier 1970 §140,
  Johnson 1985 §4.2);
* Kalker's C11 at the ellipse ratio a/b = m/n and Poisson's ratio ν, interpolated in Kalker's
  table (Kalker 1990, Table E.3, the table used by CONTACT's ``linrol``): linear in the ratio,
  and quadratic in ν through the three tabulated ν = 0, 0.25, 0.5 applied to 1/C11, which is
  almost linear in ν (its narrow-ellipse limit is C11 = π² / (4 (1 - ν))).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .kernels import frame2d

# Kalker (1990), Table E.3, column C11 for ν = 0, 0.25, 0.5. Rows: g = 0.1, 0.2, ..., 1.0, where
# g = a/b for a <= b (first block) and g = b/a for a > b (second block); a is along the rolling
# direction.
_KALKER_G = np.linspace(0.1, 1.0, 10)
_KALKER_NU = (0.0, 0.25, 0.5)
_C11_A_LE_B = np.array(
    [
        [2.51, 3.31, 4.85],
        [2.59, 3.37, 4.81],
        [2.68, 3.44, 4.80],
        [2.78, 3.53, 4.82],
        [2.88, 3.62, 4.83],
        [2.98, 3.72, 4.91],
        [3.09, 3.81, 4.97],
        [3.19, 3.91, 5.05],
        [3.29, 4.01, 5.12],
        [3.40, 4.12, 5.20],
    ]
)
_C11_A_GT_B = np.array(  # rows g = b/a = 0.1 .. 1.0
    [
        [10.7, 11.7, 12.9],
        [6.96, 7.78, 8.82],
        [5.57, 6.34, 7.34],
        [4.84, 5.57, 6.57],
        [4.37, 5.10, 6.11],
        [4.06, 4.78, 5.80],
        [3.82, 4.54, 5.58],
        [3.65, 4.36, 5.42],
        [3.51, 4.22, 5.30],
        [3.40, 4.12, 5.20],
    ]
)


@lru_cache(maxsize=256)
def hertz_coefficients(curvature_x: float, curvature_y: float) -> tuple[float, float]:
    """Hertz coefficients (for the x semi-axis, for the y semi-axis) from the relative curvatures.

    With k = (short semi-axis)/(long semi-axis) and e² = 1 - k², Hertz's conditions are
    ``B/A = (E(e)/k² - K(e)) / (K(e) - E(e))`` (B the larger curvature), ``m³ = 2E(e)/(π k²)``,
    ``n³ = 2E(e) k/π``; the long semi-axis (coefficient m) lies along the smaller curvature.
    Remembered per pair of curvatures (a 3D run's set-up asks for the same pair for every wheel).
    """
    if not (curvature_x > 0.0 and curvature_y > 0.0):
        raise ValueError(f"Hertz contact needs positive curvatures (got {curvature_x}, {curvature_y})")
    small, large = sorted((curvature_x, curvature_y))
    ratio = large / small
    if ratio - 1.0 < 1e-12:
        return 1.0, 1.0
    from scipy.special import ellipe, ellipk  # 0.02 s: a run without creep does without it

    def mismatch(e2: float) -> float:
        k_, e_ = ellipk(e2), ellipe(e2)
        return (e_ / (1.0 - e2) - k_) / (k_ - e_) - ratio

    # The mismatch rises monotonically from 1 - ratio < 0 (a circle) to +inf (e -> 1): bisection to
    # adjacent doubles, exact to the last bit of e². Not scipy.optimize.brentq: importing
    # scipy.optimize costs 0.14 s of every fresh `svbi run` for this one root.
    lo, hi = 1e-14, 1.0 - 1e-16
    for _ in range(2000):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if mismatch(mid) < 0.0:
            lo = mid
        else:
            hi = mid
    e2 = 0.5 * (lo + hi)
    k2 = 1.0 - e2
    m = (2.0 * ellipe(e2) / (math.pi * k2)) ** (1.0 / 3.0)
    n = (2.0 * ellipe(e2) * math.sqrt(k2) / math.pi) ** (1.0 / 3.0)
    return (m, n) if curvature_x <= curvature_y else (n, m)


def kalker_c11(a_over_b: float, nu: float) -> float:
    """Kalker's C11 for an ellipse with semi-axis ratio a/b (a along x) and Poisson's ratio ν."""
    if not 0.0 <= nu <= 0.5:
        raise ValueError(f"Poisson's ratio {nu} outside Kalker's table (0 to 0.5)")
    if a_over_b <= 1.0:
        g, table = a_over_b, _C11_A_LE_B
    else:
        g, table = 1.0 / a_over_b, _C11_A_GT_B
    if g < _KALKER_G[0] - 1e-12:
        raise ValueError(
            f"contact ellipse ratio a/b = {a_over_b:.4g} outside Kalker's table (0.1 to 10); "
            "check the wheel and rail radii"
        )
    by_nu = [np.interp(g, _KALKER_G, table[:, j]) for j in range(3)]
    n0, n1, n2 = _KALKER_NU
    lagrange = (
        (nu - n1) * (nu - n2) / ((n0 - n1) * (n0 - n2)),
        (nu - n0) * (nu - n2) / ((n1 - n0) * (n1 - n2)),
        (nu - n0) * (nu - n1) / ((n2 - n0) * (n2 - n1)),
    )
    return 1.0 / sum(w / c for w, c in zip(lagrange, by_nu, strict=True))


@dataclass(frozen=True)
class CreepParameters:
    """Material and geometry of the wheel-rail contact (all values assumed, none from the paper).

    Defaults: steel E = 210 GPa, ν = 0.3; wheel rolling radius 0.4575 m (assumed, typical of Chinese
    high-speed EMUs); rail head transverse radius 0.3 m (the 300 mm crown radius of
    60E1/UIC60 rail); friction coefficient 0.3 (dry rail).
    """

    youngs_modulus: float = 2.1e11
    poisson_ratio: float = 0.3
    wheel_radius: float = 0.4575
    rail_head_radius: float = 0.3
    friction: float = 0.3

    def __post_init__(self) -> None:
        for name in ("youngs_modulus", "wheel_radius", "rail_head_radius", "friction"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"creep parameter {name} must be positive (got {value})")
        if not 0.0 <= self.poisson_ratio <= 0.5:
            raise ValueError(f"creep parameter poisson_ratio must be in [0, 0.5] (got {self.poisson_ratio})")

    @property
    def hertz(self) -> tuple[float, float]:
        """Hertz coefficients (m for a, n for b) of this geometry."""
        return hertz_coefficients(0.5 / self.wheel_radius, 0.5 / self.rail_head_radius)

    @property
    def c11(self) -> float:
        """Kalker's C11 of this geometry and material."""
        m, n = self.hertz
        return kalker_c11(m / n, self.poisson_ratio)

    def named_values(self) -> dict[str, float]:
        """Numeric values of the law's parameters by symbol name (``svbi.codegen.creep.PARAMETERS``)."""
        m, n = self.hertz
        return {
            "E_wr": self.youngs_modulus,
            "nu_wr": self.poisson_ratio,
            "R_wheel": self.wheel_radius,
            "R_rail": self.rail_head_radius,
            "hertz_m": m,
            "hertz_n": n,
            "kalker_c11": self.c11,
            "mu_f": self.friction,
        }

    def values(self) -> dict[Any, float]:
        """Numeric values keyed by the symbols of ``svbi.codegen.creep`` (imports SymPy: for tests
        and derivations, not for a run)."""
        # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
        from ...codegen import creep as law

        named = self.named_values()
        return {s: named[s.name] for s in law.PARAMETERS}

    def vector(self) -> tuple[float, ...]:
        """The parameter values in the kernels' ``creep`` input order (``PARAMETERS``)."""
        named = self.named_values()
        return tuple(named[name] for name in frame2d().DATA["creep_parameters"])


def _evaluate(name: str, creepage: ArrayLike, normal_load: ArrayLike, params: CreepParameters) -> NDArray:
    xi = np.asarray(creepage, dtype=float)
    n = np.asarray(normal_load, dtype=float)
    xi, n = np.broadcast_arrays(xi, n)
    loaded = n > 0.0
    # The unloaded branch is 0, but NumPy evaluates every branch: keep N^(1/3) real there.
    safe_n = np.where(loaded, n, 1.0)
    kernels = frame2d()
    with np.errstate(divide="ignore", invalid="ignore"):
        if name == "f33":
            out = kernels.kalker_f33(safe_n, params.vector())
        else:
            force, slope = kernels.creep_force(xi, safe_n, params.vector())
            out = force if name == "force" else slope
    return np.where(loaded, np.broadcast_to(out, xi.shape), 0.0)


def creep_force(
    creepage: ArrayLike, normal_load: ArrayLike, params: CreepParameters | None = None
) -> NDArray[np.float64]:
    """Longitudinal creep force F_x (N) of each wheel, Eq. (15) with saturation (broadcast)."""
    return _evaluate("force", creepage, normal_load, params or CreepParameters())


def creep_force_derivative(
    creepage: ArrayLike, normal_load: ArrayLike, params: CreepParameters | None = None
) -> NDArray[np.float64]:
    """dF_x/dξ (N) of each wheel: the tangent the Newmark step can use to linearise the law."""
    return _evaluate("slope", creepage, normal_load, params or CreepParameters())


def kalker_coefficient(normal_load: ArrayLike, params: CreepParameters | None = None) -> NDArray[np.float64]:
    """Kalker's f33 = G a b C11 (N) under each wheel's normal load (0 out of contact)."""
    n = np.asarray(normal_load, dtype=float)
    return _evaluate("f33", np.zeros_like(n), n, params or CreepParameters())


class CreepLaw:
    """The creep law with one parameter set, for the time loop (one call per step).

    The law is split (``svbi.codegen.creep.split_creep_force``) into coefficients that depend on the
    parameters only, computed once here by the generated ``creep_split_coefficients``, and the
    per-step ``creep_split_force(ξ, N, c, ∛N)``: the same two generated functions as the C loop's; the
    Hertz and Kalker coefficients are computed once.
    """

    def __init__(self, params: CreepParameters | None = None) -> None:
        self.params = params or CreepParameters()
        kernels = frame2d()
        self._vector = self.params.vector()
        self.coefficients = np.asarray(kernels.creep_split_coefficients(self._vector), dtype=np.float64)
        self._force = kernels.creep_split_force
        self._f33 = kernels.kalker_f33

    def force(self, creepage: NDArray[np.float64], normal_load: NDArray[np.float64]) -> NDArray[np.float64]:
        """F_x (N), the force on the wheel (opposite to the slip): 0 where N <= 0."""
        loaded = normal_load > 0.0
        safe_n = np.where(loaded, normal_load, 1.0)  # every branch is evaluated: keep N^(1/3) real
        with np.errstate(divide="ignore", invalid="ignore"):
            out = self._force(creepage, safe_n, self.coefficients, np.cbrt(safe_n))
        return np.where(loaded, out, 0.0)

    def f33(self, normal_load: ArrayLike) -> NDArray[np.float64]:
        """Kalker's f33 (N) under each load (0 where N <= 0)."""
        n = np.asarray(normal_load, dtype=float)
        loaded = n > 0.0
        return np.where(loaded, self._f33(np.where(loaded, n, 1.0), self._vector), 0.0)
