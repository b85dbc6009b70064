"""A constant force crossing one simply supported span, against Frýba's modal series.

Frýba (Vibration of Solids and Structures under Moving Loads, 1972, Ch. 1): an undamped
Euler-Bernoulli beam, a force P moving at speed v from x = 0 at t = 0, beam at rest. With
``omega = pi v / L``, ``omega_n = n^2 omega_1`` and ``alpha = omega / omega_1``, while the force is on
the beam

    w(x, t) = -(2 P L^3 / (pi^4 E I)) sum_n [sin(n omega t) - (alpha / n) sin(omega_n t)]
              / (n^2 (n^2 - alpha^2)) sin(n pi x / L)

(deflection positive up, force downward). The series is summed here with enough terms that its
truncation is far below the tolerance.
"""

from __future__ import annotations

import numpy as np
import pytest

import svbi
from svbi.examples import paper_section
from svbi.runtime.scenario.schema import validate_scenario

L, MU, E, _, Iy = paper_section()
P = 170.0e3


def fryba_midspan(t: np.ndarray, v: float, terms: int = 200) -> np.ndarray:
    n = np.arange(1, terms + 1)[:, None]
    w1 = (np.pi / L) ** 2 * np.sqrt(E * Iy / MU)
    omega = np.pi * v / L
    alpha = omega / w1
    series = (np.sin(n * omega * t) - (alpha / n) * np.sin(n**2 * w1 * t)) / (n**2 * (n**2 - alpha**2))
    return -(2 * P * L**3 / (np.pi**4 * E * Iy)) * np.sum(series * np.sin(n * np.pi / 2), axis=0)


def run(speed_kmh: float, method: str = "localized-dynamic", dt: float = 1e-4):
    return svbi.simulate(
        validate_scenario(
            {
                "bridge": dict(
                    spans=1,
                    span_length=L,
                    mass_per_length=MU,
                    youngs_modulus=E,
                    area=8.63,
                    second_moment=Iy,
                    damping_ratio=0.0,
                    elements_per_span=16,
                ),
                "train": dict(
                    vehicle="moving-load",
                    speed_kmh=speed_kmh,
                    parameters=dict(axle_loads=[P], axle_offsets=[0.0]),
                ),
                "solver": dict(method=method, backend="numpy", time_step=dt, output_every=1),
            }
        )
    )


@pytest.mark.parametrize("speed_kmh", [150.0, 360.0])
def test_peak_midspan_deflection_matches_fryba(speed_kmh):
    v = speed_kmh / 3.6
    ds = run(speed_kmh)
    t = ds.time.values
    on = t <= L / v
    w = ds.midspan_uz.values[on, 0]
    ref = fryba_midspan(t[on], v)
    peak_ref = np.abs(ref).max()
    assert abs(np.abs(w).max() - peak_ref) < 5e-3 * peak_ref
    # and the whole history, not only its peak
    assert np.abs(w - ref).max() < 5e-3 * peak_ref
    # the prescribed load is reported as the contact force, with no gaps
    assert np.all(ds.contact_force.values == P)
    assert np.all(ds.gap_bridge.values == 0.0)


@pytest.mark.parametrize("method", ["coupled-dynamic", "coupled-classic"])
def test_all_methods_carry_a_moving_load(method):
    """The monolithic methods run the same loop with prescribed forces and give the same answer."""
    ref = run(300.0, dt=5e-4)
    other = run(300.0, method, dt=5e-4)
    scale = np.abs(ref.midspan_uz).max()
    assert float(np.abs(other.midspan_uz - ref.midspan_uz).max()) < 1e-9 * scale
