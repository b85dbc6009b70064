"""Unilateral normal contact, flange contact and creep in the 3D steps (runtime/methods/coupled3d.py,
localized3d.py) against independent truth.

* **Flange**: a lateral load on the car body that the cones cannot hold within the clearance
  (their gravitational stiffness carries ``K_g c_f``, a few hundred newtons) drives the wheelset
  against its flange. Statically the flange gap is closed and the flange force is the load less
  the lateral components of the normal forces, written here from the cone's normals; in a damped
  run the gap stays within round-off of the rail while closed and the flange force settles at the
  static one.
* **Lift-off**: an upward pull larger than the car's weight on its wheelset: both wheels leave the
  rail at the first step (forces exactly zero), the car's centre of mass flies on the parabola of
  the net force (Newmark is exact for it); the pull released, the wheelset lands with forces
  ``>= 0`` and no rebound.
* **Bouncing deck**: a light wheelset resting on a span vibrating in its first vertical mode
  leaves it when the deck's downward acceleration exceeds ``g`` and lands where its free flight
  meets the deck again; both times against the closed form of the mode and the parabola.
* **localized = coupled** to 1e-10 of each series' peak with creep, a flange contact, a lift-off
  and a landing in the run.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import eigh
from scipy.optimize import brentq

from svbi.codegen.topology3d import parse_topology3d
from svbi.runtime.methods.chunk3d import SteppedChunks
from svbi.runtime.methods.classic3d import CoupledClassic3D
from svbi.runtime.methods.coupled3d import CoupledDynamic3D, State3D, static_state
from svbi.runtime.methods.localized3d import LocalizedDynamic3D
from svbi.runtime.model.creep_law import CreepParameters
from svbi.runtime.model.span3d import Section3D, simply_supported_span
from svbi.runtime.model.system3d import ContactKernel3D, System3D, Track3D, vehicle3d
from tests.cases import SPRUNG_WHEELSET_3D_DAMPED

GRAVITY = 9.81

# the sprung wheelset of tests/cases.py with a dashpot beside each spring (a damped test vehicle)
TOPOLOGY = SPRUNG_WHEELSET_3D_DAMPED

WHEELSET = """
name = "lone-wheelset-3d"
kind = "rigid-body"
dimensions = 3
description = "A wheelset alone (test vehicle)."
source = "tests"
[parameters.m_w]
value = 1.0
unit = "kg"
description = "wheelset mass"
[parameters.car_length]
value = 1.0
unit = "m"
description = "spacing"
[[bodies]]
name = "ws"
dofs = ["y", "z", "phi", "psi"]
mass = "m_w"
roll_inertia = "0.2"
yaw_inertia = "0.2"
position = "0"
height = "0.46"
[[wheels]]
name = "left"
body = "ws"
lateral = "0.75"
radius = "0.46"
[[wheels]]
name = "right"
body = "ws"
lateral = "-0.75"
radius = "0.46"
"""

LAM, B = 0.1, 0.75
COS = 1.0 / np.sqrt(1.0 + LAM**2)
LB, H_T, E_T = 10.0, 1.2, 0.3
SECTION = Section3D(E=3.0e10, A=5.0, I_y=3.0, I_z=20.0, J=4.0, mass_per_length=12000.0)
CLEARANCE = 0.005
LATERAL = 2000.0  # N on the car body: the cones hold about 90 N at the clearance
DT = 1e-3


@pytest.fixture(scope="module")
def car():
    return vehicle3d(parse_topology3d(TOPOLOGY))


def body_load(car, lateral: float = 0.0, pull: float = 0.0) -> np.ndarray:
    load = np.zeros(len(car.dof_names))
    load[car.index("y_body")] = lateral
    load[car.index("z_ws")] = pull
    return load


def weight(car) -> float:
    return -(car.F[car.index("z_body")] + car.F[car.index("z_ws")])


def normal_lateral(st: State3D, roll: float) -> float:
    """Lateral force of the normal forces on the wheelset: ``P n_y``, the cone's normal
    ``(0, -s lam, 1) / sqrt(1 + lam^2)`` turned by the roll."""
    return sum(P * COS * (-s * LAM * np.cos(roll) - np.sin(roll)) for P, s in zip(st.P, (1, -1), strict=True))


def test_static_flange_holds_the_car(car):
    span = simply_supported_span(SECTION, LB, 4)
    track = Track3D(conicity=LAM, eccentricity=E_T, rail_height=H_T, flange_clearance=CLEARANCE)
    system = System3D(car, span, track, speed=0.0, start=LB / 2, load=body_load(car, LATERAL))
    st = static_state(system)
    stepper = CoupledDynamic3D(system, st, DT)
    flange_gaps = stepper.flange_gaps()
    assert abs(flange_gaps[0]) < 1e-15 and flange_gaps[1] == pytest.approx(2 * CLEARANCE, rel=1e-9)
    assert st.flange[1] == 0.0 and st.flange[0] > 0.0
    # the wheelset's lateral balance: flange (pushing it right) = load + normal forces' lateral part
    roll = st.q[car.index("phi_ws")]
    assert st.flange[0] == pytest.approx(LATERAL + normal_lateral(st, roll), rel=1e-12)
    # the cones carry a part of the load (their gravitational stiffness at the clearance and the
    # wheel loads shifted by the body's roll: measured 386 N), the flange the rest
    assert 0.0 < -normal_lateral(st, roll) < 0.25 * LATERAL
    # the relative lateral displacement is the clearance
    mid = 2
    v, phi = st.u[span.dof(mid, "v")], st.u[span.dof(mid, "phi")]
    assert st.q[car.index("y_ws")] - (v - H_T * phi) == pytest.approx(CLEARANCE, rel=1e-12)


def test_flange_contact_in_a_run(car):
    """The load set on at t = 0 on the car standing at gravity's equilibrium: the wheelset strikes
    its flange (a plastic impact) and is held there, within round-off of the clearance, while the
    car settles on its damped suspension towards the static state under the load."""
    span = simply_supported_span(SECTION, LB, 4)
    track = Track3D(conicity=LAM, eccentricity=E_T, rail_height=H_T, flange_clearance=CLEARANCE)
    system = System3D(car, span, track, speed=0.0, start=LB / 2)
    st = static_state(system)
    system.load = body_load(car, LATERAL)
    stepper = CoupledDynamic3D(system, st, DT)
    gaps, forces, q = [], [], []
    for n in range(STEPS_TO_REST):
        stepper.step(n)
        gaps.append(stepper.flange_gaps())
        forces.append(stepper.state.flange.copy())
        q.append(stepper.state.q.copy())
    gaps, forces, q = np.array(gaps), np.array(forces), np.array(q)
    closed = forces[:, 0] > 0
    assert closed.any() and (forces >= 0).all() and (forces[:, 1] == 0).all()
    # never beyond the clearance: the closing step's row is g = 0, the stabilised rows hold it
    assert gaps[:, 0].min() > -1e-15  # measured -8.7e-19
    assert np.abs(gaps[closed, 0]).max() < 1e-15
    # coming to rest on the flange: towards the static state under the load (the wheelset within
    # 1.0e-6 m of it over the last 0.1 s, measured, with the deck's sway; the body still sways by
    # 1.5e-4 m)
    static = static_state(System3D(car, span, track, speed=0.0, start=LB / 2, load=body_load(car, LATERAL)))
    y_ws = car.index("y_ws")
    assert np.abs(q[-100:, y_ws] - static.q[y_ws]).max() < 5e-4 * CLEARANCE


STEPS_TO_REST = 800


PULL_STEPS, FREE_STEPS = 40, 160


@pytest.mark.parametrize("method", [CoupledDynamic3D, CoupledClassic3D], ids=["dynamic", "classic"])
def test_lift_off_flight_and_landing(car, method):
    """An upward pull of 1.5 times the car's weight on the wheelset of the car standing on the span,
    for 40 steps, then released (coupled-dynamic, and coupled-classic, whose landing row is the same
    position-level ``g_{n+1} = 0``)."""
    span = simply_supported_span(SECTION, LB, 4)
    track = Track3D(conicity=LAM, eccentricity=0.0, rail_height=H_T)
    system = System3D(car, span, track, speed=0.0, start=LB / 2)
    st = static_state(system)
    W = weight(car)
    masses = np.diag(car.M)[[car.index("z_body"), car.index("z_ws")]]
    m = masses.sum()
    z_cm = lambda q: (masses @ q[[car.index("z_body"), car.index("z_ws")]]) / m  # noqa: E731
    cm0 = z_cm(st.q)
    system.load = body_load(car, pull=1.5 * W)
    stepper = method(system, st, DT)
    P, flying, cm, gaps, z_w, w_rail = [], [], [], [], [], []
    for n in range(PULL_STEPS + FREE_STEPS):
        if n == PULL_STEPS:
            system.load = None
        s = stepper.step(n)
        P.append(s.P.copy())
        flying.append(~s.contact[:2])
        cm.append(z_cm(s.q))
        gaps.append(stepper.gaps())
        z_w.append(s.q[car.index("z_ws")])
        w_rail.append(s.u[span.dof(2, "w")])
    P, flying, gaps = np.array(P), np.array(flying), np.array(gaps)
    # both wheels leave at once and carry nothing while the pull lasts
    assert flying[:PULL_STEPS].all() and (P[:PULL_STEPS] == 0.0).all()
    # the centre of mass on the parabola of the net force: Newmark is exact for a constant force,
    # once the step load at t = 0 (accelerations zero at t = 0, ``a`` from t_1 on) has gone through
    # the first step's trapezoid: ``a dt^2 (n^2 - n + 1/2) / 2``
    a = (1.5 * W - W) / m
    n = np.arange(1, PULL_STEPS + 1)
    flight = a * DT**2 * (n**2 - n + 0.5) / 2
    assert np.array(cm[:PULL_STEPS]) - cm0 == pytest.approx(flight, rel=1e-9, abs=1e-13)
    # the gap of a centred wheelset: (z_w - w) cos(delta) (rail at the section's centre, no twist)
    opened = (np.array(z_w) - np.array(w_rail)) * COS
    assert gaps[:PULL_STEPS, 0] == pytest.approx(opened[:PULL_STEPS], rel=1e-9, abs=1e-15)
    assert gaps[:PULL_STEPS, 1] == pytest.approx(opened[:PULL_STEPS], rel=1e-9, abs=1e-15)
    # released, it falls back and lands: forces never tensile, the gaps closed again afterwards
    landed = np.flatnonzero(~flying[:, 0])
    assert landed.size and landed[0] > PULL_STEPS
    assert (P >= 0.0).all()
    assert (gaps >= -1e-12).all()
    assert np.abs(gaps[landed[0] :]).max() < 1e-6
    assert not flying[-20:].any()


def test_light_wheelset_on_a_bouncing_deck():
    """A 1 kg wheelset standing at midspan on a span vibrating in its first vertical mode, 3 cm at
    midspan, starting at the lowest point: it leaves the deck when the deck's downward acceleration
    exceeds ``g`` (``w(t) = -A cos(omega t)``, ``t_lift = arccos(-g / (omega^2 A)) / omega``) and lands
    where its free flight from there (``z = w + w' s - g s^2 / 2``) meets the deck again. The wheelset's
    mass moves the deck by a few 1e-5 of itself; the steps find each event at the first step past
    it (within one step)."""
    vehicle = vehicle3d(parse_topology3d(WHEELSET))
    for dof, k in (("y_ws", 100.0), ("psi_ws", 100.0)):  # springs to the ground: centring only
        i = vehicle.index(dof)
        vehicle.K[i, i] += k
    L, E, Iy, MU, A = 25.0, 2.87e9, 2.9, 2303.0, 0.03
    span = simply_supported_span(Section3D(E=E, A=1.0, I_y=Iy, I_z=10.0, J=5.0, mass_per_length=MU), L, 8)
    f = span.free
    w_free = np.array([i for i, d in enumerate(f) if d % 6 == 2])  # the vertical DOFs w
    vals, vecs = eigh(span.K[np.ix_(f, f)], span.M[np.ix_(f, f)])
    vertical = [j for j in range(len(vals)) if np.abs(vecs[w_free, j]).max() > 0.5 * np.abs(vecs[:, j]).max()]
    omega = float(np.sqrt(vals[vertical[0]]))
    mode = np.zeros(span.M.shape[0])
    mode[f] = vecs[:, vertical[0]]
    mode /= mode[span.dof(4, "w")]
    track = Track3D(conicity=LAM)
    system = System3D(vehicle, span, track, speed=0.0, start=L / 2)
    g = GRAVITY
    q = np.zeros(len(vehicle.dof_names))
    q[vehicle.index("z_ws")] = -A
    qdd = np.zeros_like(q)
    qdd[vehicle.index("z_ws")] = omega**2 * A
    m = vehicle.M[vehicle.index("z_ws"), vehicle.index("z_ws")]
    P = np.full(2, m * (omega**2 * A - vehicle.F[vehicle.index("z_ws")] / m) / (2 * COS))
    state = State3D(0.0, q, np.zeros_like(q), qdd, -A * mode, 0 * mode, omega**2 * A * mode, P)
    dt = 1e-3
    stepper = CoupledDynamic3D(system, state, dt)
    flying = []
    for n in range(300):
        flying.append(not stepper.step(n).contact[0])
    flying = np.array(flying)
    t = dt * np.arange(1, flying.size + 1)
    t_lift_step = t[np.argmax(flying)]
    t_land_step = t[np.argmax(flying & ~np.roll(flying, -1))] + dt  # first step back in contact

    w = lambda s: -A * np.cos(omega * s)  # noqa: E731
    wd = lambda s: A * omega * np.sin(omega * s)  # noqa: E731
    t_lift = np.arccos(-g / (omega**2 * A)) / omega
    z = lambda s: w(t_lift) + wd(t_lift) * (s - t_lift) - 0.5 * g * (s - t_lift) ** 2  # noqa: E731
    t_land = brentq(lambda s: z(s) - w(s), t_lift + 1e-4, t_lift + 2 * np.pi / omega)
    assert 0.0 <= t_lift_step - t_lift < dt
    assert 0.0 <= t_land_step - t_land < dt


def test_localized_is_coupled_with_creep_flange_and_lift_off(car):
    """The car rolling at 20 m/s with creep along an eccentric, raised track (dt = 1e-4 s: this
    light wheelset's explicit yaw creep needs it): a lateral load on its body drives the wheelset
    against a 0.05 mm flange clearance, and an upward pull on the wheelset for 40 steps lifts it off
    the rail; it lands. Both steppers from the same static state, the same loads."""
    span = simply_supported_span(SECTION, LB, 4)
    track = Track3D(conicity=LAM, eccentricity=E_T, rail_height=H_T, flange_clearance=5e-5)
    system = System3D(car, span, track, speed=20.0, start=3.0, creep=CreepParameters())
    st0 = static_state(system)
    series = []
    for cls in (CoupledDynamic3D, LocalizedDynamic3D):
        st = State3D(**{k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in vars(st0).items()})
        system.load = body_load(car, lateral=6000.0)
        stepper = cls(system, st, 1e-4)
        rows, events = [], set()
        for n in range(200):
            system.load = body_load(car, 6000.0, 1.5 * weight(car) if 100 <= n < 140 else 0.0)
            s = stepper.step(n)
            events.update(f"{k}{int(c)}" for k, c in enumerate(s.contact))
            rows.append(
                np.concatenate(
                    [s.q, s.u[span.dof(2, "v") : span.dof(2, "psi") + 1], s.P, s.flange, s.creep.reshape(-1)]
                )
            )
        series.append(np.array(rows))
    # the run has a flange contact, a lift-off and a landing
    assert {"00", "10", "21"} <= events
    coupled, localized = series
    assert (coupled[-1, -12:] != 0).any()  # creep forces after landing
    peak = np.abs(coupled).max(axis=0)
    live = peak > 0
    assert live.sum() > 15
    err = np.abs(localized - coupled).max(axis=0)[live] / peak[live]
    assert err.max() < 1e-10


def test_explicit_creep_refuses_an_unstable_time_step(car):
    """Lagged by one step, a wheelset's creep force is a damper of rate ``k``; ``k dt > 1`` is
    refused with the largest admissible step (as in 2D). This wheelset's yaw: ``2 f11 b^2 /
    (I_z v)``, about 1.5e4 1/s at 5 m/s."""
    span = simply_supported_span(SECTION, LB, 4)
    system = System3D(car, span, Track3D(conicity=LAM), speed=5.0, start=3.0, creep=CreepParameters())
    st = static_state(system)
    with pytest.raises(
        ValueError, match=r"wheelset 'ws' are unstable at dt = 0.001 s \((lateral|yaw) .*take dt <="
    ):
        CoupledDynamic3D(system, st, DT)
    LocalizedDynamic3D(system, st, 5e-5)  # k dt below 1


def test_the_flange_sees_the_alignment_the_run_sets(car):
    """A run sets the rail irregularities under each wheelset on the step's contact kernels
    (``stepper.kernels[w].irregularity``); the flange gaps must see the same alignment ``r_a`` (the
    track centreline moves by it: ``g_F,s = c_f - s (y_w - y_r)``, ``y_r`` including ``r_a``)."""
    span = simply_supported_span(SECTION, LB, 4)
    track = Track3D(conicity=LAM, eccentricity=E_T, rail_height=H_T, flange_clearance=CLEARANCE)
    system = System3D(car, span, track, speed=0.0, start=LB / 2)
    stepper = CoupledDynamic3D(system, static_state(system), DT)
    before = np.array(stepper.flange_gaps())
    shift = 1.5e-3
    rough = np.zeros(9)
    rough[1] = shift  # the alignment, m to the left
    stepper.kernels[0].irregularity = rough
    after = np.array(stepper.flange_gaps())
    assert after - before == pytest.approx([shift, -shift], abs=1e-15)


@pytest.mark.parametrize("method", [LocalizedDynamic3D, CoupledDynamic3D])
def test_a_landing_on_a_rough_rail_stops_the_wheels_on_it(car, method):
    """A run sets the rail irregularities only on the step's contact kernels
    (:class:`SteppedChunks`); the impact of a landing must stop the wheels on that rail. The car at
    20 m/s on a rail of constant slope ``r_v' = 2e-4`` and curvature ``r_v'' = 1e-4 1/m`` (the rail
    rises at ``v r_v' = 4 mm/s``), its wheelset pulled up for 40 steps: both wheels land at the same
    step, after which the plastic impact's conditions hold, ``g' = 0`` and ``g'' = 0`` at the
    landing wheels, here written out with the gap rates of contact kernels of the test's own that
    see the rail (``g''`` the residual with ``c1 = c0 = 0``, ``g'`` that with ``c1 = 1`` less it).
    Measured with the rail unseen by the impact: ``g' = -4.0e-3 m/s`` (the rail's rise) and ``g'' =
    -0.040 m/s^2``; seen: below 1e-11."""
    span = simply_supported_span(SECTION, LB, 4)
    system = System3D(
        car, span, Track3D(conicity=LAM, eccentricity=E_T, rail_height=H_T), speed=20.0, start=3.0
    )
    weight = -(car.F[car.index("z_body")] + car.F[car.index("z_ws")])
    rough = np.array([0.0, 0.0, 0.0, 2e-4, 0.0, 0.0, 1e-4, 0.0, 0.0])
    stepper = method(system, static_state(system), 1e-4)
    chunks = SteppedChunks(stepper)
    ws = system.vehicle.wheelsets[0]
    le = span.length / span.n_elements
    rates = [ContactKernel3D(ws, system.track, le, system.speed, c1, 0.0) for c1 in (0.0, 1.0)]
    for kernel in rates:
        kernel.irregularity = rough
    landings = 0
    for n in range(200):
        system.load = body_load(car, pull=1.5 * weight if 100 <= n < 140 else 0.0)
        before = stepper.state.contact[:2].copy()
        chunks.advance(n, 1, rough[None, None, :], 1)
        st = stepper.state
        if (before | ~st.contact[:2]).all():
            continue
        landings += 1
        assert st.contact[:2].all() and not before.any()  # both wheels at once
        (e, xi), ground = system.contact_location(st.t)[0], system.ground_under(st.t)
        z, zd, zdd = (
            stepper.asm.z(0, e, a, b, g)
            for a, b, g in zip((st.q, st.qd, st.qdd), (st.u, st.ud, st.udd), ground, strict=True)
        )
        gtt, gt1 = (kernel.residual(z, zd, zdd, xi) for kernel in rates)
        assert np.abs(gt1 - gtt).max() < 1e-11  # g' (m/s)
        assert np.abs(gtt).max() < 1e-9  # g'' (m/s^2)
    assert landings == 1
