"""The 3D step on a deck whose spans differ in length (so do their elements: each contact kernel
takes the length of the element under its wheelset) against svbi's 2D run of the same bridge
(``svbi.simulate``, same dt, elements, kappa, zeta), in the vertical plane: a sprung mass on a
coned wheelset (``SPRUNG_WHEELSET_3D``, symmetric, on the track's axis) crossing from a 10 m span
onto a 16 m one (elements of 1.25 m and 2 m), on a chain of two simply supported girders (the NumPy
coupled-dynamic step) and on a girder continuous over both spans (the compiled localized-dynamic
loop). In the vertical plane the 3D step is the 2D model: both midspan deflections and the contact
force agree to round-off; nothing moves laterally.

The wheelset starts on the first abutment (a start on a deflected span differs by the initial
rates: docs/three-d.md, "What is left")."""

from __future__ import annotations

import numpy as np
import pytest
from cases import SW_CONICITY, SW_DECK, SW_SPEED, sprung_mass_run2d, sprung_wheelset3d
from conftest import c_compiler_works

from svbi.runtime.backends.c.stepper3d import LocalizedDynamic3DC
from svbi.runtime.methods.coupled3d import CoupledDynamic3D, static_state
from svbi.runtime.model.bridge import Girder, Section
from svbi.runtime.model.bridge3d import Bridge3D, section3d
from svbi.runtime.model.system3d import GROUND, System3D, Track3D

SPANS = (10.0, 16.0)
V = SW_SPEED
DT, ELEMENTS, STEPS = 2e-3, 8, 300
"""300 steps: the wheelset crosses the joint (10 m) at step 180 and ends 6.7 m onto the 16 m span."""
LAM = SW_CONICITY
COS = 1.0 / np.sqrt(1.0 + LAM**2)
PLANE = Section(**SW_DECK, damping_ratio=0.0)


def girders(continuous: bool) -> list[Girder]:
    return [Girder(SPANS, PLANE)] if continuous else [Girder((s,), PLANE) for s in SPANS]


def run3d(continuous: bool, method: type) -> tuple[np.ndarray, np.ndarray, float, list[int]]:
    """Midspan deflections (steps x 2), normal forces (steps x 2), the largest lateral motion of deck
    and vehicle, and the element under the wheelset at every step."""
    car = sprung_wheelset3d()
    parts = girders(continuous)
    bridge = Bridge3D(parts, ELEMENTS, [section3d(PLANE, 10.0, 5.0)] * len(parts))
    assert sorted(set(bridge.deck_element_length)) == [1.25, 2.0]
    system = System3D(car, bridge, Track3D(conicity=LAM), speed=V, start=0.0)
    stepper = method(system, static_state(system), DT)
    mids = [bridge.midspan_node(s) for s in range(2)]
    lateral_dofs = [bridge.dof(n, d) for n in range(bridge.nodes) for d in ("v", "phi")]
    lateral_q = [i for i, n in enumerate(car.dof_names) if n.startswith(("y_", "phi_", "psi_"))]
    w, P, lateral, elements = [], [], 0.0, []
    for n in range(STEPS):
        st = stepper.step(n)
        w.append([st.u[bridge.dof(m, "w")] for m in mids])
        P.append(st.P.copy())
        lateral = max(lateral, np.abs(st.u[lateral_dofs]).max(), np.abs(st.q[lateral_q]).max())
        elements.append(system.contact_location(st.t)[0][0])
    return np.array(w), np.array(P), lateral, elements


def run2d(continuous: bool):
    girders = [dict(spans=list(SPANS))] if continuous else [dict(spans=[s]) for s in SPANS]
    return sprung_mass_run2d(0, STEPS, elements=ELEMENTS, dt=DT, girders=girders)


@pytest.mark.parametrize(
    ("continuous", "method"),
    [
        pytest.param(False, CoupledDynamic3D, id="chain-numpy-coupled"),
        pytest.param(
            True,
            LocalizedDynamic3DC,
            id="continuous-c-loop",
            marks=pytest.mark.skipif(not c_compiler_works(), reason="no working C compiler"),
        ),
    ],
)
def test_unequal_spans_in_the_vertical_plane_are_the_2d_run(continuous: bool, method: type) -> None:
    w3, P3, lateral, elements = run3d(continuous, method)
    r2 = run2d(continuous)
    w2 = np.asarray(r2.midspan_uz.values)[1:].reshape(STEPS, 2)
    P2 = np.asarray(r2.contact_force.values).reshape(STEPS + 1, -1)[1:, 0]
    # the wheelset runs on both spans' elements (1.25 m, then 2 m), never on the ground
    assert GROUND not in elements
    assert elements[0] < ELEMENTS <= elements[-1]
    assert sum(e >= ELEMENTS for e in elements) > 100
    peak = np.abs(w2).max()
    assert np.abs(w2[:, 0]).max() > 1e-4 and np.abs(w2[:, 1]).max() > 1e-4  # both spans deflect
    assert np.abs(w3 - w2).max() < 1e-11 * peak
    assert np.abs(P3[:, 0] - P3[:, 1]).max() < 1e-11 * P2.max()  # a symmetric car: equal wheels
    assert np.abs(COS * (P3[:, 0] + P3[:, 1]) - P2).max() < 1e-11 * P2.max()
    assert lateral < 1e-14
