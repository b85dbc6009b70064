"""Longitudinal creep force of a wheel (paper Section 2.4, Eqs. 15-16).

* **Creepage**, Eq. (16) with the rolling part removed (docs/architecture.md, conventions):
  ``ξ = (W_T^Vᵀ u̇_V - W_T^Bᵀ u̇_B - v W_T^B'ᵀ u_B - v r_T') / v``, built by :func:`creepage`
  from whatever direction columns and DOF vectors the caller gives.
* **Kalker's linear coefficient** ``f33 = G a b C11`` (Kalker 1967; 1990, Table E.3), with the
  semi-axes a (rolling direction x) and b (lateral) of the Hertz contact ellipse under the normal
  load N: the wheel has rolling radius ``R_wheel`` in x and is conical (flat) across; the rail is
  straight in x and has head radius ``R_rail`` across. The relative curvatures are therefore
  ``A = 1/(2 R_wheel)`` in x and ``B = 1/(2 R_rail)`` across, and (Timoshenko & Goodier 1970,
  §140; Johnson 1985, §4.2) for two bodies of the same steel

      a = m c,  b = n c,  c = (3 N (1 - ν²) / (2 E (A + B)))^(1/3).

  The Hertz coefficients m, n depend only on the ratio B/A through complete elliptic integrals.
  They stay parameters here (``hertz_m`` multiplies the rolling-direction semi-axis a, ``hertz_n``
  the lateral b) so that the kernel is exact and closed-form; their values are computed from the
  radii by solving Hertz's elliptic-integral equations (``svbi.runtime.model.creep_law.hertz_coefficients``).
  Likewise ``kalker_c11`` is a parameter whose value comes from Kalker's table at a/b = m/n and ν.
* **Saturation** (Shen, Hedrick & Elkins 1983): with ``F_lin = |f33 ξ|`` and
  ``β = F_lin / (μ N)``, the force magnitude is ``μN (β - β²/3 + β³/27)`` for β < 3 and μN
  beyond; the creep force is ``F_x = -ε f33 ξ`` with ``ε = F / F_lin``. ε is written as the
  polynomial ``1 - β/3 + β²/27`` (β < 3) and ``1/β`` (β >= 3), so the expression has no 0/0 at
  ξ = 0; F is C1 in ξ (its slope ``-f33 (1 - β/3)²`` vanishes at β = 3). A wheel out of contact
  (N <= 0) has no creep force.

Every branch is a ``sympy.Piecewise``, so the law is exact and can be emitted like any other kernel.
"""

from __future__ import annotations

from functools import cache

import sympy as sp

xi = sp.Symbol("xi_x", real=True)
"""Longitudinal creepage ξ (dimensionless)."""
normal_load = sp.Symbol("N_c", real=True)
"""Normal contact force N (N), positive in compression (docs/design.md section 2)."""
N_CBRT = sp.Symbol("N_cbrt", positive=True)
"""The cube root of the normal load: an input of the split law (:func:`split_creep_force`)."""
v = sp.Symbol("v", positive=True)
"""Train speed (m/s); the same symbol as in ``constraints``."""

youngs_modulus = sp.Symbol("E_wr", positive=True)
"""Young's modulus of wheel and rail steel (Pa)."""
poisson_ratio = sp.Symbol("nu_wr", positive=True)
"""Poisson's ratio of wheel and rail steel."""
wheel_radius = sp.Symbol("R_wheel", positive=True)
"""Wheel rolling radius (m): the curvature radius of the wheel in the rolling direction x."""
rail_radius = sp.Symbol("R_rail", positive=True)
"""Transverse radius of the rail head (m)."""
hertz_m = sp.Symbol("hertz_m", positive=True)
"""Hertz coefficient of the rolling-direction semi-axis a."""
hertz_n = sp.Symbol("hertz_n", positive=True)
"""Hertz coefficient of the lateral semi-axis b."""
kalker_c11 = sp.Symbol("kalker_c11", positive=True)
"""Kalker's longitudinal creepage coefficient C11 (depends on a/b and ν)."""
friction = sp.Symbol("mu_f", positive=True)
"""Wheel-rail friction coefficient μ."""

PARAMETERS = (
    youngs_modulus,
    poisson_ratio,
    wheel_radius,
    rail_radius,
    hertz_m,
    hertz_n,
    kalker_c11,
    friction,
)
"""Parameters of the creep law, in kernel input order."""


def creepage(
    w_t_vehicle: sp.Matrix,
    ud_vehicle: sp.Matrix,
    w_t_bridge: sp.Matrix,
    ud_bridge: sp.Matrix,
    w_t_bridge_dx: sp.Matrix,
    u_bridge: sp.Matrix,
    r_t_dx: sp.Matrix | sp.Expr,
    speed: sp.Expr = v,
) -> sp.Matrix:
    """Eq. (16): creepages of the wheels, one row per column of the direction matrices.

    ``w_t_vehicle`` is ``W_T^V`` (vehicle DOFs × wheels) and ``ud_vehicle`` the vehicle velocity
    column; ``w_t_bridge`` and ``w_t_bridge_dx`` are ``W_T^B`` and its x-derivative ``W_T^B'``
    (bridge or element DOFs × wheels), ``ud_bridge`` and ``u_bridge`` the matching velocity and
    displacement columns; ``r_t_dx`` is ``r_T'`` under each wheel (a column, or a scalar for one
    wheel). Row vectors (a single wheel's direction written as a 1 × n row) are accepted too.
    """

    def col(m: sp.Matrix, n: int) -> sp.Matrix:
        m = sp.Matrix(m)
        return m.T if m.rows == 1 and m.cols == n and n != 1 else m

    ud_v, ud_b, u_b = sp.Matrix(ud_vehicle), sp.Matrix(ud_bridge), sp.Matrix(u_bridge)
    wv = col(w_t_vehicle, ud_v.rows)
    wb = col(w_t_bridge, ud_b.rows)
    wbx = col(w_t_bridge_dx, u_b.rows)
    if not (wv.rows == ud_v.rows and wb.rows == ud_b.rows and wbx.rows == u_b.rows):
        raise ValueError(
            "creepage: direction matrices must have one row per DOF of the velocity/displacement "
            f"column (got W_T^V {wv.shape} for {ud_v.rows} DOFs, W_T^B {wb.shape} for {ud_b.rows}, "
            f"W_T^B' {wbx.shape} for {u_b.rows})"
        )
    nw = wv.cols
    if wb.cols != nw or wbx.cols != nw:
        raise ValueError(f"creepage: {nw} vehicle wheels but {wb.cols}/{wbx.cols} bridge columns")
    r1 = sp.Matrix([r_t_dx] * nw) if not isinstance(r_t_dx, sp.MatrixBase) else sp.Matrix(r_t_dx)
    if r1.shape != (nw, 1):
        raise ValueError(f"creepage: r_T' must be a column of {nw} entries (got {r1.shape})")
    return (wv.T * ud_v - wb.T * ud_b - speed * wbx.T * u_b - speed * r1) / speed


def curvatures() -> tuple[sp.Expr, sp.Expr]:
    """Relative curvatures (A in the rolling direction, B across), 1/m."""
    return 1 / (2 * wheel_radius), 1 / (2 * rail_radius)


def shear_modulus() -> sp.Expr:
    """G = E / (2 (1 + ν))."""
    return youngs_modulus / (2 * (1 + poisson_ratio))


def hertz_semi_axes(load: sp.Expr = normal_load) -> tuple[sp.Expr, sp.Expr]:
    """Semi-axes (a along x, b across) of the Hertz contact ellipse under normal load ``load``."""
    a_curv, b_curv = curvatures()
    c = (3 * load * (1 - poisson_ratio**2) / (2 * youngs_modulus * (a_curv + b_curv))) ** sp.Rational(1, 3)
    return hertz_m * c, hertz_n * c


def kalker_f33(load: sp.Expr = normal_load) -> sp.Expr:
    """Kalker's longitudinal creep coefficient f33 = G a b C11 (N)."""
    a, b = hertz_semi_axes(load)
    return shear_modulus() * a * b * kalker_c11


@cache
def creep_force() -> sp.Expr:
    """F_x(ξ, N): Eq. (15) with Shen-Hedrick-Elkins saturation; Piecewise, exact."""
    f33 = kalker_f33()
    beta = f33 * sp.Abs(xi) / (friction * normal_load)
    return sp.Piecewise(
        (sp.S.Zero, normal_load <= 0),
        (-f33 * xi * (1 - beta / 3 + beta**2 / 27), beta < 3),
        (-friction * normal_load * sp.sign(xi), True),
    )


@cache
def creep_force_derivative() -> sp.Expr:
    """dF_x/dξ: ``-f33 (1 - β/3)²`` below saturation, 0 beyond and out of contact."""
    f33 = kalker_f33()
    beta = f33 * sp.Abs(xi) / (friction * normal_load)
    return sp.Piecewise(
        (sp.S.Zero, normal_load <= 0),
        (-f33 * (1 - beta / 3) ** 2, beta < 3),
        (sp.S.Zero, True),
    )


def she_factor(beta: sp.Expr) -> sp.Expr:
    """Shen-Hedrick-Elkins ε(β) = F / F_lin at ``β = F_lin / (μN)``: ``1 - β/3 + β²/27`` below 3,
    ``1/β`` beyond (also used by the 3D law, ``svbi.codegen.creep3d``)."""
    return sp.Piecewise((1 - beta / 3 + beta**2 / 27, beta < 3), (1 / beta, True))


def saturation_coefficient() -> sp.Expr:
    """ε = F / F_lin as a Piecewise in ξ and N (1 at ξ = 0)."""
    f33 = kalker_f33()
    beta = f33 * sp.Abs(xi) / (friction * normal_load)
    return she_factor(beta)


@cache
def split_creep_force() -> tuple[tuple[sp.Expr, ...], sp.Expr, tuple[sp.Symbol, ...]]:
    """The creep law split for the time loop: per-run coefficients and a per-step remainder.

    The law's parameters are fixed for a run, so every subexpression that depends on them only
    (``E^(1/3)``, ``(1/(2 R_wheel) + 1/(2 R_rail))^(-2/3)``, ...) becomes a coefficient ``c_k``,
    computed once per wheel; what is left depends on the creepage, the normal load and the
    ``c_k``. Powers of products are separated first (``(N (1 - nu^2))^(2/3)`` ->
    ``N^(2/3) (1 - nu^2)^(2/3)``: N > 0 wherever the law is used, and the parameters are
    positive), so that only the powers of N remain per step; those are powers of :data:`N_CBRT`
    (``N^(2/3) = N_cbrt^2``), an input, so a step takes one cube root instead of two ``pow``. The
    parameter-only factors of a product (numbers included) form one coefficient, so no product of
    constants is left per step. Returns the coefficient expressions, the reduced law and the
    coefficient symbols.
    """
    params = set(PARAMETERS)
    expanded = sp.expand_power_base(creep_force(), force=True)
    expanded = expanded.replace(
        lambda e: e.is_Pow and e.base == normal_load and e.exp.is_Rational and e.exp.q == 3,
        lambda e: N_CBRT ** (3 * e.exp),
    )
    coefs: dict[sp.Expr, sp.Symbol] = {}

    def constant(e: sp.Expr) -> bool:
        return e.free_symbols <= params

    def coefficient(e: sp.Expr) -> sp.Symbol:
        if e not in coefs:
            coefs[e] = sp.Symbol(f"creep_c{len(coefs)}", real=True)
        return coefs[e]

    def split(e: sp.Expr) -> sp.Expr:
        free = e.free_symbols
        if free and free <= params and not e.is_Number:  # a parameter itself is a coefficient too
            return coefficient(e)
        if e.is_Mul:
            fixed = [a for a in e.args if constant(a)]
            rest = [split(a) for a in e.args if not constant(a)]
            if len(fixed) > 1 or (fixed and not fixed[0].is_Number):
                return sp.Mul(coefficient(sp.Mul(*fixed)), *rest, evaluate=False)
            return sp.Mul(*fixed, *rest)
        if not e.args or e.is_Symbol:
            return e
        return e.func(*[split(a) for a in e.args])

    reduced = split(expanded)
    return tuple(coefs), reduced, tuple(coefs.values())
