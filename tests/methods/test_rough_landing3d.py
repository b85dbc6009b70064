"""A landing on rough rails (runtime/methods/coupled3d.py, ``_Step3D.set_irregularity``): the plastic
impact stops the landing wheel relative to the rail it lands on, irregularities included.

The impact evaluates the gap rates ``g'`` and ``g''`` with their own kernels (``c1 = 1`` and
``c1 = c0 = 0``); a run sets the rail's irregularity under each wheelset on every kernel of the
step through ``set_irregularity``. The case: the sprung wheelset of tests/cases.py at 20 m/s on a
10 m span, rails with vertical, alignment and cross-level waves (1.5, 1.0 and 0.4 mm, level and
flat where the wheelset starts), pulled up for 40 steps so that both wheels fly and land. After the
landing step the landing contacts' normal
velocity, with the rail's slope under them, is round-off (the rail's vertical velocity under a wheel
at 20 m/s on these waves is up to 18 mm/s; the impact with level-rail rates left 5.4 mm/s).
"""

from __future__ import annotations

import numpy as np
from cases import SPRUNG_WHEELSET_3D

from svbi.codegen.topology3d import parse_topology3d
from svbi.runtime.methods.chunk3d import SteppedChunks
from svbi.runtime.methods.coupled3d import CoupledDynamic3D, State3D, static_state
from svbi.runtime.methods.localized3d import LocalizedDynamic3D
from svbi.runtime.model.span3d import Section3D, simply_supported_span
from svbi.runtime.model.system3d import System3D, Track3D, vehicle3d

DT = 1e-4
STEPS = 200


def _waves(system: System3D, t: np.ndarray) -> np.ndarray:
    """(steps, wheelsets, 9): smooth vertical, alignment and cross-level waves ``a (1 - cos k s)``
    from the wheelsets' places at t = 0 (``s`` the distance travelled: level and flat there, where the
    static state stands), their slopes and curvatures."""
    s = np.repeat(system.speed * t[:, None], len(system.vehicle.wheelsets), axis=1)
    out = np.zeros((*s.shape, 9))
    for c, (a, k) in enumerate(((1.5e-3, 0.6), (1.0e-3, 0.45), (4e-4, 0.8))):
        out[..., c] = a * (1.0 - np.cos(k * s))
        out[..., 3 + c] = a * k * np.sin(k * s)
        out[..., 6 + c] = a * k * k * np.cos(k * s)
    return out


def test_a_landing_on_rough_rails_stops_the_wheel_on_the_rail() -> None:
    vehicle = vehicle3d(parse_topology3d(SPRUNG_WHEELSET_3D))
    span = simply_supported_span(
        Section3D(E=3.0e10, A=5.0, I_y=3.0, I_z=20.0, J=4.0, mass_per_length=12000.0), 10.0, 4
    )
    system = System3D(vehicle, span, Track3D(conicity=0.1), speed=20.0, start=3.0)
    weight = -(vehicle.F[vehicle.index("z_body")] + vehicle.F[vehicle.index("z_ws")])
    t = (np.arange(STEPS) + 1) * DT
    level = _waves(system, t)
    for method in (LocalizedDynamic3D, CoupledDynamic3D):
        stepper = method(system, static_state(system), DT)
        chunks = SteppedChunks(stepper)
        # the pull: more than the weight on the wheelset for 40 steps (system.load of the step)
        rows = []
        for n in range(STEPS):
            pull = np.zeros(len(vehicle.dof_names))
            pull[vehicle.index("z_ws")] = 1.5 * weight if 100 <= n < 140 else 0.0
            system.load = pull
            rows.append(chunks.advance(n, 1, level[n : n + 1], 1))
        system.load = None
        closed = np.concatenate([r.contact for r in rows])[:, :2]
        landing = np.flatnonzero((~closed[:-1] & closed[1:]).any(axis=1)) + 1
        assert landing.size, "no landing"
        # the gap rates at the end of the landing step, with the rail under the wheels
        j = int(landing[0])
        probe = method(system, static_state(system), DT)
        probe.set_irregularity(level[j])
        st = rows[j]
        state = State3D(
            st.t[0],
            st.q[0],
            st.qd[0],
            st.qdd[0],
            st.u[0],
            st.ud[0],
            st.udd[0],
            st.P[0],
            st.flange[0],
            st.contact[0],
        )
        gt, _ = probe._gap_rates(state, system.contact_location(st.t[0]))
        landed = closed[j] & ~closed[j - 1]
        assert np.abs(gt[:2][landed]).max() < 1e-12, (method.name, gt[:2])
