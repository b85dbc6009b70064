"""The 3D coupled-dynamic step on a 3D bridge of several spans (runtime/model/bridge3d.py as the
step's deck) against svbi's 2D coupled-dynamic run of the same case (``svbi.simulate``, same dt,
elements, kappa, zeta): a sprung mass on a coned wheelset crossing from span 1 to span 2 of a chain
of simply supported spans, and a train of two such cars (runtime/model/train3d.py) each crossing a
joint of a four-span chain. In the vertical plane the 3D step is the 2D model: every span's
midspan deflection and every contact force agree to round-off; nothing moves laterally.

Every wheelset starts on a support line: a car that starts on a deflected span starts from the
static state with zero rates, which the 2D run and the 3D step do not take alike to round-off
(docs/three-d.md, "What is left": consistent initial rates).

The one car runs on the NumPy coupled-dynamic step (the monolithic step over a joint). The train
of two cars runs on the compiled localized-dynamic loop (``LocalizedDynamic3DC``): it checks the
same physics, 80 times faster; the loop is the NumPy localized step to round-off for a train of
two cars over a chain of spans (tests/backends/test_loop3d_c.py,
``test_train_over_a_chain_with_irregularities_and_creep``), and the localized step is the coupled
one on a chain of spans (tests/methods/test_quake3d_step.py,
``test_localized_is_coupled_with_a_travelling_wave_and_a_crossing``)."""

from __future__ import annotations

import numpy as np
import pytest
from cases import SW_CONICITY, SW_SPEED, sprung_mass_run2d, sprung_wheelset3d, sw_chain3d
from conftest import c_compiler_works

from svbi.runtime.backends.c.stepper3d import LocalizedDynamic3DC
from svbi.runtime.methods.coupled3d import CoupledDynamic3D, static_state
from svbi.runtime.model.system3d import GROUND, System3D, Track3D
from svbi.runtime.model.train3d import train3d

L = 10.0
SPACING = 20.0
"""Between the cars' leading axles (the 2D car's ``car_length``): two spans."""
V = SW_SPEED
DT, ELEMENTS = 2e-3, 8
LAM = SW_CONICITY
COS = 1.0 / np.sqrt(1.0 + LAM**2)


def run3d(
    spans: int, cars: int, start: float, steps: int, method: type = CoupledDynamic3D
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Midspan deflections (steps x spans), normal forces (steps x 2 per wheelset) and the largest
    lateral motion of deck and vehicle, stepped by ``method``."""
    car = sprung_wheelset3d()
    vehicle = train3d([car] * cars, SPACING) if cars > 1 else car
    bridge = sw_chain3d(spans, ELEMENTS)
    system = System3D(vehicle, bridge, Track3D(conicity=LAM), speed=V, start=start)
    stepper = method(system, static_state(system), DT)
    mids = [bridge.midspan_node(s) for s in range(spans)]
    lateral_dofs = [bridge.dof(n, d) for n in range(bridge.nodes) for d in ("v", "phi")]
    lateral_q = [
        i for i, n in enumerate(vehicle.dof_names) if n.split(".")[-1].startswith(("y_", "phi_", "psi_"))
    ]
    w, P, lateral = [], [], 0.0
    for n in range(steps):
        st = stepper.step(n)
        w.append([st.u[bridge.dof(m, "w")] for m in mids])
        P.append(st.P.copy())
        lateral = max(lateral, np.abs(st.u[lateral_dofs]).max(), np.abs(st.q[lateral_q]).max())
    return np.array(w), np.array(P), np.array(lateral)


def run2d(spans: int, cars: int, start: float, steps: int):
    return sprung_mass_run2d(
        spans, steps, start=start, cars=cars, car_length=SPACING, elements=ELEMENTS, dt=DT
    )


@pytest.mark.parametrize(
    ("spans", "cars", "start", "steps", "method"),
    [
        pytest.param(2, 1, 0.0, 250, CoupledDynamic3D, id="one-car-over-a-joint"),
        pytest.param(
            4,
            2,
            SPACING,
            250,
            LocalizedDynamic3DC,
            id="two-cars-over-two-joints-c-loop",
            marks=pytest.mark.skipif(not c_compiler_works(), reason="no working C compiler"),
        ),
    ],
)
def test_several_spans_in_the_vertical_plane_are_the_2d_run(spans, cars, start, steps, method) -> None:
    w3, P3, lateral = run3d(spans, cars, start, steps, method)
    r2 = run2d(spans, cars, start, steps)
    w2 = np.asarray(r2.midspan_uz.values)[1:].reshape(steps, spans)
    P2 = np.asarray(r2.contact_force.values).reshape(steps + 1, -1)[1:]
    # every wheelset crosses a joint during the run
    for k in range(cars):
        x0 = start - k * SPACING
        assert int(x0 // L) != int((x0 + V * steps * DT) // L)
    peak = np.abs(w2).max()
    assert peak > 1e-4
    assert np.abs(w3 - w2).max() < 1e-11 * peak
    assert np.abs(w2[:, 0]).max() > 1e-4 and np.abs(w2[:, 1]).max() > 1e-4  # spans ahead and behind load
    for k in range(cars):  # both normal forces of a wheelset carry its 2D contact force
        assert np.abs(P3[:, 2 * k] - P3[:, 2 * k + 1]).max() < 1e-11 * P2.max()
        assert np.abs(COS * (P3[:, 2 * k] + P3[:, 2 * k + 1]) - P2[:, k]).max() < 1e-11 * P2.max()
    assert lateral < 1e-14


def test_wheelset_locations_on_a_bridge() -> None:
    """A wheelset beyond the last abutment is on the approach track (the ground: element
    ``GROUND``), the last abutment included, as in 2D."""
    car = sprung_wheelset3d()
    bridge = sw_chain3d(2, ELEMENTS)
    system = System3D(car, bridge, Track3D(conicity=LAM), speed=V, start=19.0)
    assert system.contact_location(0.0) == [(ELEMENTS + 7, pytest.approx(0.2))]
    assert system.contact_location(0.1) == [(GROUND, 0.0)]
    assert System3D(car, bridge, start=2 * L).contact_location(0.0) == [(GROUND, 0.0)]
