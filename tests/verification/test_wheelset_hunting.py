"""The derived coned wheelset (codegen.wheelset3d) against closed forms: Klingel's kinematic
wavelength, and the critical speed and hunting frequency of a wheelset on lateral and yaw springs
from the Routh-Hurwitz criterion of the textbook equations, written out here."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from svbi.codegen import wheelset3d as ws
from svbi.runtime.model.kalker3d import kalker_coefficients

AB = 5.5e-3**2  # contact ellipse a = b = 5.5 mm: Kalker's table at g = 1, nu = 0.25
G_STEEL = 80e9
C11, C22, C23 = kalker_coefficients(1.0, 0.25)
VALUES = {
    "m_w": 1813.0,
    "I_wz": 1120.0,
    "r0": 0.46,
    "b": 0.75,
    "lam": 0.1,
    "delta0": 0.1,
    "W": 109e3,
    "f11": G_STEEL * AB * C11,
    "f22": G_STEEL * AB * C22,
    "f23": G_STEEL * AB**1.5 * C23,
    "k_y": 0.5e6,
    "k_psi": 2.0e6,
}


def matrices(speed: float, values: dict[str, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    model = ws.derive_wheelset()
    subs = {s: values[s.name] for s in ws.PARAMETERS}
    subs[ws.v] = speed

    def arr(m: sp.Matrix) -> np.ndarray:
        return np.array(m.subs(subs).tolist(), dtype=float)

    return arr(model.mass_matrix), arr(model.damping_matrix), arr(model.stiffness_matrix)


def state_matrix(speed: float, values: dict[str, float]) -> np.ndarray:
    m, c, k = matrices(speed, values)
    mi = np.linalg.inv(m)
    return np.block([[np.zeros((2, 2)), np.eye(2)], [-mi @ k, -mi @ c]])


@pytest.mark.parametrize("conicity", [0.05, 0.1, 0.15])
def test_klingel_wavelength(conicity: float) -> None:
    r0, b, speed = 0.46, 0.75, 40.0
    kin = ws.derive_wheelset().kinematic_matrix
    a = np.array(kin.subs({ws.r0: r0, ws.b: b, ws.lam: conicity, ws.v: speed}).tolist(), dtype=float)
    eig = np.linalg.eigvals(a)
    assert np.abs(eig.real).max() < 1e-12  # undamped: the free coned wheelset sways for ever
    wavelength = 2 * math.pi * speed / np.abs(eig.imag).max()
    assert wavelength == pytest.approx(2 * math.pi * math.sqrt(r0 * b / conicity), rel=1e-12)


def test_creepages_of_the_cone() -> None:
    # xi_x = -/+ (lam y / r0 + b psi' / v), xi_y = y'/v - psi, spin -/+ delta / r0 + psi' / v
    left, right = ws.contacts()
    y, psi, yd, pd, v = ws.y, ws.psi, ws.ydot, ws.psidot, ws.v
    lam, r0, b, d0 = ws.lam, ws.r0, ws.b, ws.delta0
    assert sp.simplify(left.xi_x - (-lam * y / r0 - b * pd / v)) == 0
    assert sp.simplify(right.xi_x - (lam * y / r0 + b * pd / v)) == 0
    for c in (left, right):
        assert sp.simplify(c.xi_y - (yd / v - psi)) == 0
    assert sp.simplify(left.xi_sp - (pd / v - (d0 + lam * y / b) / r0)) == 0
    assert sp.simplify(right.xi_sp - (pd / v + (d0 - lam * y / b) / r0)) == 0


def textbook_polynomial(speed: float, p: dict[str, float]) -> np.ndarray:
    """Characteristic polynomial (highest power first) of the linear wheelset of Wickens with
    Kalker's f11, f22, f23, the gravitational stiffness W lam / b and yaw term -W b delta0:

        m y'' + 2 f22/v y' + 2 f23/v psi' + (k_y + W lam/b - 2 f23 lam/(b r0)) y - 2 f22 psi = 0
        I psi'' - 2 f23/v y' + 2 f11 b^2/v psi' + 2 f11 b lam/r0 y + (k_psi + 2 f23 - W b delta0) psi = 0
    """
    m, i, v = p["m_w"], p["I_wz"], speed
    f11, f22, f23, lam, b, r0 = p["f11"], p["f22"], p["f23"], p["lam"], p["b"], p["r0"]
    a11 = [m, 2 * f22 / v, p["k_y"] + p["W"] * lam / b - 2 * f23 * lam / (b * r0)]
    a12 = [2 * f23 / v, -2 * f22]
    a21 = [-2 * f23 / v, 2 * f11 * b * lam / r0]
    a22 = [i, 2 * f11 * b**2 / v, p["k_psi"] + 2 * f23 - p["W"] * b * p["delta0"]]
    return np.polysub(np.polymul(a11, a22), np.polymul(a12, a21))


def routh_hurwitz_margin(speed: float, p: dict[str, float]) -> float:
    """The last Hurwitz determinant of a quartic, a1 (a3 a2 - a4 a1) - a3^2 a0, scaled: positive
    while every root is in the left half plane (the other conditions hold throughout here)."""
    a4, a3, a2, a1, a0 = textbook_polynomial(speed, p)
    assert min(a4, a3, a2, a1, a0) > 0 and a3 * a2 - a4 * a1 > 0
    return (a1 * (a3 * a2 - a4 * a1) - a3**2 * a0) / (a1 * a3 * a2)


def bisect(fun, lo: float, hi: float) -> float:  # noqa: ANN001 - a scalar function
    assert fun(lo) > 0 > fun(hi)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if fun(mid) > 0 else (lo, mid)
    return 0.5 * (lo + hi)


def test_characteristic_polynomial_is_the_textbook_one() -> None:
    for speed in (20.0, 70.0, 150.0):
        m, c, k = matrices(speed, VALUES)
        s = sp.Symbol("s")
        derived = sp.Poly(sp.Matrix(m * s**2 + c * s + k).det(), s).all_coeffs()
        np.testing.assert_allclose(
            np.array(derived, dtype=float), textbook_polynomial(speed, VALUES), rtol=1e-12
        )


def test_critical_speed_and_hunting_frequency() -> None:
    def growth(speed: float) -> float:
        return -np.linalg.eigvals(state_matrix(speed, VALUES)).real.max()

    critical = bisect(growth, 10.0, 300.0)
    expected = bisect(lambda s: routh_hurwitz_margin(s, VALUES), 10.0, 300.0)
    assert critical == pytest.approx(expected, rel=1e-9)
    # at the boundary the roots are +-i omega with omega^2 = a1 / a3 (Routh-Hurwitz)
    _, a3, _, a1, _ = textbook_polynomial(expected, VALUES)
    eig = np.linalg.eigvals(state_matrix(critical, VALUES))
    hunting = np.abs(eig[np.argmax(eig.real)].imag)
    assert hunting == pytest.approx(math.sqrt(a1 / a3), rel=1e-6)
    assert 10.0 < critical < 300.0
    print(f"critical speed {critical:.2f} m/s, hunting {hunting / (2 * math.pi):.3f} Hz")


def test_stiff_creep_tends_to_kinematic_hunting() -> None:
    # with creep coefficients far above the springs, the wheelset rolls almost without slip: its
    # least damped pair approaches Klingel's frequency v sqrt(lam / (b r0))
    speed = 30.0
    values = dict(VALUES, f11=1e13, f22=1e13, f23=0.0, k_y=0.0, k_psi=0.0, W=0.0)
    eig = np.linalg.eigvals(state_matrix(speed, values))
    slow = eig[np.argmin(np.abs(eig))]
    klingel = speed * math.sqrt(values["lam"] / (values["b"] * values["r0"]))
    assert abs(slow.imag) == pytest.approx(klingel, rel=1e-3)


def test_kalker_coefficients() -> None:
    f = ws.kalker_coefficients()
    subs = {ws.G_wr: G_STEEL, ws.a_c: 5.5e-3, ws.b_c: 5.5e-3, ws.C11: 4.12, ws.C22: 3.67, ws.C23: 1.47}
    assert float(f[ws.f11].subs(subs)) == pytest.approx(VALUES["f11"], rel=1e-14)
    assert float(f[ws.f22].subs(subs)) == pytest.approx(VALUES["f22"], rel=1e-14)
    assert float(f[ws.f23].subs(subs)) == pytest.approx(VALUES["f23"], rel=1e-14)
