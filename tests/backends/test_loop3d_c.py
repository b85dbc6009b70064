"""The compiled 3D localized-dynamic loop (runtime/csrc/loop3d, runtime/backends/c/stepper3d.py)
against the NumPy step it compiles (:class:`LocalizedDynamic3D`, stepped here), on small systems:

* a train of two cars over a chain of two spans with vertical, alignment and cross-level
  irregularities, bilateral and unilateral normal contact, creep on, in chunks of steps;
* the car lifted off by an upward pull and landing again, with a flange contact and creep (the
  event-rich case of tests/methods/test_unilateral3d_step.py);
* a flange closing under a lateral load (a plastic impact on the flange);
* a three-component travelling earthquake with the car crossing from the approach track onto a
  two-span chain (tests/methods/test_quake3d_step.py);
* a girder continuous over two spans on a pier;
* spans of different lengths (their elements too): two cars with rough rails and creep crossing
  joints, and a car from the approach track under the earthquake.

Every series (each DOF of ``q`` and ``u``, each contact's ``P``, flange force and creep force
component) within 1e-10 of its own peak (2e-10 in the lift-off case, see there; series below 1e-12
of the largest of their kind are round-off of quantities that do not move and are left out), the
same contact states at every step, and the normal gaps at the output steps. The contact kernels
are the same generated expressions in both (NumPy and C emitted from one CasADi graph), the linear
algebra differs (band Cholesky and dense LU against NumPy's dense inverses), and so does the
interface iteration: the C loop's iterations after a pass's first are chord iterations on the
matrix that iteration factored, the NumPy step forms and solves a new matrix at every iteration;
both stop by the same rule at the same solution. So the two agree to round-off, amplified over the
events of a run. The lift-off case also runs the C loop with Newton at every iteration.
"""

from __future__ import annotations

import numpy as np
import pytest
from cases import SW_CONICITY, SW_DECK, copy_state3d, ground_bump, sprung_wheelset3d

from svbi.runtime.backends.c.stepper3d import CHORD_RATE, LocalizedDynamic3DC, vehicle_blocks
from svbi.runtime.methods.chunk3d import SteppedChunks
from svbi.runtime.methods.coupled3d import static_state
from svbi.runtime.methods.localized3d import LocalizedDynamic3D
from svbi.runtime.model.bridge import Girder, Pier, Section
from svbi.runtime.model.bridge3d import Bridge3D, section3d
from svbi.runtime.model.creep_law import CreepParameters
from svbi.runtime.model.ground import FunctionGround
from svbi.runtime.model.span3d import Section3D, simply_supported_span
from svbi.runtime.model.system3d import System3D, Track3D
from svbi.runtime.model.train3d import train3d

try:  # the compiler is needed
    from svbi.runtime.backends.c.stepper3d import load_loop3d

    load_loop3d()
except Exception as exc:  # pragma: no cover - no C compiler
    pytest.skip(f"no C compiler for the 3D loop: {exc}", allow_module_level=True)

LAM = SW_CONICITY
DECK = Section(**SW_DECK, damping_ratio=0.02)
PIER = Section(mass_per_length=12e3, youngs_modulus=3.0e10, area=5.0, second_moment=4.0, damping_ratio=0.05)
TOLERANCE = 1e-10


def car():
    """The damped sprung wheelset (tests/cases.py)."""
    return sprung_wheelset3d(damped=True)


copy = copy_state3d


def irregularity(system: System3D, t: float) -> np.ndarray:
    """Smooth vertical, alignment and cross-level irregularities (m, rad) with their slopes and
    curvatures along x, under each wheelset at ``t``."""
    x = system.positions(t)
    out = np.zeros((x.size, 9))
    for c, (a, k) in enumerate(((1.5e-3, 0.6), (1.0e-3, 0.45), (4e-4, 0.8))):
        out[:, c] = a * np.sin(k * x)
        out[:, 3 + c] = a * k * np.cos(k * x)
        out[:, 6 + c] = -a * k * k * np.sin(k * x)
    return out


def run_numpy(system, state, dt, steps, normal, rough=False, loads=None):
    stepper = LocalizedDynamic3D(system, copy(state), dt, normal=normal)
    rows, contact, gaps = [], [], []
    for n in range(steps):
        if loads is not None:
            system.load = loads(n)
        if rough:
            stepper.set_irregularity(irregularity(system, (n + 1) * dt))
        s = stepper.step(n)
        rows.append(np.concatenate([s.q, s.u, s.P, s.flange, s.creep.reshape(-1)]))
        contact.append(s.contact.copy())
        gaps.append(stepper.gaps())
    return np.array(rows), np.array(contact), np.array(gaps)


def run_c(
    system,
    state,
    dt,
    steps,
    normal,
    rough=False,
    loads=None,
    chunk=50,
    every=5,
    chord=True,
    kept=None,
    chord_rate=CHORD_RATE,
):
    stepper = LocalizedDynamic3DC(system, copy(state), dt, normal=normal, chord=chord, chord_rate=chord_rate)
    if kept is not None:
        kept.append(stepper)
    rows, contact, gaps = [], [], []
    n = 0
    while n < steps:
        k = 1 if loads is not None else min(chunk, steps - n)
        if loads is not None:
            system.load = loads(n)
        level = np.array(
            [
                irregularity(system, (m + 1) * dt) if rough else 0.0 * irregularity(system, 0.0)
                for m in range(n, n + k)
            ]
        )
        ch = stepper.advance(n, k, level, every)
        assert stepper.stopped is None and len(ch) == k
        rows.append(np.hstack([ch.q, ch.u, ch.P, ch.flange, ch.creep.reshape(k, -1)]))
        contact.append(ch.contact)
        gaps.append(ch.gaps)
        n += k
    assert stepper.state.t == pytest.approx(steps * dt, rel=1e-14)
    return np.vstack(rows), np.vstack(contact), np.vstack(gaps)


def agree(system, a, b, every=5, tolerance=TOLERANCE) -> float:
    """The largest difference of each series over its peak; asserts the tolerance."""
    (rows_a, contact_a, gaps_a), (rows_b, contact_b, gaps_b) = a, b
    assert (contact_a == contact_b).all()
    peak = np.abs(rows_a).max(axis=0)
    nV, nB = len(system.vehicle.dof_names), system.span.M.shape[0]
    kinds = np.split(np.arange(peak.size), [nV, nV + nB])
    live = np.zeros(peak.size, dtype=bool)
    for cols in kinds:
        live[cols] = peak[cols] > 1e-12 * peak[cols].max()
    err = np.abs(rows_a - rows_b).max(axis=0)[live] / peak[live]
    assert err.max() < tolerance, err.max()
    # the normal gaps at the output steps (every 5th), NaN at the others
    out = (np.arange(len(rows_a)) + 1) % every == 0
    assert np.isnan(gaps_b[~out]).all()
    scale = np.abs(gaps_a).max() + 1e-6
    assert np.abs(gaps_b[out] - gaps_a[out]).max() < 1e-9 * scale
    return float(err.max())


def c_equals_numpy(system, dt, steps, normal, rough=False, loads=None, tolerance=TOLERANCE):
    """The NumPy step and the C loop from the same static state of ``system``, held to each other
    (:func:`agree`); returns the NumPy run ``(rows, contact states, gaps)``."""
    state = static_state(system)
    a = run_numpy(system, state, dt, steps, normal, rough=rough, loads=loads)
    b = run_c(system, state, dt, steps, normal, rough=rough, loads=loads)
    agree(system, a, b, tolerance=tolerance)
    return a


@pytest.mark.parametrize("normal", ["bilateral", "unilateral"])
def test_train_over_a_chain_with_irregularities_and_creep(normal) -> None:
    """Two cars at 20 m/s on a two-span chain (the leading car's wheelset on the second span),
    rough rails in three directions, creep on: 300 steps of 1e-4 s in chunks of 50."""
    train = train3d([car(), car()], 6.0)
    bridge = Bridge3D([Girder((10.0,), DECK)] * 2, 4, [section3d(DECK, 10.0, 5.0)] * 2)
    system = System3D(
        train,
        bridge,
        Track3D(conicity=LAM, eccentricity=0.2, rail_height=0.8),
        speed=20.0,
        start=13.0,
        bridge_damping=bridge.C,
        creep=CreepParameters(),
    )
    a = c_equals_numpy(system, 1e-4, 300, normal, rough=True)
    assert np.abs(a[0][:, -24:]).max() > 0  # creep forces


def test_wheelsets_on_one_span_one_on_its_first_element() -> None:
    """Two cars on the second span of a chain, one wheelset on the span's first element (whose node
    on the support line has its translations and twist held), the other further on: the bridge's
    compliance couples them (the two elements' free DOFs lie in the same part of the structure,
    although the straight girder's axial, lateral, vertical and torsional DOFs do not couple in its
    stiffness). Rough rails, creep, unilateral contact."""
    train = train3d([car(), car()], 3.0)
    bridge = Bridge3D([Girder((10.0,), DECK)] * 2, 4, [section3d(DECK, 10.0, 5.0)] * 2)
    system = System3D(
        train,
        bridge,
        Track3D(conicity=LAM, eccentricity=0.2, rail_height=0.8),
        speed=20.0,
        start=13.9,
        bridge_damping=bridge.C,
        creep=CreepParameters(),
    )
    assert [e for e, _ in system.contact_location(0.03)] == [5, 4]
    c_equals_numpy(system, 1e-4, 300, "unilateral", rough=True)


def landing_next_to_supports() -> System3D:
    """Three cars at 80 m/s standing on the last two elements of the second span and the first two
    of the third of a three-span chain at t = 0 (two wheelsets on the third span, one on its first
    element), creep: on rough rails every wheel lifts off in the first steps and they land over the
    next 80 (test_several_wheels_landing_next_to_supports)."""
    train = train3d([car(), car(), car()], 2.0)
    bridge = Bridge3D([Girder((10.0,), DECK)] * 3, 4, [section3d(DECK, 10.0, 5.0)] * 3)
    return System3D(
        train,
        bridge,
        Track3D(conicity=LAM, eccentricity=0.2, rail_height=0.8),
        speed=80.0,
        start=23.0,
        bridge_damping=bridge.C,
        creep=CreepParameters(),
    )


def test_several_wheels_landing_next_to_supports() -> None:
    """Three cars at 80 m/s standing on the last two elements of the second span and the first two
    of the third of a three-span chain at t = 0 (two wheelsets on the third span, one on its first
    element), rough rails, creep: every wheel lifts off in the first steps and they land over the
    next 80, both wheels of the wheelset next to the second support at the same step."""
    system = landing_next_to_supports()
    assert [e for e, _ in system.contact_location(0.0)] == [9, 8, 7]
    a = c_equals_numpy(system, 1e-4, 120, "unilateral", rough=True)
    normal = a[1][:, np.tile([True, True, False, False], 3)]
    landing = normal[1:] & ~normal[:-1]
    assert landing.sum() >= 5 and landing.sum(axis=1).max() == 2


def test_a_landing_on_a_rough_rail_as_a_run_steps_it() -> None:
    """The NumPy step as a run drives it (:class:`SteppedChunks`: the irregularity set on the step's
    contact kernels only) against the C loop, through a landing of both wheels on a rail of constant
    slope and curvature (tests/methods/test_unilateral3d_step.py's case): the impact of both sees
    the rail. Measured when the NumPy impact did not: 0.26 of the peak normal force; now 1.6e-10 of
    its peak on the wheelset's roll (8.5e-7 rad, four orders below the car's bounce), 4e-11 on the
    normal forces: held to 2e-10, as the lift-off case below."""
    vehicle = car()
    span = simply_supported_span(
        Section3D(E=3.0e10, A=5.0, I_y=3.0, I_z=20.0, J=4.0, mass_per_length=12000.0), 10.0, 4
    )
    track = Track3D(conicity=LAM, eccentricity=0.3, rail_height=1.2)
    rough = np.array([0.0, 0.0, 0.0, 2e-4, 0.0, 0.0, 1e-4, 0.0, 0.0])[None, None, :]
    weight = -(vehicle.F[vehicle.index("z_body")] + vehicle.F[vehicle.index("z_ws")])
    out = []
    system = System3D(vehicle, span, track, speed=20.0, start=3.0)
    for step in (LocalizedDynamic3D, LocalizedDynamic3DC):
        stepper = step(system, static_state(system), 1e-4)
        numpy = step is LocalizedDynamic3D
        chunks = SteppedChunks(stepper) if numpy else stepper
        rows, contact, gaps = [], [], []
        for n in range(200):
            load = np.zeros(len(vehicle.dof_names))
            load[vehicle.index("z_ws")] = WEIGHT_PULL * weight if 100 <= n < 140 else 0.0
            system.load = load
            ch = chunks.advance(n, 1, rough, 1 if numpy else 5)  # agree's gaps
            rows.append(np.concatenate([ch.q[0], ch.u[0], ch.P[0], ch.flange[0], ch.creep[0].ravel()]))
            contact.append(ch.contact[0])
            gaps.append(ch.gaps[0])
        out.append((np.array(rows), np.array(contact), np.array(gaps)))
    contact = out[0][1]
    assert not contact[150, :2].any() and contact[-1, :2].all()  # the wheels off, then landed
    agree(system, *out, tolerance=2e-10)


WEIGHT_PULL = 1.5


def test_lift_off_landing_and_flange_with_creep() -> None:
    """The car at 20 m/s with creep along an eccentric, raised track, a lateral load on its body
    against a 0.05 mm flange clearance and an upward pull on the wheelset for 40 steps: both wheels
    lift off and land (an impact), the flange closes.

    The loops' round-off differs (band and dense solves against NumPy's inverses; chord iterations
    against Newton's) and the events amplify it more than in the other cases: measured 1.12e-10 of
    its peak on the right contact's spin moment (peak 1.3 N m, three orders below its creep
    forces), 1.05e-10 on a longitudinal deck DOF that only the creep forces move (peak 6e-10 m),
    9.2e-11 on a normal force; held to 2e-10 here."""
    vehicle = car()
    span = simply_supported_span(
        Section3D(E=3.0e10, A=5.0, I_y=3.0, I_z=20.0, J=4.0, mass_per_length=12000.0), 10.0, 4
    )
    track = Track3D(conicity=LAM, eccentricity=0.3, rail_height=1.2, flange_clearance=5e-5)
    system = System3D(vehicle, span, track, speed=20.0, start=3.0, creep=CreepParameters())
    state = static_state(system)
    weight = -(vehicle.F[vehicle.index("z_body")] + vehicle.F[vehicle.index("z_ws")])

    def loads(n: int) -> np.ndarray:
        load = np.zeros(len(vehicle.dof_names))
        load[vehicle.index("y_body")] = 6000.0
        load[vehicle.index("z_ws")] = WEIGHT_PULL * weight if 100 <= n < 140 else 0.0
        return load

    a = run_numpy(system, state, 1e-4, 200, "unilateral", loads=loads)
    steppers: list[LocalizedDynamic3DC] = []
    b = run_c(system, state, 1e-4, 200, "unilateral", loads=loads, kept=steppers)
    c = run_c(system, state, 1e-4, 200, "unilateral", loads=loads, chord=False, kept=steppers)
    # every chord that has not converged followed by Newton (rate 0): the switch back to Newton
    d = run_c(system, state, 1e-4, 200, "unilateral", loads=loads, chord_rate=0.0, kept=steppers)
    events = {f"{k}{int(c)}" for row in a[1] for k, c in enumerate(row)}
    assert {"00", "10", "21"} <= events  # lift-off, landing, flange
    agree(system, a, b, tolerance=2e-10)
    # Newton at every iteration (the NumPy step's iteration) reaches the same solution, and the
    # chord iterations ran: one factorisation per active-set pass, the other iterations chords
    agree(system, a, c, tolerance=2e-10)
    agree(system, a, d, tolerance=2e-10)
    chord, newton, switching = steppers
    assert newton.factorizations == newton.iterations
    assert chord.factorizations == chord.passes < chord.iterations
    assert chord.passes < switching.factorizations < switching.iterations


def test_flange_closing_under_a_lateral_load() -> None:
    """A lateral load set on at t = 0 drives the standing car's wheelset against its flange."""
    vehicle = car()
    span = simply_supported_span(
        Section3D(E=3.0e10, A=5.0, I_y=3.0, I_z=20.0, J=4.0, mass_per_length=12000.0), 10.0, 4
    )
    track = Track3D(conicity=LAM, eccentricity=0.3, rail_height=1.2, flange_clearance=0.005)
    system = System3D(vehicle, span, track, speed=0.0, start=5.0)
    load = np.zeros(len(vehicle.dof_names))
    load[vehicle.index("y_body")] = 2000.0
    system.load = load
    a = c_equals_numpy(system, 1e-3, 300, "unilateral")
    assert a[1][:, 2].any()  # the flange closed


def quake_crossing(bridge: Bridge3D, start: float) -> System3D:
    """The sprung wheelset at 100 km/h from ``start`` on the approach track onto ``bridge``, 2 %
    damping, on an eccentric raised track, under three components of a wave travelling at 300 m/s."""
    c = 300.0
    ground = FunctionGround(
        vertical=ground_bump(0.005, 2 * np.pi * 1.0, 0.05, c),
        longitudinal=ground_bump(-0.03, 2 * np.pi * 2.0, 0.05, c),
        lateral=ground_bump(0.001, 2 * np.pi * 1.0, 0.05, c),
        apparent_velocity=c,
    )
    return System3D(
        sprung_wheelset3d(),
        bridge,
        Track3D(conicity=LAM, eccentricity=0.3, rail_height=0.8),
        speed=100.0 / 3.6,
        start=start,
        bridge_damping=bridge.C,
        ground=ground,
    )


def test_travelling_earthquake_and_the_approach_track() -> None:
    """Three components of a wave travelling at 300 m/s, 2 % damping, the car crossing from the
    approach track onto a two-span chain on an eccentric raised track (tests/methods/
    test_quake3d_step.py's case), dt = 2e-3 s, 250 steps in chunks of 50."""
    bridge = Bridge3D([Girder((10.0,), DECK)] * 2, 8, [section3d(DECK, 10.0, 5.0)] * 2)
    c_equals_numpy(quake_crossing(bridge, start=-3.0), 2e-3, 250, "unilateral")


def test_continuous_girder_on_a_pier() -> None:
    """A girder continuous over two 10 m spans, its middle support on a 6 m pier (bearings on
    springs), two cars with creep and rough rails."""
    girder = Girder((10.0, 10.0), DECK, fixed_support=1)
    bridge = Bridge3D(
        [girder],
        4,
        [section3d(DECK, 10.0, 5.0)],
        [Pier(1, 6.0, PIER, bearing_vertical=4e9)],
        [section3d(PIER, 9.0, 6.0, poisson_ratio=0.25)],
        [3e8],
    )
    system = System3D(
        train3d([car(), car()], 6.0),
        bridge,
        Track3D(conicity=LAM, rail_height=0.8),
        speed=20.0,
        start=14.0,
        bridge_damping=bridge.C,
        creep=CreepParameters(),
    )
    c_equals_numpy(system, 1e-4, 200, "unilateral", rough=True)


def test_spans_of_different_lengths_with_irregularities_and_creep() -> None:
    """Spans of 6 m, then a girder continuous over 10 m and 8 m (elements of 1.5 m, 2.5 m and 2 m):
    two cars 10 m apart, their wheelsets crossing the joints at 6 m and 16 m (each onto elements of
    another length), rough rails in three directions, creep on, 300 steps of 1e-4 s in chunks of 50."""
    bridge = Bridge3D(
        [Girder((6.0,), DECK), Girder((10.0, 8.0), DECK, fixed_support=1)],
        4,
        [section3d(DECK, 10.0, 5.0)] * 2,
    )
    assert bridge.deck_element_length.tolist() == [1.5] * 4 + [2.5] * 4 + [2.0] * 4
    system = System3D(
        train3d([car(), car()], 10.0),
        bridge,
        Track3D(conicity=LAM, eccentricity=0.2, rail_height=0.8),
        speed=20.0,
        start=15.8,
        bridge_damping=bridge.C,
        creep=CreepParameters(),
    )
    before = [e for e, _ in system.contact_location(0.0)]
    after = [e for e, _ in system.contact_location(300 * 1e-4)]
    assert before == [7, 3] and after == [8, 4]  # both wheelsets change span
    a = c_equals_numpy(system, 1e-4, 300, "unilateral", rough=True)
    assert np.abs(a[0][:, -24:]).max() > 0  # creep forces


def test_spans_of_different_lengths_from_the_approach_under_an_earthquake() -> None:
    """The travelling three-component earthquake of the test above, the car crossing from the
    approach track onto a chain of a 6 m and a 10 m span (elements of 1.5 m and 2.5 m), dt = 2e-3 s,
    250 steps in chunks of 50."""
    bridge = Bridge3D([Girder((6.0,), DECK), Girder((10.0,), DECK)], 4, [section3d(DECK, 10.0, 5.0)] * 2)
    system = quake_crossing(bridge, start=-1.0)
    assert [e for e, _ in system.contact_location(250 * 2e-3)] == [6]  # on the 10 m span
    c_equals_numpy(system, 2e-3, 250, "unilateral")


def test_vehicle_blocks_are_the_cars() -> None:
    """The C loop's vehicle compliance is per car: a train's matrices split at the cars, a
    wheelset's DOFs in one block."""
    one = car()
    train = train3d([one, one, one], 6.0)
    n = len(one.dof_names)
    blocks = vehicle_blocks(train.M, train.C, train.K, together=[w.dofs for w in train.wheelsets])
    assert [b for b in blocks if b[0] % n == 0 and b[1] % n == 0] == blocks
    assert {s // n for s, _ in blocks} == {0, 1, 2}


def test_a_non_finite_state_stops_the_loop_at_its_step() -> None:
    """A NaN in the state: the loop stops at the first step, the chunk is empty and ``stopped``
    names the step and the reason (as the 2D loop's guard)."""
    bridge = Bridge3D([Girder((10.0,), DECK)], 4, [section3d(DECK, 10.0, 5.0)])
    system = System3D(car(), bridge, Track3D(conicity=LAM), speed=10.0, start=4.0)
    stepper = LocalizedDynamic3DC(system, static_state(system), 1e-3)
    good = stepper.advance(0, 5, np.zeros((5, 1, 9)), 1)
    assert len(good) == 5 and stepper.stopped is None
    stepper.state.q[0] = np.nan
    chunk = stepper.advance(5, 5, np.zeros((5, 1, 9)), 1)
    assert len(chunk) == 0
    assert stepper.stopped == "the 3D C loop stopped at step 6 (t = 0.006 s): non-finite state"


def test_refusals(monkeypatch) -> None:
    import svbi.runtime.backends.c.stepper3d as s3

    bridge = Bridge3D([Girder((10.0,), DECK)], 4, [section3d(DECK, 10.0, 5.0)])
    system = System3D(train3d([car(), car()], 6.0), bridge, Track3D(conicity=LAM), speed=10.0, start=9.0)
    state = static_state(system)
    monkeypatch.setattr(s3, "MAX_WHEELSETS", 1)
    with pytest.raises(ValueError, match="at most 1 wheelsets .* this train has 2"):
        LocalizedDynamic3DC(system, copy(state), 1e-3)
    monkeypatch.setattr(s3, "MAX_WHEELSETS", 256)
    monkeypatch.setattr(s3, "MAX_FREE_DOFS", 10)
    with pytest.raises(ValueError, match="at most 10 free DOFs"):
        LocalizedDynamic3DC(system, copy(state), 1e-3)


@pytest.mark.parametrize("wave", [None, 300.0, "per-line"])
def test_the_excitation_of_a_chunk_is_the_steps_own(wave) -> None:
    """The excitation a chunk hands to C, vectorised over its steps for the ground of a scenario
    (synthetic three-component record, synchronous, travelling or one record per support line): the
    same numbers, bit for bit, as the NumPy step's ``contact_location``, ``ground_under`` and
    ``support_targets`` step by step."""
    from pathlib import Path

    from svbi.runtime.run.simulate3d import build_run3d
    from svbi.runtime.scenario.schema import load_scenario

    example = Path(__file__).resolve().parents[2] / "examples" / "paper-2020-3d.toml"
    overrides = {
        "bridge.spans": 3,
        "train.cars": 1,
        "train.start_position": 40.0,
        "solver.duration": 0.01,
        "earthquake.arrival": 0.0,
    }
    if wave == "per-line":  # the 3 spans' 4 support lines
        overrides |= {
            "earthquake.vertical": ["synthetic", "none", "synthetic", "synthetic"],
            "earthquake.lateral": ["none", "synthetic", "synthetic", "none"],
        }
    elif wave:
        overrides |= {"earthquake.apparent_velocity": wave}
    run = build_run3d(load_scenario(example, overrides=overrides))
    stepper = LocalizedDynamic3DC(run.system, static_state(run.system), 1e-4)
    n0, k = (1500 if wave == 300.0 else 7), 30  # the wave reaches the train (40 m on) at 0.13 s
    ex = stepper.excitation(n0, k, np.zeros((k, 4, 9)))
    ground, support = stepper._quake_loop(ex.t)
    assert np.array_equal(ex.ground, ground) and np.array_equal(ex.support, support)
    assert np.abs(ground).max() > 0 and np.abs(support).max() > 0
    for s, t in enumerate(ex.t):
        assert t == (n0 + s + 1) * 1e-4
        loc = run.system.contact_location(float(t))
        assert ex.element[s].tolist() == [e for e, _ in loc] and ex.xi[s].tolist() == [x for _, x in loc]
