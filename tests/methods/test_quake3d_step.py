"""Ground motion at the supports and the approach track in the 3D steps (docs/three-d.md, "The 3D
time step (prototype)": support motion, approach track).

* a car crossing from the approach track onto a span and off again, with and without a vertical and
  longitudinal earthquake (synchronous and a travelling wave), against svbi's 2D coupled-dynamic
  run of the same case (``svbi.simulate`` with the same ground, ``FunctionGround``) in the vertical
  plane: midspan deflections, axial displacements and contact forces to round-off;
* a car standing on a bridge whose ground moves at a constant velocity in x, y and z: the whole
  system translates rigidly with the ground (exact for Newmark), the gaps stay closed;
* a span under a uniform lateral ground acceleration: its midspan lateral displacement relative to
  the ground against the modal solution of the Euler-Bernoulli span, written here (lateral modes in
  closed form, each modal equation integrated by ``solve_ivp``);
* localized = coupled with a three-component travelling wave, damping and a crossing.

The crossings run on the compiled localized-dynamic loop (``LocalizedDynamic3DC``), 30 to 80 times
faster than the NumPy coupled step: they check the same physics against the 2D run, the loop is
the NumPy localized step to round-off with a three-component travelling earthquake and the approach
track (tests/backends/test_loop3d_c.py, ``test_travelling_earthquake_and_the_approach_track``), and
the localized step is the coupled one on the approach track under such a wave (the last test here).
The NumPy coupled step against the 2D run: tests/methods/test_bridge3d_step.py (over a joint) and
tests/methods/test_coupled3d_step.py.
"""

from __future__ import annotations

import numpy as np
import pytest
from cases import (
    SW_CONICITY,
    SW_DECK,
    SW_SPEED,
    ground_bump,
    sprung_mass_run2d,
    sprung_wheelset3d,
    sw_chain3d,
)
from conftest import c_compiler_works
from scipy.integrate import solve_ivp

from svbi.runtime.backends.c.stepper3d import LocalizedDynamic3DC
from svbi.runtime.methods.coupled3d import CoupledDynamic3D, static_state
from svbi.runtime.methods.localized3d import LocalizedDynamic3D
from svbi.runtime.model.bridge3d import Bridge3D
from svbi.runtime.model.ground import FunctionGround
from svbi.runtime.model.system3d import GROUND, System3D, Track3D

L = 10.0
E, Iy, MU = SW_DECK["youngs_modulus"], SW_DECK["second_moment"], SW_DECK["mass_per_length"]
V = SW_SPEED
DT, ELEMENTS = 2e-3, 8
LAM = SW_CONICITY
COS = 1.0 / np.sqrt(1.0 + LAM**2)


def support_targets(ground, b: Bridge3D, t: float, dt: float) -> np.ndarray:
    """The supports' Newmark-consistent targets (docs/method.md, "Support targets"), written here:
    ``h = q - dt^2/4 q''`` of each support's component at its line, at ``t - dt``, ``t``, ``t + dt``,
    then ``(h0 + 2 h1 + h2) / 4``; held rotations 0."""
    x = np.array([s.x for s in b.supports])

    def h(tk):
        (vz, _, az), (vx, _, ax) = ground.motion(tk, x)
        vy, _, ay = ground.lateral(tk, x)
        q = {"x": vx - dt * dt / 4 * ax, "y": vy - dt * dt / 4 * ay, "z": vz - dt * dt / 4 * az}
        return np.array([q[s.direction][i] if s.direction in q else 0.0 for i, s in enumerate(b.supports)])

    h0, h1, h2 = (h(t + k * dt) for k in (-1, 0, 1))
    return 0.25 * (h0 + 2 * h1 + h2)


car = sprung_wheelset3d


def bridge(spans: int, damping: float, elements: int = ELEMENTS, lateral: float = 10.0) -> Bridge3D:
    return sw_chain3d(spans, elements, damping, lateral)


def run3d(spans, start, steps, damping=0.0, ground=None, method=CoupledDynamic3D):
    b = bridge(spans, damping)
    system = System3D(
        car(), b, Track3D(conicity=LAM), speed=V, start=start, bridge_damping=b.C, ground=ground
    )
    stepper = method(system, static_state(system), DT)
    mids = [b.midspan_node(s) for s in range(spans)]
    w, u, P, where = [], [], [], []
    stepper.support_error = 0.0
    for n in range(steps):
        st = stepper.step(n)
        if ground is not None:
            off = np.abs(st.u[b.support_dofs] - support_targets(ground, b, st.t, DT)).max()
            stepper.support_error = max(stepper.support_error, off)
        w.append([st.u[b.dof(m, "w")] for m in mids])
        u.append([st.u[b.dof(m, "u")] for m in mids])
        P.append(st.P.copy())
        where.append(system.contact_location(st.t)[0][0])
    return np.array(w), np.array(u), np.array(P), np.array(where), stepper


def run2d(spans, start, steps, damping=0.0, ground=None):
    return sprung_mass_run2d(
        spans, steps, start=start, elements=ELEMENTS, dt=DT, damping=damping, ground=ground
    )


QUAKES = {
    "no-earthquake": None,
    "synchronous": dict(
        vertical=ground_bump(0.005, 2 * np.pi * 2.0, t0=0.05),
        longitudinal=ground_bump(-0.03, 2 * np.pi * 2.0, t0=0.05),
    ),
    "wave-300m/s": dict(
        vertical=ground_bump(0.02, 2 * np.pi * 3.0, t0=0.05, c=300.0),
        longitudinal=ground_bump(-0.03, 2 * np.pi * 2.0, t0=0.05, c=300.0),
        apparent_velocity=300.0,
    ),
}


C_LOOP = pytest.mark.skipif(not c_compiler_works(), reason="no working C compiler")


@pytest.mark.parametrize(
    ("quake", "method"),
    [
        pytest.param("no-earthquake", LocalizedDynamic3DC, id="no-earthquake-c-loop", marks=C_LOOP),
        pytest.param("synchronous", LocalizedDynamic3DC, id="synchronous-c-loop", marks=C_LOOP),
        pytest.param("wave-300m/s", LocalizedDynamic3DC, id="wave-300m/s-c-loop", marks=C_LOOP),
    ],
)
def test_crossing_from_the_approach_track_is_the_2d_run(quake, method) -> None:
    """The car starts 5 m before a chain of two 10 m spans (damped 2 %) and leaves it at the far end:
    the 3D step in the vertical plane is svbi's 2D run of the same case, ground motion included."""
    spans, start, steps = 2, -5.0, 520  # 1.04 s: 28.9 m, from x = -5 m to 23.9 m (wheelset)
    spec = QUAKES[quake]
    g3 = g2 = None
    if spec is not None:
        g3 = FunctionGround(**spec)
        g2 = FunctionGround(**spec)
    w3, u3, P3, where, stepper = run3d(spans, start, steps, damping=0.02, ground=g3, method=method)
    r2 = run2d(spans, start, steps, damping=0.02, ground=g2)
    w2 = np.asarray(r2.midspan_uz.values)[1:].reshape(steps, spans)
    u2 = np.asarray(r2.midspan_ux.values)[1:].reshape(steps, spans)
    P2 = np.asarray(r2.contact_force.values).reshape(steps + 1, -1)[1:, 0]
    assert where[0] == GROUND and where[-1] == GROUND and (where != GROUND).sum() > 100
    peak = np.abs(w2).max()
    assert peak > 1e-4
    assert np.abs(w3 - w2).max() < 1e-11 * peak
    if spec is not None:
        assert np.abs(u2).max() > 1e-3
        assert np.abs(u3 - u2).max() < 1e-11 * np.abs(u2).max()
        # the supports on their targets: the 2D support gaps at round-off, the 3D supports exactly
        qmax = float(np.abs(r2.ground_uz).max())
        assert qmax > 1e-3
        assert float(np.abs(r2.gap_support).max()) < 1e-13 * qmax
        largest = max(qmax, float(np.abs(r2.ground_ux).max()))
        assert stepper.support_error < 1e-15 * largest
    # the forces: 1e-11 of the peak at rest (measured 1.3e-13), 1e-10 under the earthquake (measured
    # 1.9e-12 synchronous, 9.1e-12 for the wave): they are a0-scaled differences of displacements
    # that now carry the ground's 0.12 m, a hundred times the deflection
    tol = 1e-11 if spec is None else 1e-10
    assert np.abs(P3[:, 0] - P3[:, 1]).max() < tol * P2.max()
    assert np.abs(COS * (P3[:, 0] + P3[:, 1]) - P2).max() < tol * P2.max()


def test_the_system_translates_with_a_ground_at_constant_velocity() -> None:
    """A car standing on the first span of a two-span bridge whose ground moves at a constant
    velocity (x, y, z), everything starting with that velocity: the exact solution is the static
    state translated rigidly, which Newmark reproduces exactly; the gaps stay closed."""
    rate = np.array([0.3, -0.2, 0.1])  # m/s along x, y, z

    def moving(k):
        return lambda t, x: (rate[k] * t + 0.0 * x, rate[k] + 0.0 * x, 0.0 * x)

    ground = FunctionGround(vertical=moving(2), longitudinal=moving(0), lateral=moving(1))
    b = bridge(2, 0.02)
    veh = car()
    system = System3D(veh, b, Track3D(conicity=LAM), speed=0.0, start=4.0, bridge_damping=b.C, ground=ground)
    st0 = static_state(system)
    u0, q0 = st0.u.copy(), st0.q.copy()
    # the translation's rates: T maps the supports' rates to the bridge's rigid field
    st0.ud = b.T @ b.support_motion(np.tile(rate, (b.spans + 1, 1)))
    ys = [i for i, n in enumerate(veh.dof_names) if n.startswith("y_")]
    zs = [i for i, n in enumerate(veh.dof_names) if n.startswith("z_")]
    st0.qd[ys], st0.qd[zs] = rate[1], rate[2]
    stepper = CoupledDynamic3D(system, st0, DT)
    rigid_u = b.T @ b.support_motion(np.tile(rate, (b.spans + 1, 1)))
    for n in range(200):
        st = stepper.step(n)
        q = q0.copy()
        q[ys] += rate[1] * st.t
        q[zs] += rate[2] * st.t
        assert np.abs(st.u - (u0 + rigid_u * st.t)).max() < 1e-13
        assert np.abs(st.q - q).max() < 1e-13
        assert np.abs(st.P - st0.P).max() < 1e-9 * st0.P.max()
        assert np.abs(stepper.gaps()).max() < 1e-14
    assert abs(st.t * rate[1]) > 0.07  # it has moved 8 cm sideways


@C_LOOP
def test_lateral_relative_response_of_a_span_is_the_modal_solution() -> None:
    """A 10 m span (16 elements, undamped, ``I_z`` 0.05 m^4: first lateral mode 3.93 Hz) under a
    uniform lateral ground motion, the car on the approach track: the midspan's lateral
    displacement relative to the ground against ``sum_n Gamma_n phi_n(L/2) Y_n`` with
    ``Y_n'' + omega_n^2 Y_n = -q_y''`` (odd modes ``sin(n pi x/L)``, ``Gamma_n = 4/(n pi)``,
    ``omega_n = (n pi/L)^2 sqrt(E I_z/mu)``), integrated by ``solve_ivp``. Tolerance 2e-3 of the
    peak: Newmark's period error ``(omega dt)^2/12`` on the first mode (5e-5 at dt = 1e-3 s) and the
    higher modes' (3rd: 4e-3 on its 1/30 share), the discretisation's 1e-6. On the compiled
    localized loop (the NumPy localized step to round-off under a three-component earthquake,
    tests/backends/test_loop3d_c.py, ``test_travelling_earthquake_and_the_approach_track``)."""
    Iz, dt, steps = 0.05, 1e-3, 500
    motion = ground_bump(0.01, 2 * np.pi * 2.0)
    ground = FunctionGround(lateral=motion)
    b = bridge(1, 0.0, elements=16, lateral=Iz)
    system = System3D(car(), b, Track3D(conicity=LAM), speed=0.0, start=-50.0, ground=ground)
    stepper = LocalizedDynamic3DC(system, static_state(system), dt)
    mid = b.dof(b.midspan_node(0), "v")
    t = (np.arange(steps) + 1) * dt
    rel = []
    for n in range(steps):
        st = stepper.step(n)
        rel.append(st.u[mid] - motion(st.t, 0.0)[0])
    rel = np.array(rel)

    def modal(n: int) -> np.ndarray:
        omega = (n * np.pi / L) ** 2 * np.sqrt(E * Iz / MU)
        sol = solve_ivp(
            lambda s, y: [y[1], -(omega**2) * y[0] - float(motion(s, 0.0)[2])],
            (0.0, t[-1]),
            [0.0, 0.0],
            t_eval=t,
            rtol=1e-10,
            atol=1e-13,
        )
        return 4 / (n * np.pi) * np.sin(n * np.pi / 2) * sol.y[0]

    exact = sum(modal(n) for n in (1, 3, 5, 7, 9))
    peak = np.abs(exact).max()
    assert peak > 1e-3
    assert np.abs(rel - exact).max() < 2e-3 * peak


def test_localized_is_coupled_with_a_travelling_wave_and_a_crossing() -> None:
    """Three components of a travelling wave (300 m/s), 2 % damping, a car crossing from the
    approach track onto a two-span chain on an eccentric raised track (it sways and rolls): the
    partitioned step gives the monolithic one to 1e-10 of each series' peak."""
    c = 300.0
    ground = dict(
        vertical=ground_bump(0.005, 2 * np.pi * 1.0, 0.05, c),
        longitudinal=ground_bump(-0.03, 2 * np.pi * 2.0, 0.05, c),
        lateral=ground_bump(0.001, 2 * np.pi * 1.0, 0.05, c),
        apparent_velocity=c,
    )
    out = []
    for method in (CoupledDynamic3D, LocalizedDynamic3D):
        b = bridge(2, 0.02)
        system = System3D(
            car(),
            b,
            Track3D(conicity=LAM, eccentricity=0.3, rail_height=0.8),
            speed=V,
            start=-3.0,
            bridge_damping=b.C,
            ground=FunctionGround(**ground),
        )
        stepper = method(system, static_state(system), DT)
        series = []
        for n in range(250):
            st = stepper.step(n)
            series.append(np.concatenate([st.q, st.u, st.P]))
        out.append(np.array(series))
    a, b_ = out
    peak = np.abs(a).max(axis=0)
    moving = peak > 1e-12
    assert (np.abs(a - b_)[:, moving].max(axis=0) < 1e-10 * peak[moving]).all()


def test_a_ground_motion_needs_a_bridge_deck() -> None:
    """A Span3D carries no support lines: a ground motion on it is refused at set-up."""
    from svbi.runtime.model.span3d import Section3D, simply_supported_span

    span = simply_supported_span(Section3D(E=E, A=1.0, I_y=Iy, I_z=10.0, J=5.0, mass_per_length=MU), L, 4)
    with pytest.raises(ValueError, match="a ground motion needs a deck with supports on the ground"):
        System3D(car(), span, ground=FunctionGround(lateral=ground_bump(0.01, 1.0)))
