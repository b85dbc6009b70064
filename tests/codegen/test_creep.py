"""Creep law (paper Eqs. 15-16): Hertz ellipse, Kalker coefficient, Shen-Hedrick-Elkins saturation."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from svbi.codegen import creep as law
from svbi.runtime.model.creep_law import (
    CreepParameters,
    creep_force,
    creep_force_derivative,
    hertz_coefficients,
    kalker_c11,
    kalker_coefficient,
)

PARAMS = CreepParameters()


@pytest.mark.parametrize(
    ("theta_deg", "m", "n"),
    # Timoshenko & Goodier (1970), Theory of Elasticity, §140 table of Hertz coefficients.
    [(30, 2.731, 0.493), (40, 2.136, 0.567), (50, 1.754, 0.641), (60, 1.486, 0.717), (80, 1.128, 0.893)],
)
def test_hertz_coefficients_match_timoshenko_table(theta_deg: float, m: float, n: float) -> None:
    cos_theta = math.cos(math.radians(theta_deg))  # cos θ = (B - A) / (A + B)
    small, large = 1.0 - cos_theta, 1.0 + cos_theta
    got_m, got_n = hertz_coefficients(small, large)  # long semi-axis along the smaller curvature
    assert got_m == pytest.approx(m, rel=3e-3) and got_n == pytest.approx(n, rel=3e-3)
    swapped = hertz_coefficients(large, small)
    assert swapped == pytest.approx((got_n, got_m), rel=1e-14)


def test_hertz_circular_contact_closed_form() -> None:
    """Equal radii: the ellipse is a circle, a³ = 3 N R / (4 E*) with E* = E / (2 (1 - ν²))."""
    radius, load = sp.symbols("R N", positive=True)
    a, b = law.hertz_semi_axes(load)
    sub = {law.wheel_radius: radius, law.rail_radius: radius, law.hertz_m: 1, law.hertz_n: 1}
    e_star = law.youngs_modulus / (2 * (1 - law.poisson_ratio**2))
    assert sp.simplify(a.subs(sub) ** 3 - 3 * load * radius / (4 * e_star)) == 0
    assert sp.simplify(a.subs(sub) - b.subs(sub)) == 0
    assert hertz_coefficients(2.0, 2.0) == (1.0, 1.0)


@pytest.mark.parametrize("nu", [0.0, 0.25, 0.3, 0.5])
def test_kalker_c11_narrow_ellipse_limit(nu: float) -> None:
    """For a/b -> 0 Kalker's C11 tends to π² / (4 (1 - ν)); at a/b = 0.1 the table is within 2 %."""
    assert kalker_c11(0.1, nu) == pytest.approx(math.pi**2 / (4 * (1 - nu)), rel=0.02)


def test_kalker_c11_trends_and_range() -> None:
    ratios = np.linspace(0.1, 10.0, 60)
    for nu in (0.0, 0.3):
        values = [kalker_c11(r, nu) for r in ratios]
        assert np.all(np.diff(values) > 0)  # a longer patch in the rolling direction creeps stiffer
    assert kalker_c11(1.0, 0.3) > kalker_c11(1.0, 0.25) > kalker_c11(1.0, 0.0)
    with pytest.raises(ValueError, match="outside Kalker's table"):
        kalker_c11(0.05, 0.3)


def test_f33_composition() -> None:
    """f33 = G a b C11 with the Hertz semi-axes written out here from their definition."""
    load = 70e3
    e, nu = PARAMS.youngs_modulus, PARAMS.poisson_ratio
    curv_sum = 0.5 / PARAMS.wheel_radius + 0.5 / PARAMS.rail_head_radius
    c = (3 * load * (1 - nu**2) / (2 * e * curv_sum)) ** (1 / 3)
    m, n = PARAMS.hertz
    expected = e / (2 * (1 + nu)) * (m * c) * (n * c) * PARAMS.c11
    assert float(kalker_coefficient(load)) == pytest.approx(expected, rel=1e-12)
    assert m > 1.0 > n  # rolling radius 0.4575 m > rail head 0.3 m: the ellipse is long along x


def test_small_creepage_is_linear_kalker() -> None:
    load = np.array([40e3, 70e3, 120e3])
    f33 = kalker_coefficient(load)
    xi = 1e-7
    np.testing.assert_allclose(creep_force(xi, load) / (-f33 * xi), 1.0, rtol=1e-4)
    np.testing.assert_allclose(creep_force_derivative(0.0, load), -f33, rtol=1e-14)


def test_large_creepage_saturates_at_mu_n() -> None:
    load = 70e3
    for xi in (0.05, 0.5, -0.05, -3.0):
        assert creep_force(xi, load) == pytest.approx(-math.copysign(PARAMS.friction * load, xi), rel=1e-14)
    # Continuous and C1 at β = 3.
    xi3 = 3 * PARAMS.friction * load / float(kalker_coefficient(load))
    below, above = creep_force([xi3 * (1 - 1e-9), xi3 * (1 + 1e-9)], load)
    assert below == pytest.approx(above, rel=1e-8)
    assert abs(creep_force_derivative(xi3 * (1 - 1e-6), load)) < 1e-9 * float(kalker_coefficient(load))


def test_creep_force_dissipates() -> None:
    """F·ξ <= 0: the creep force never feeds energy into the wheel-rail motion."""
    rng = np.random.default_rng(3)
    xi = np.concatenate([rng.normal(0, 1e-3, 2000), rng.normal(0, 0.1, 2000), np.linspace(-0.02, 0.02, 401)])
    load = np.concatenate([rng.uniform(-2e4, 2e5, 4000), np.full(401, 7e4)])
    force = creep_force(xi, load)
    assert np.all(force * xi <= 0.0)
    assert np.all(np.abs(force) <= PARAMS.friction * np.maximum(load, 0.0) * (1 + 1e-14))
    assert np.all(force[load <= 0.0] == 0.0)


def test_derivative_is_exact() -> None:
    """The closed-form slope equals SymPy's derivative of the force, and finite differences."""
    pos = sp.Symbol("p", positive=True)
    for sign in (1, -1):
        branch = law.creep_force().args[1][0].subs(law.xi, sign * pos)
        claimed = law.creep_force_derivative().args[1][0].subs(law.xi, sign * pos)
        assert sp.simplify(sp.diff(branch, pos) * sign - claimed) == 0
    xi = np.linspace(-0.01, 0.01, 101) + 1.3e-5
    h = 1e-9
    fd = (creep_force(xi + h, 70e3) - creep_force(xi - h, 70e3)) / (2 * h)
    np.testing.assert_allclose(
        creep_force_derivative(xi, 70e3), fd, atol=1e-5 * float(kalker_coefficient(7e4))
    )


def test_numpy_equals_sympy() -> None:
    values = PARAMS.values()
    force = law.creep_force().subs(values)
    slope = law.creep_force_derivative().subs(values)
    rng = np.random.default_rng(5)
    for xi, load in zip(rng.normal(0, 5e-3, 25), rng.uniform(-1e4, 1.5e5, 25), strict=True):
        point = {law.xi: sp.Float(xi, 30), law.normal_load: sp.Float(load, 30)}
        expected_f = float(force.subs(point).evalf(30))
        expected_s = float(slope.subs(point).evalf(30))
        assert float(creep_force(xi, load)) == pytest.approx(expected_f, rel=1e-12, abs=1e-9)
        assert float(creep_force_derivative(xi, load)) == pytest.approx(expected_s, rel=1e-12, abs=1e-6)


def test_creepage_builder() -> None:
    """Eq. (16) from matrices: one wheel, written out by hand for comparison."""
    z, th = sp.symbols("z_w theta_w", real=True)
    zd, thd = sp.symbols("zd_w thetad_w", real=True)
    ub = sp.Matrix(sp.symbols("u1 u2 u3", real=True))
    ubd = sp.Matrix(sp.symbols("ud1 ud2 ud3", real=True))
    radius, rx, h = sp.symbols("r_w r_x h", real=True)
    w_v = sp.Matrix([0, radius])  # contact point moves forward by radius * theta
    w_b = sp.Matrix([[1 - h, h, -h]])  # any row: given as 1 x 3
    w_bx = sp.Matrix([[2, -1, h]])
    xi = law.creepage(w_v, sp.Matrix([zd, thd]), w_b, ubd, w_bx, ub, rx)
    v = law.v
    by_hand = (
        radius * thd
        - ((1 - h) * ubd[0] + h * ubd[1] - h * ubd[2])
        - v * (2 * ub[0] - ub[1] + h * ub[2])
        - v * rx
    ) / v
    assert xi.shape == (1, 1)
    assert sp.simplify(xi[0, 0] - by_hand) == 0
    with pytest.raises(ValueError, match="one row per DOF"):
        law.creepage(sp.Matrix([1, 2, 3]), sp.Matrix([zd, thd]), w_b, ubd, w_bx, ub, rx)
