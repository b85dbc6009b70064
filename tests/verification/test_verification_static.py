"""Static check: a train standing on the bridge carries its weight, and the bridge deflects as a
simply supported beam under point loads (closed form), for every method.

The train is held still through the Python API (``hold_train=True``: speed 0, which the scenario
file forbids) and started from the static equilibrium of the whole system (``start="static"``). A
few time steps must then leave everything exactly where it is.
"""

from __future__ import annotations

import numpy as np
import pytest

import svbi
from svbi.codegen.topology import load_topology
from svbi.examples import paper_section
from svbi.runtime.scenario.schema import validate_scenario

L, MU, E, _, Iy = paper_section()
G = 9.81


def deflection(x: float, a: float, P: float) -> float:
    """Simply supported beam: deflection at x (up positive) under a downward load P at a."""
    if x > a:
        x, a = L - x, L - a
    b = L - a
    return -P * b * x * (L * L - b * b - x * x) / (6 * L * E * Iy)


@pytest.mark.parametrize("method", ["localized-dynamic", "coupled-dynamic", "coupled-classic"])
def test_train_standing_on_a_span(method):
    lead = 25.0
    scenario = validate_scenario(
        {
            "bridge": dict(
                spans=2,
                span_length=L,
                mass_per_length=MU,
                youngs_modulus=E,
                area=8.63,
                second_moment=Iy,
                damping_ratio=0.02,
                elements_per_span=16,
            ),
            "train": dict(vehicle="pioneer-2d", cars=1, speed_kmh=300.0, start_position=lead),
            "solver": dict(method=method, backend="numpy", time_step=1e-3, duration=0.02, output_every=1),
        }
    )
    ds = svbi.simulate(scenario, hold_train=True, start="static")

    p = load_topology("pioneer-2d").defaults()
    # statics of the symmetric car: each axle carries a quarter of the body, half a bogie, one wheelset
    axle = (p["carbody_mass"] / 4 + p["bogie_mass"] / 2 + p["wheelset_mass"]) * G
    offsets = np.array(
        [
            0.0,
            2 * p["axle_half_spacing"],
            2 * p["bogie_half_spacing"],
            2 * (p["bogie_half_spacing"] + p["axle_half_spacing"]),
        ]
    )
    force = ds.contact_force.values[:, 0, :]
    np.testing.assert_allclose(force, axle, rtol=1e-9)

    expected = sum(deflection(L / 2, lead - o, axle) for o in offsets)
    mid = ds.midspan_uz.values
    np.testing.assert_allclose(mid[:, 0], expected, rtol=1e-9)
    assert np.abs(mid[:, 1]).max() < 1e-12  # the second span carries nothing
    assert np.abs(ds.gap_bridge.values).max() < 1e-12
    assert np.abs(ds.carbody_az.values).max() < 1e-9
