"""A sprung mass crossing one simply supported span, against an independent modal solution.

Classic moving-oscillator benchmark (Yang, Yau & Wu 2004): L = 25 m, E = 2.87 GPa, I = 2.9 m^4,
m = 2303 kg/m, sprung mass M = 5750 kg on k = 1595 kN/m, 100 km/h, no damping.

The reference is written here, independently of the code under test: the beam is expanded in the
exact modes ``sin(n pi x / L)`` of a simply supported Euler-Bernoulli beam, the wheel (mass m_w, the
topology's 500 kg, which svbi needs because the contact constraint acts on a mass) rides rigidly on
the beam at ``x = v t``, so its acceleration is the total second derivative of the deflection under
it, ``w_tt + 2 v w_xt + v^2 w_xx``, and the sprung mass hangs on the spring. Gravity acts on both
masses; the spring is pre-compressed by the static weight of the sprung mass (the static start on
rigid track). This is the same physics as svbi's model, so the two must agree to discretisation
error. The equations are integrated by DOP853 at tight tolerances.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import svbi
from svbi.runtime.scenario import validate_scenario

L, E, I, MU = 25.0, 2.87e9, 2.9, 2303.0
M_S, K_S, M_W = 5750.0, 1.595e6, 500.0
V = 100.0 / 3.6
G = 9.81
MODES = 30


def modal_reference(n_modes: int = MODES):
    """Dense-output solution: returns a function t -> midspan deflection (m)."""
    n = np.arange(1, n_modes + 1)
    k_n = n * np.pi / L
    w2 = k_n**4 * E * I / MU
    m0 = MU * L / 2  # modal mass of sin(n pi x / L)

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        q, qd = y[:n_modes], y[n_modes : 2 * n_modes]
        z, zd = y[-2], y[-1]
        x = V * t
        phi = np.sin(k_n * x)
        phi1 = k_n * np.cos(k_n * x)
        phi2 = -(k_n**2) * phi
        w, wd = phi @ q, phi @ qd
        spring = K_S * (w - z)  # z: sprung mass from its static position; w: wheel = beam under it
        # contact force P = m_w (w_c'' + g) + M g + spring; w_c'' = phi.q'' + 2 v phi'.q' + v^2 phi''.q
        conv = 2 * V * (phi1 @ qd) + V * V * (phi2 @ q)
        f = -m0 * w2 * q - phi * (M_W * (conv + G) + M_S * G + spring)
        # (m0 I + m_w phi phi^T) q'' = f, by Sherman-Morrison
        qdd = f / m0 - (M_W * phi * (phi @ f) / m0**2) / (1 + M_W * (phi @ phi) / m0)
        zdd = spring / M_S
        return np.concatenate([qd, qdd, [zd, zdd]])

    y0 = np.zeros(2 * n_modes + 2)
    sol = solve_ivp(rhs, (0.0, L / V), y0, method="DOP853", rtol=1e-11, atol=1e-14, dense_output=True)
    assert sol.success
    mid = np.sin(n * np.pi / 2)

    def midspan(t: np.ndarray) -> np.ndarray:
        return mid @ sol.sol(t)[:n_modes]

    return midspan


@pytest.fixture(scope="module")
def reference():
    return modal_reference()


def scenario(dt: float, elements: int = 16, method: str = "localized-dynamic"):
    return validate_scenario({
        "bridge": dict(spans=1, span_length=L, mass_per_length=MU, youngs_modulus=E, area=1.0,
                       second_moment=I, damping_ratio=0.0, elements_per_span=elements),
        "train": dict(vehicle="sprung-mass", speed=V,
                      parameters=dict(sprung_mass=M_S, stiffness=K_S, wheel_mass=M_W, damping=0.0)),
        "solver": dict(method=method, backend="numpy", time_step=dt, output_every=1),
    })


def error(ds, reference) -> tuple[float, float]:
    t = ds.time.values
    keep = t <= L / V
    w = ds.midspan_uz.values[keep, 0]
    ref = reference(t[keep])
    return float(np.abs(w - ref).max() / np.abs(ref).max()), float(np.abs(ref).max())


def test_reference_is_converged_in_modes(reference):
    """The modal series is converged: half the modes change the peak by far less than the tolerance."""
    t = np.linspace(0, L / V, 400)
    coarse = modal_reference(MODES // 2)(t)
    assert np.abs(coarse - reference(t)).max() < 1e-4 * np.abs(reference(t)).max()


@pytest.mark.slow
def test_midspan_history_matches_modal_solution(reference):
    ds = svbi.simulate(scenario(1e-4))
    err, peak = error(ds, reference)
    assert 2.0e-3 < peak < 3.5e-3  # the benchmark's order of magnitude (2.4 mm without wheel mass)
    assert err < 5e-3, f"max error {err:.3g} of the peak"


def test_second_order_in_time(reference):
    """Halving the time step divides the error by about four (Newmark is second order)."""
    dts = [8e-3, 4e-3, 2e-3]
    errors = [error(svbi.simulate(scenario(dt)), reference)[0] for dt in dts]
    order = np.polyfit(np.log(dts), np.log(errors), 1)[0]
    assert 1.7 < order < 2.4, f"observed order {order:.2f} from errors {errors}"
