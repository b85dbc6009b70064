"""The run of a 3D scenario (docs/three-d.md, "3D runs"): ``svbi.simulate`` and ``svbi run`` come
here when ``scenario.dimensions == 3``.

The scenario becomes a :class:`~svbi.runtime.model.bridge3d.Bridge3D` (shorthand or long form, piers
included), a train of ``train.cars`` 3D cars (:func:`~svbi.runtime.model.system3d.vehicle3d`,
:func:`~svbi.runtime.model.train3d.train3d`, spaced by the vehicle's ``car_length`` as 2D trains
are), the cone-and-knife-edge track of :func:`~svbi.runtime.scenario.build.track_geometry_3d` and a
:class:`~svbi.runtime.model.system3d.System3D`. The steps are those of
:mod:`svbi.runtime.methods.localized3d`, :mod:`svbi.runtime.methods.coupled3d` and
:mod:`svbi.runtime.methods.classic3d`, advanced a chunk
of steps at a time through the chunk interface (``advance(n0, k, irregularity, every)`` returning a
:class:`~svbi.runtime.methods.chunk3d.Chunk3D`; :class:`~svbi.runtime.methods.chunk3d.SteppedChunks`
for the NumPy steps). Each chunk fills its rows of
:class:`~svbi.runtime.run.results3d.Histories3D` at once (``_Recorder3D.record_chunk``, vectorised
over the steps and the wheelsets); the vertical variables of the 2D results (``midspan_uz``,
``deck_acceleration``, ``carbody_az``, ...) are recorded every ``output_every`` steps and given to
:func:`~svbi.runtime.run.results3d.dataset3d` as its ``base``.

The ground of ``[earthquake]`` (vertical, longitudinal and lateral components, per support line or
travelling) moves the 3D bridge's supports; wheelsets before and after the deck run on rigid track
moving with the ground. What the 3D step cannot do yet is refused before anything is built, in one
line naming the key (:class:`NotRun3D`): a braking or accelerating train,
``train.initial = "rigid-track"``. With
``solver.backend = "c"`` localized-dynamic steps on the compiled 3D loop (:func:`stepper3d`); other
methods and backends step on NumPy with a :class:`~svbi.runtime.backends.base.BackendFallback`
warning. The
contact is the step's: ``contact.normal`` unilateral (lift-off and landing, the default) or
bilateral, flange contact at ``contact.flange_clearance``, and with ``contact.creep`` Kalker's creep
forces with Shen-Hedrick-Elkins saturation (``[contact]``'s material and friction, as in 2D).

Rail irregularities (``[track]``) are set on the step's contact kernels (their ``irregularity``
argument) under each wheelset at t_{n+1} before each step (evaluated for a whole chunk at once): a
German spectrum gives the vertical profile (the 2D run's table), the alignment and the cross-level;
a measured profile its vertical column. The static state at t = 0 is on level track (a spectral
profile's onset ramp starts at the leading wheelset, so every wheel stands on level rail then).
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ... import __version__
from ..backends.base import BackendFallback
from ..backends.c.stepper3d import SOLVE_FAILURES, LocalizedDynamic3DC
from ..backends.c.stepper3d import STATUS as STATUS_3D
from ..excitation.irregularity import (
    GermanSpectrum,
    Irregularity,
    OnsetRamp,
    SpectralIrregularity,
    measured_profile_3d,
)
from ..methods.chunk3d import Chunk3D, ChunkStopped, SteppedChunks, chunk_head, first_non_finite
from ..methods.classic3d import CoupledClassic3D
from ..methods.coupled3d import CoupledDynamic3D, State3D, static_state
from ..methods.guard import FORCE_LIMIT_FACTOR
from ..methods.localized3d import LocalizedDynamic3D
from ..model.bridge3d import Bridge3D
from ..model.ground import Ground, ground_from_scenario
from ..model.kernels import FRAME3D, load, load_broadcasting
from ..model.system3d import GROUND, System3D, Track3D, Vehicle3DNumeric, vehicle3d, vehicle_parameters3d
from ..model.train3d import train3d
from ..scenario.build import (
    IRREGULARITY_TABLE_DIVISIONS,
    TrackGeometry3D,
    bridge_from_scenario,
    creep_parameters,
    irregularity_table,
    piers_3d,
    section3d,
    track_geometry_3d,
)
from ..scenario.limits import vehicle_ref
from ..scenario.schema import Scenario, not_in_3d
from .output import RunInterrupted, signal_name
from .results3d import SIDE_SIGN, Histories3D, dataset3d

if TYPE_CHECKING:
    import xarray as xr

CHUNK_STEPS = 256
"""About how many steps a 3D loop advances between two recordings (:func:`chunk_steps`)."""
STEPS_3D = {
    "localized-dynamic": LocalizedDynamic3D,
    "coupled-dynamic": CoupledDynamic3D,
    "coupled-classic": CoupledClassic3D,
}
"""The 3D step of each ``solver.method`` that has one."""
CONTACT_MODEL = "coned wheels on knife-edge rails: {normal} normal contact, flange contact, {creep}"
"""The results' ``contact_model`` attribute (filled in per run)."""
COMPONENTS = ("vertical", "alignment", "cross-level")
"""The irregularity components, in the order of the contact kernels' ``[r_v, r_a, r_c]``."""
RAMP_LENGTH = 20.0
"""m: the onset ramp of a spectral irregularity, from the leading axle at t = 0 (as in 2D)."""

STEP_TOO_LARGE = "the time step may be too large for this model; try a smaller one"
"""The likely cause named when a 3D step of the localized or coupled-dynamic method diverges, or when
the contact problem of a step (any method) has no solution or does not settle."""


class NotRun3D(ValueError):
    """A 3D scenario asks for what the 3D run cannot do yet: one line naming the file and the key."""

    def __init__(self, key: str, message: str, where: str = "") -> None:
        self.key = key
        super().__init__(": ".join(p for p in (where, key, message) if p))


# --------------------------------------------------------------------------------------------------
# the scenario's 3D model


@dataclass
class Run3D:
    """A 3D scenario's model, ready to step."""

    bridge: Bridge3D
    system: System3D
    geometry: TrackGeometry3D
    cars: int
    per_car: int
    """Wheelsets per car."""
    duration: float
    steps: int
    carbody: list[dict[str, int]]
    """Per car: the vehicle index of its car body's ``y``, ``z``, ``phi``, ``theta`` (those it has)."""
    irregularity: dict[str, Irregularity]
    """The rail's irregularities by component (``vertical``, ``alignment``, ``cross-level``: those
    the track has; empty without)."""

    def irregularity_at(self, t: float | np.ndarray) -> np.ndarray:
        """``[r_v, r_a, r_c]``, their slopes and curvatures along x under each wheelset at ``t`` (the
        contact kernels' irregularity argument): ``(wheelsets, 9)`` for one time, ``(len(t),
        wheelsets, 9)`` for an array of times (one evaluation of each profile for all of them)."""
        sys_ = self.system
        times = np.asarray(t, dtype=float)
        offsets = np.array([w.offset for w in sys_.vehicle.wheelsets])
        x = sys_.start + sys_.speed * times.reshape(-1)[:, None] - offsets[None, :]
        out = np.zeros((*x.shape, 9))
        for j, name in enumerate(COMPONENTS):
            if name in self.irregularity:
                r = self.irregularity[name].evaluate(x)
                for d in range(3):
                    out[..., 3 * d + j] = r[d]
        return out[0] if times.ndim == 0 else out


def chunk_steps(every: int) -> int:
    """The steps of one chunk of a 3D run: the multiple of ``output_every`` nearest to
    :data:`CHUNK_STEPS` (at least one output interval), so that every chunk but the last ends on a
    stored step."""
    every = max(1, int(every))
    return every * max(1, round(CHUNK_STEPS / every))


def refuse(scenario: Scenario) -> None:
    """Raise :class:`NotRun3D` for what the 3D run cannot do yet (the checks that need no model)."""
    where = scenario.source or ""
    ss = scenario.solver

    def no(key: str, message: str) -> NotRun3D:
        return NotRun3D(key, message, where)

    if ss.method not in STEPS_3D:
        raise no(
            "solver.method",
            f"{ss.method!r} has no 3D step: use one of {', '.join(map(repr, STEPS_3D))}",
        )
    for key, message in not_in_3d(scenario):
        raise no(key, message)


def _carbody(vehicle: Vehicle3DNumeric, cars: int) -> list[dict[str, int]]:
    """Per car, the car body's DOFs: the first body of the car (file order) that is not a wheelset."""
    wheelsets = {w.name.split(".", 1)[-1] for w in vehicle.wheelsets}
    out = []
    for k in range(cars):
        prefix = f"car{k}."
        bodies = []
        for name in vehicle.dof_names:
            if name.startswith(prefix):
                body = name[len(prefix) :].split("_", 1)[1]
                if body not in wheelsets and body not in bodies:
                    bodies.append(body)
        if not bodies:
            out.append({})
            continue
        body = bodies[0]
        out.append(
            {
                d: vehicle.index(f"{prefix}{d}_{body}")
                for d in ("y", "z", "phi", "theta")
                if f"{prefix}{d}_{body}" in vehicle.dof_names
            }
        )
    return out


def build_run3d(scenario: Scenario, hold_train: bool = False) -> Run3D:
    """The 3D bridge, train, track and system of a 3D scenario, after :func:`refuse` and the check
    that every wheelset stays on the deck for the whole run (one line naming the key otherwise)."""
    refuse(scenario)
    where = scenario.source or ""
    ts, ss = scenario.train, scenario.solver
    ref = vehicle_ref(scenario)
    topo = vehicle_parameters3d(ref)
    given = {k: float(v) for k, v in ts.parameters.items() if not isinstance(v, list)}  # type: ignore[arg-type]
    car = vehicle3d(ref, given)
    spacing = given.get("car_length", float(topo.parameters["car_length"].value))
    train = train3d([car] * ts.cars, spacing)
    per_car = len(car.wheelsets)
    if per_car == 0:
        raise NotRun3D("train.vehicle", f"{topo.name} has no wheelsets: nothing rests on the deck", where)

    plane = bridge_from_scenario(scenario, matrices=False)
    long_form = scenario.bridge.girders is not None
    sections = [section3d(scenario, g if long_form else None) for g in range(len(plane.girders))]
    piers = piers_3d(scenario)
    bridge = Bridge3D(
        plane.girders,
        scenario.bridge.elements_per_span,
        sections,
        plane.piers,
        [p.section for p in piers],
        [p.bearing_stiffness_lateral for p in piers],
    )
    speed = 0.0 if hold_train else ts.speed_ms
    start = float(ts.start_position)
    length = bridge.length
    rear = max(w.offset for w in train.wheelsets)
    if ss.duration is None:  # until the last wheelset leaves the deck, as the 2D run
        if speed <= 0.0:
            raise NotRun3D("solver.duration", "a train that does not move needs solver.duration", where)
        duration = max(length + rear - start, 0.0) / speed
    else:
        duration = float(ss.duration)
    steps = max(int(math.ceil(duration / ss.time_step - 1e-9)), 1)
    ground = None
    eq = scenario.earthquake
    if eq is not None and any(eq.sources(c) != ["none"] for c in eq.components):
        ground = ground_from_scenario(scenario, steps * ss.time_step)
    g = track_geometry_3d(scenario)
    track = Track3D(
        conicity=g.conicity,
        eccentricity=g.eccentricity,
        rail_height=g.rail_height,
        flange_clearance=g.flange_clearance,
    )
    system = System3D(
        train,
        bridge,
        track,
        speed=speed,
        start=start,
        bridge_damping=bridge.C,
        creep=creep_parameters(scenario),
        ground=ground,
    )
    irregularity = irregularities_3d(scenario, speed, duration, steps * ss.time_step)
    front = min(w.offset for w in train.wheelsets)
    path = np.array([start - rear, start + speed * steps * ss.time_step - front])
    for profile in irregularity.values():  # a measured profile must cover the wheelsets' path
        try:
            profile.evaluate(path)
        except ValueError as exc:
            raise NotRun3D("track.irregularity", str(exc), where) from None
    return Run3D(bridge, system, g, ts.cars, per_car, duration, steps, _carbody(train, ts.cars), irregularity)


def irregularities_3d(
    scenario: Scenario, speed: float, duration: float, end_time: float
) -> dict[str, Irregularity]:
    """The rail's irregularities of ``[track]`` by component. A German spectrum gives all three
    (the vertical profile the 2D run's own table, the alignment and cross-level their spectra of the
    same seed, each with the 2D run's onset ramp from ``train.start_position`` and its table
    spacing); a measured profile file its vertical column (2D profile files carry no other)."""
    spec = scenario.track
    if spec.irregularity == "none":
        return {}
    if spec.is_profile:
        return dict(measured_profile_3d(scenario.resolve_path(spec.irregularity)))
    x0 = float(scenario.train.start_position)
    travel = max(speed * duration, 1.0)
    dx = spec.wavelength_min / IRREGULARITY_TABLE_DIVISIONS
    x1 = x0 + max(speed * end_time, 1.0) + 4 * dx
    band = (spec.wavelength_min, spec.wavelength_max)
    out: dict[str, Irregularity] = {
        "vertical": irregularity_table(spec.irregularity, spec.seed, travel, *band, x0, x1, dx)
    }
    level = "low" if spec.irregularity == "german-low" else "high"
    for name in COMPONENTS[1:]:
        exact = SpectralIrregularity(
            GermanSpectrum(level, name),  # type: ignore[arg-type]
            seed=spec.seed,
            length=travel,
            wavelength_min=band[0],
            wavelength_max=band[1],
            ramp=OnsetRamp(start=x0, length=RAMP_LENGTH),
        )
        out[name] = exact.tabulate(x0, x1, dx)
    return out


def rigid_track_statics(vehicle: Vehicle3DNumeric) -> tuple[np.ndarray, np.ndarray]:
    """``(q, Q0)``: the vehicle standing on rigid level track (its wheelsets held at their nominal
    place, gaps closed) under gravity, and the vertical wheel loads (wheelset by wheelset, left then
    right, N): each wheelset's vertical reaction split between its wheels by its roll moment,
    ``Q_left,right = (R_z +- R_phi / b) / 2``."""
    n = len(vehicle.dof_names)
    held = np.concatenate([w.dofs for w in vehicle.wheelsets])
    free = np.setdiff1d(np.arange(n), held)
    q = np.zeros(n)
    q[free] = np.linalg.solve(vehicle.K[np.ix_(free, free)], vehicle.F[free])
    reaction = vehicle.K @ q - vehicle.F  # the rails' generalized force on the wheelset DOFs
    loads = []
    for w in vehicle.wheelsets:
        rz, rphi = reaction[w.dofs[1]], reaction[w.dofs[2]]
        loads += [0.5 * (rz + rphi / w.half_gauge), 0.5 * (rz - rphi / w.half_gauge)]
    return q, np.array(loads)


# --------------------------------------------------------------------------------------------------
# the deck at a point: the frame element's shape functions


def deck_rows(bridge: Bridge3D, element: int, xi: float) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """``{name: (dofs, weights)}``: the deck's axial ``u``, lateral ``v``, vertical ``w`` and twist
    ``phi`` at ``xi`` of deck element ``element`` as weights on its 12 DOFs (the generated shape
    functions of the 3D frame element, at the element's own length)."""
    rows = load(FRAME3D).shape_functions(float(bridge.deck_element_length[element]), float(xi))
    dofs = bridge.element_dofs(element)
    return {name: (dofs, rows[k]) for k, name in enumerate(("u", "v", "w", "phi"))}


def deck_rows_many(bridge: Bridge3D, element: np.ndarray, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`deck_rows` at many points at once: ``(dofs, weights)``, ``dofs`` ``(m, 12)`` the DOFs
    of deck element ``element[i]`` and ``weights`` ``(m, 4, 12)`` the rows of ``u``, ``v``, ``w``
    and ``phi`` at ``xi[i]`` (the same generated shape functions, evaluated at all the points)."""
    element = np.asarray(element, dtype=np.intp).reshape(-1)
    weights = load_broadcasting(FRAME3D).shape_functions(
        np.asarray(bridge.deck_element_length, dtype=float)[element], np.asarray(xi, dtype=float).reshape(-1)
    )
    first = np.asarray(bridge.deck_element_nodes, dtype=np.intp)[element]
    dofs = np.asarray(bridge.global_dof)[np.stack([first, first + 1], axis=1)].reshape(element.size, -1)
    return dofs, weights.reshape(element.size, 4, -1)


def _point_rows(
    bridge: Bridge3D, points: list[tuple[int, float]], name: str
) -> tuple[np.ndarray, np.ndarray]:
    """``(dofs, weights)``, each ``(points, 12)``: DOF ``name`` (``u``, ``v``, ``w`` or ``phi``) of
    the deck at each point is ``weights[i] @ u[dofs[i]]``."""
    element = np.array([e for e, _ in points], dtype=np.intp)
    xi = np.array([x for _, x in points], dtype=float)
    dofs, weights = deck_rows_many(bridge, element, xi)
    return dofs, weights[:, ("u", "v", "w", "phi").index(name)]


# --------------------------------------------------------------------------------------------------
# the loop


class _Recorder3D:
    """Rows of :class:`Histories3D` (every step) and of the vertical variables (every output)."""

    def __init__(self, run: Run3D, state: State3D, capacity: int, every: int) -> None:
        self.run, self.every = run, every
        b, sys_ = run.bridge, run.system
        veh = sys_.vehicle
        self.q_rigid, q0 = rigid_track_statics(veh)
        self.static_wheel_load = q0.reshape(run.cars, run.per_car, 2)
        spans = b.spans
        mids = [b.midspan(s) for s in range(spans)]
        self.mid = {n: _point_rows(b, mids, n) for n in ("u", "v", "w", "phi")}
        self.ends = np.array(
            [
                [b.dof(int(b.span_nodes[s][0]), "theta"), b.dof(int(b.span_nodes[s][-1]), "theta")]
                for s in range(spans)
            ]
        )
        # every span's nodes, span by span (a joint's two nodes both listed): the deck's twist there
        self.twist_dofs = np.concatenate(
            [[b.dof(int(n), "phi") for n in b.span_nodes[s]] for s in range(spans)]
        )
        self.twist_span = np.repeat(np.arange(spans), [len(b.span_nodes[s]) for s in range(spans)])
        self.twist_x = np.concatenate(
            [b.line_x[s] + np.linspace(0.0, b.span_lengths[s], len(b.span_nodes[s])) for s in range(spans)]
        )
        self.pier_v = np.array([b.dof(b.pier_top(i), "v") for i in range(len(b.piers))], dtype=np.intp)
        self.pier_u = np.array([b.dof(b.pier_top(i), "u") for i in range(len(b.piers))], dtype=np.intp)
        self.ground: Ground = sys_.ground if sys_.ground is not None else Ground()
        self.moves = sys_.ground is not None
        """Whether the ground moves (else its displacements are zeros, not evaluated)."""
        self.lines = np.asarray(b.line_x, dtype=float)
        self.pier_line = np.array([p.support for p in b.piers], dtype=np.intp)
        self.lam = math.atan(sys_.track.conicity)
        self.h_t = sys_.track.rail_height
        self.ws = veh.wheelsets
        self.start = sys_.start
        self.offsets = np.array([w.offset for w in veh.wheelsets])
        self.ws_y = np.array([w.dofs[0] for w in veh.wheelsets], dtype=np.intp)
        self.ws_phi = np.array([w.dofs[2] for w in veh.wheelsets], dtype=np.intp)
        nw = len(self.ws)
        c, a = run.cars, run.per_car
        self.steps = 0
        self.time = np.zeros(capacity)
        self.normal = np.zeros((capacity, nw * 2))
        self.flange = np.zeros((capacity, nw * 2))
        self.fx = np.zeros((capacity, nw * 2))
        self.fy = np.zeros((capacity, nw * 2))
        self.tread = np.ones((capacity, nw * 2), dtype=bool)
        self.flange_closed = np.zeros((capacity, nw * 2), dtype=bool)
        self.angle = np.zeros((capacity, nw * 2))
        self.lateral = np.zeros((capacity, nw))
        self.ay = np.zeros((capacity, c))
        self.roll = np.zeros((capacity, c))
        self.mid_v = np.zeros((capacity, spans))
        self.mid_v_rel = np.zeros((capacity, spans))
        self.pier_uy_rel = np.zeros((capacity, len(b.piers)))
        self.mid_phi = np.zeros((capacity, spans))
        self.pier_uy = np.zeros((capacity, len(self.pier_v)))
        rows = (capacity + every - 1) // every
        self.count = 0
        self.v: dict[str, np.ndarray] = {
            "midspan_uz": np.zeros((rows, spans)),
            "midspan_ux": np.zeros((rows, spans)),
            "deck_acceleration": np.zeros((rows, spans)),
            "end_rotation": np.zeros((rows, spans, 2)),
            "carbody_uz": np.zeros((rows, c)),
            "carbody_az": np.zeros((rows, c)),
            "carbody_pitch": np.zeros((rows, c)),
            "normal_gap": np.zeros((rows, nw * 2)),
            "wheel_uplift": np.zeros((rows, nw * 2)),
            "wheelset_position": np.zeros((rows, nw)),
            "pier_top_ux": np.zeros((rows, len(self.pier_u))),
            "deck_twist": np.zeros((rows, self.twist_dofs.size)),
            "midspan_uz_rel": np.zeros((rows, spans)),
            "midspan_ux_rel": np.zeros((rows, spans)),
            "pier_drift": np.zeros((rows, len(self.pier_u))),
            "ground_uz": np.zeros(rows),
            "ground_ux": np.zeros(rows),
        }
        self.shape = (c, a)

    def record_chunk(self, chunk: Chunk3D) -> None:
        """Rows ``self.steps`` to ``self.steps + len(chunk) - 1`` of the histories from a chunk of
        consecutive states (the first may be the initial state, t = 0): vectorised over the steps
        and the wheelsets. The vertical variables at the rows whose index is a multiple of
        ``every`` (the chunk's gaps must be there)."""
        k = len(chunk)
        if k == 0:
            return
        i0 = self.steps
        rows = slice(i0, i0 + k)
        sys_, run = self.run.system, self.run
        b = run.bridge
        t = np.asarray(chunk.t, dtype=float)
        u, q, qdd = chunk.u, chunk.q, chunk.qdd
        irr = chunk.irregularity
        self.time[rows] = t
        self.normal[rows] = chunk.P
        self.flange[rows] = chunk.flange
        self.fx[rows] = chunk.creep[..., 0].reshape(k, -1)
        self.fy[rows] = chunk.creep[..., 1].reshape(k, -1)
        closed = np.asarray(chunk.contact, dtype=bool).reshape(k, -1, 4)  # normal l, r, flange l, r
        self.tread[rows] = closed[:, :, :2].reshape(k, -1)
        self.flange_closed[rows] = closed[:, :, 2:].reshape(k, -1)
        # the track under every wheelset at every time: the deck's, or the ground's on the approach
        element, xi = sys_.contact_locations(t)
        on = element != GROUND
        phi_d = np.zeros(element.shape)
        y_d = np.zeros(element.shape)
        if on.any():
            dofs, weights = deck_rows_many(b, element[on], xi[on])
            step = np.broadcast_to(np.arange(k)[:, None], element.shape)[on]
            ue = u[step[:, None], dofs]
            v = np.einsum("mj,mj->m", weights[:, 1], ue)
            phi_d[on] = np.einsum("mj,mj->m", weights[:, 3], ue)
            y_d[on] = v - self.h_t * phi_d[on]  # the track centreline on the deck
        if (~on).any() and self.moves:
            x = self.start + sys_.speed * t[:, None] - self.offsets[None, :]
            y_d = np.where(on, y_d, self.ground.displacements("lateral", t, x))
        y_r = y_d + irr[:, :, 1]
        phi_t = phi_d + irr[:, :, 2]  # the track plane's roll: the deck's and the cross-level
        self.lateral[rows] = q[:, self.ws_y] - y_r
        roll = q[:, self.ws_phi] - phi_t
        self.angle[rows] = (self.lam + SIDE_SIGN[None, None, :] * roll[:, :, None]).reshape(k, -1)
        for c, body in enumerate(run.carbody):
            if "y" in body:
                self.ay[rows, c] = qdd[:, body["y"]]
            if "phi" in body:
                self.roll[rows, c] = q[:, body["phi"]] - self.q_rigid[body["phi"]]
        self.mid_v[rows] = self._at(self.mid["v"], u)
        self.mid_phi[rows] = self._at(self.mid["phi"], u)
        # relative to the ground the span moves with as a rigid body: the mean of its two support
        # lines' motion at midspan (the ground does not rotate)
        gy = self._lines("lateral", t)
        self.mid_v_rel[rows] = self.mid_v[rows] - 0.5 * (gy[:, :-1] + gy[:, 1:])
        if len(self.pier_v):
            self.pier_uy[rows] = u[:, self.pier_v]
            self.pier_uy_rel[rows] = self.pier_uy[rows] - gy[:, self.pier_line]
        out = np.flatnonzero((np.arange(i0, i0 + k) % self.every) == 0)  # stored rows of the chunk
        if out.size:
            k0, m = self.count, out.size
            o = slice(k0, k0 + m)
            uo, to = u[out], t[out]
            d = self.v
            d["midspan_uz"][o] = self._at(self.mid["w"], uo)
            d["midspan_ux"][o] = self._at(self.mid["u"], uo)
            d["deck_acceleration"][o] = self._at(self.mid["w"], chunk.udd[out])
            d["end_rotation"][o] = uo[:, self.ends]
            d["deck_twist"][o] = uo[:, self.twist_dofs]
            for c, body in enumerate(run.carbody):
                if "z" in body:
                    d["carbody_uz"][o, c] = q[out, body["z"]] - self.q_rigid[body["z"]]
                    d["carbody_az"][o, c] = qdd[out, body["z"]]
                if "theta" in body:
                    d["carbody_pitch"][o, c] = q[out, body["theta"]] - self.q_rigid[body["theta"]]
            d["normal_gap"][o] = chunk.gaps[out]
            # a wheel off its rail: its normal gap is its height above the rail (0 in contact, as 2D)
            tread = chunk.contact[out].reshape(m, -1, 4)[:, :, :2].reshape(m, -1)
            d["wheel_uplift"][o] = np.where(tread, 0.0, np.maximum(chunk.gaps[out], 0.0))
            d["wheelset_position"][o] = self.start + sys_.speed * to[:, None] - self.offsets[None, :]
            gz, gx = self._lines("vertical", to), self._lines("longitudinal", to)
            d["midspan_uz_rel"][o] = d["midspan_uz"][o] - 0.5 * (gz[:, :-1] + gz[:, 1:])
            d["midspan_ux_rel"][o] = d["midspan_ux"][o] - 0.5 * (gx[:, :-1] + gx[:, 1:])
            d["ground_uz"][o], d["ground_ux"][o] = gz[:, 0], gx[:, 0]
            if len(self.pier_u):
                d["pier_top_ux"][o] = uo[:, self.pier_u]
                d["pier_drift"][o] = d["pier_top_ux"][o] - gx[:, self.pier_line]
            self.count += m
        self.steps += k

    @staticmethod
    def _at(point: tuple[np.ndarray, np.ndarray], u: np.ndarray) -> np.ndarray:
        """``(steps, points)``: a DOF of the deck at fixed points (:func:`_point_rows`) from the
        span's DOF vectors ``u`` (steps x bridge DOFs)."""
        dofs, weights = point
        return np.einsum("kpj,pj->kp", u[:, dofs], weights)

    def _lines(self, component: str, t: np.ndarray) -> np.ndarray:
        """``(len(t), support lines)``: the ground's displacement ``component`` at the support
        lines at the times ``t`` (zeros when the ground is at rest)."""
        if not self.moves:
            return np.zeros((t.size, self.lines.size))
        return self.ground.displacements(component, t, self.lines)

    def histories(self, speed: float) -> Histories3D:
        n = self.steps
        c, a = self.shape
        wheel = (n, c, a, 2)
        t = self.time[:n]
        pier = self.pier_uy[:n] if len(self.pier_v) else None
        return Histories3D(
            time=t,
            distance=speed * t,
            normal_force=self.normal[:n].reshape(wheel),
            contact_angle=self.angle[:n].reshape(wheel),
            creep_longitudinal=self.fx[:n].reshape(wheel),
            creep_lateral=self.fy[:n].reshape(wheel),
            flange_force=self.flange[:n].reshape(wheel),
            flange_contact=self.flange_closed[:n].reshape(wheel),
            in_contact=self.tread[:n].reshape(wheel),
            wheel_rail_lateral=self.lateral[:n].reshape(wheel[:3]),
            static_wheel_load=self.static_wheel_load,
            carbody_ay=self.ay[:n],
            carbody_roll=self.roll[:n],
            midspan_uy=self.mid_v[:n],
            midspan_uy_rel=self.mid_v_rel[:n],
            midspan_twist=self.mid_phi[:n],
            midspan_twist_rel=self.mid_phi[:n],
            pier_top_uy=pier,
            pier_top_uy_rel=self.pier_uy_rel[:n] if len(self.pier_v) else None,
        )

    def base(self) -> xr.Dataset:
        """The vertical variables of the 2D results that the 3D model gives (stored rows)."""
        import xarray as xr

        k = self.count
        c, a = self.shape
        d = {name: arr[:k] for name, arr in self.v.items()}
        b = self.run.bridge

        def at(units: str, long_name: str) -> dict[str, str]:
            return {"units": units, "long_name": long_name}

        data = {
            "midspan_uz": (
                ("time", "span"),
                d["midspan_uz"],
                at("m", "absolute vertical displacement at midspan"),
            ),
            "midspan_uz_rel": (
                ("time", "span"),
                d["midspan_uz_rel"],
                at("m", "vertical displacement at midspan relative to the ground under the span's supports"),
            ),
            "midspan_ux": (
                ("time", "span"),
                d["midspan_ux"],
                at("m", "absolute longitudinal displacement of the deck's axis at midspan"),
            ),
            "midspan_ux_rel": (
                ("time", "span"),
                d["midspan_ux_rel"],
                at(
                    "m",
                    "longitudinal displacement at midspan relative to the ground under the span's supports",
                ),
            ),
            "deck_acceleration": (
                ("time", "span"),
                d["deck_acceleration"],
                at("m/s^2", "absolute vertical acceleration at midspan (Newmark, unfiltered)"),
            ),
            "end_rotation": (
                ("time", "span", "end"),
                d["end_rotation"],
                at(
                    "rad",
                    "absolute rotation dw/dx of the span's left and right end, counter-clockwise positive",
                ),
            ),
            "carbody_uz": (
                ("time", "car"),
                d["carbody_uz"],
                at("m", "car-body bounce from static equilibrium on rigid track"),
            ),
            "carbody_az": (
                ("time", "car"),
                d["carbody_az"],
                at("m/s^2", "car-body absolute vertical acceleration"),
            ),
            "carbody_pitch": (
                ("time", "car"),
                d["carbody_pitch"],
                at("rad", "car-body pitch from static equilibrium on rigid track, front end up positive"),
            ),
            "normal_gap": (
                ("time", "car", "wheel", "side"),
                d["normal_gap"].reshape(k, c, a, 2),
                at(
                    "m",
                    "normal gap between the wheel's cone and its rail (held at 0 by the contact constraint)",
                ),
            ),
            "wheel_uplift": (
                ("time", "car", "wheel", "side"),
                d["wheel_uplift"].reshape(k, c, a, 2),
                at(
                    "m",
                    "height of an airborne wheel's contact point above its rail, normal to it (0 in contact)",
                ),
            ),
            "ground_uz": (
                ("time",),
                d["ground_uz"],
                at("m", "vertical ground displacement at the first abutment"),
            ),
            "ground_ux": (
                ("time",),
                d["ground_ux"],
                at("m", "longitudinal ground displacement at the first abutment"),
            ),
            "wheelset_position": (
                ("time", "car", "wheel"),
                d["wheelset_position"].reshape(k, c, a),
                at("m", "position of the wheelset along the deck, from the first abutment"),
            ),
        }
        data["deck_twist"] = (
            ("time", "deck_node"),
            d["deck_twist"],
            at("rad", "twist of the deck about its axis at every node of every span, left side up positive"),
        )
        coords: dict[str, Any] = {
            "end": ("end", np.array(["left", "right"], dtype=object)),
            "deck_node_x": (
                "deck_node",
                self.twist_x,
                at("m", "position of the node from the first abutment"),
            ),
            "deck_node_span": ("deck_node", self.twist_span + 1, at("1", "span of the node (from 1)")),
        }
        if len(self.pier_u):
            data["pier_top_ux"] = (
                ("time", "pier"),
                d["pier_top_ux"],
                at("m", "absolute longitudinal displacement of the pier top"),
            )
            data["pier_drift"] = (
                ("time", "pier"),
                d["pier_drift"],
                at("m", "longitudinal displacement of the pier top relative to the ground at its base"),
            )
            coords["pier_line"] = ("pier", np.array([p.support for p in b.piers]), at("1", "support line"))
        return xr.Dataset(data_vars=data, coords=coords)


def stepper3d(scenario: Scenario, system: System3D, state: State3D) -> tuple[str, Any]:
    """``(backend, step)``: the 3D step of ``solver.method`` on ``solver.backend``. The C loop has
    the localized-dynamic step (:class:`~svbi.runtime.backends.c.stepper3d.LocalizedDynamic3DC`);
    every other method, backend or a train or bridge beyond the C loop's sizes steps on NumPy,
    with a :class:`~svbi.runtime.backends.base.BackendFallback` warning that says why."""
    ss = scenario.solver
    args = (system, state, ss.time_step, ss.constraint_kappa, ss.constraint_zeta)
    normal = scenario.contact.normal
    why = ""
    if ss.backend == "c" and ss.method == "localized-dynamic":
        try:
            return "c", LocalizedDynamic3DC(*args, normal=normal)
        except ValueError as exc:
            if not str(exc).startswith("the 3D C loop"):
                raise  # the model's own error (an unstable explicit creep step): NumPy says the same
            why = str(exc)
    elif ss.backend == "c":
        why = "the C loop has localized-dynamic only"
    elif ss.backend != "numpy":
        why = f"the {ss.backend} backend has no 3D step; the C loop has localized-dynamic"
    if why:
        warnings.warn(
            f"solver.backend = {ss.backend!r}: {why}; this 3D run of {ss.method} steps on the NumPy backend",
            BackendFallback,
            stacklevel=3,
        )
    return "numpy", STEPS_3D[ss.method](*args, normal=normal)


def divergence3d(
    chunk: Chunk3D, max_gap: float, force_limit: float, per_car: int, method: str
) -> tuple[int, str] | None:
    """The first step of ``chunk`` at which the run has gone unstable, and why (None: none), as
    the 2D guard (:mod:`svbi.runtime.methods.guard`): a normal gap of a wheel in contact beyond
    ``solver.max_gap`` (read at the steps whose gaps were evaluated, the output steps), a wheel
    flying higher than that, or a normal force beyond ``force_limit``."""
    k = len(chunk)
    closed = chunk.contact.reshape(k, -1, 4)[:, :, :2].reshape(k, -1).astype(bool)
    gaps = np.nan_to_num(chunk.gaps, nan=0.0)
    drift = np.where(closed, np.abs(gaps), 0.0) > max_gap
    flight = np.where(closed, 0.0, gaps) > max_gap
    force = np.abs(chunk.P) > force_limit
    rows = np.flatnonzero(drift.any(axis=1) | flight.any(axis=1) | force.any(axis=1))
    if not rows.size:
        return None
    j = int(rows[0])

    def wheel(i: int) -> str:
        car, ws = divmod(i // 2, per_car)
        return f"car {car + 1}, wheelset {ws + 1}, {('left', 'right')[i % 2]}"

    if method == "coupled-classic":
        cause = (
            "coupled-classic imposes the constraints at acceleration level only, so the gaps drift "
            "(use localized-dynamic or coupled-dynamic)"
        )
    else:
        cause = STEP_TOO_LARGE
    if drift[j].any():
        i = int(np.argmax(np.where(drift[j], np.abs(gaps[j]), 0.0)))
        return j, (
            f"the normal gap of the wheel in contact at {wheel(i)} is {gaps[j, i]:.4g} m, beyond "
            f"solver.max_gap = {max_gap:g} m; likely cause: {cause}"
        )
    if flight[j].any():
        i = int(np.argmax(np.where(flight[j], gaps[j], 0.0)))
        return j, (
            f"the wheel at {wheel(i)} flies {gaps[j, i]:.4g} m above its rail (more than "
            f"solver.max_gap = {max_gap:g} m): derailment is likely"
        )
    i = int(np.argmax(np.abs(chunk.P[j])))
    return j, (
        f"the normal force at {wheel(i)} is {chunk.P[j, i]:.4g} N, beyond {force_limit:.3g} N "
        f"({FORCE_LIMIT_FACTOR:g} x the static wheel load); likely cause: {cause}"
    )


def simulate3d(
    scenario: Scenario,
    *,
    progress: bool = False,
    hold_train: bool = False,
    clock_start: float | None = None,
    variables: Any = None,
) -> xr.Dataset:
    """Run a 3D scenario and return its results (docs/scenario.md, "Results of a 3D run").

    :class:`NotRun3D` (a ``ValueError``, one line) for what the 3D run cannot do yet, before anything
    is built. ``variables`` keeps only those results variables."""
    from .simulate import SimulationIncomplete, _Progress

    t_start = time.perf_counter() if clock_start is None else clock_start
    ss = scenario.solver
    run = build_run3d(scenario, hold_train)
    system = run.system
    state = static_state(system)
    backend, stepper = stepper3d(scenario, system, state)
    every = ss.output_every
    recorder = _Recorder3D(run, state, run.steps + 1, every)
    chunks = stepper if backend == "c" else SteppedChunks(stepper)
    recorder.record_chunk(SteppedChunks(stepper).current(run.irregularity_at(0.0)))
    size = chunk_steps(every)
    force_limit = FORCE_LIMIT_FACTOR * max(float(np.abs(recorder.static_wheel_load).max(initial=0.0)), 1.0)
    bar = _Progress(run.steps) if progress else None
    message = ""
    interrupted: KeyboardInterrupt | None = None
    t_loop = time.perf_counter()
    try:
        n = 0
        while n < run.steps:
            k = min(size, run.steps - n)
            # under each wheelset at t_{n+1}, where the step imposes its gaps
            level = run.irregularity_at((np.arange(n, n + k) + 1) * ss.time_step)
            cause: BaseException | None = None
            try:
                # the C loop's chunk in its own buffers (recorded before the next call)
                chunk = (
                    chunks.advance(n, k, level, every, reuse=True)
                    if backend == "c"
                    else chunks.advance(n, k, level, every)
                )
            except ChunkStopped as stop:  # record the steps finished before the failure
                chunk, cause = stop.chunk, stop.cause
            stopped = getattr(chunks, "stopped", None)
            if stopped:  # the C loop stopped short: its finished steps are the chunk
                recorder.record_chunk(chunk)
                message = f"the 3D step failed at t = {(n + len(chunk) + 1) * ss.time_step:.6g} s " + (
                    f"(step {n + len(chunk) + 1} of {run.steps}): {STATUS_3D.get(chunks.status, stopped)}"
                )
                if chunks.status in SOLVE_FAILURES:
                    message += f"; likely cause: {STEP_TOO_LARGE}"
                break
            bad = first_non_finite(chunk)
            if bad is not None:
                recorder.record_chunk(chunk_head(chunk, bad))
                message = (
                    f"the 3D step diverged at t = {chunk.t[bad]:.6g} s (step {n + bad + 1} of "
                    f"{run.steps}): non-finite state"
                )
                break
            stop = divergence3d(chunk, ss.max_gap, force_limit, run.per_car, ss.method)
            if stop is not None:  # recorded up to the step that stops the run
                j, why = stop
                recorder.record_chunk(chunk_head(chunk, j + 1))
                message = (
                    f"the 3D run diverged at t = {chunk.t[j]:.6g} s (step {n + j + 1} of {run.steps}): {why}"
                )
                break
            recorder.record_chunk(chunk)
            if cause is not None:
                raise cause
            n += len(chunk)
            if bar is not None:
                bar.update(len(chunk))
    except np.linalg.LinAlgError as exc:
        message = (
            f"the 3D step failed at step {recorder.steps} of {run.steps}: {exc}; "
            f"likely cause: {STEP_TOO_LARGE}"
        )
    except KeyboardInterrupt as exc:
        interrupted = exc
        message = (
            f"interrupted by {signal_name(exc)} at t = {(recorder.steps - 1) * ss.time_step:.6g} s "
            f"(step {recorder.steps - 1} of {run.steps})"
        )
    finally:
        t_end_loop = time.perf_counter()
        if bar is not None:
            bar.close()
    data = scenario.to_dict()
    data["solver"]["duration"] = run.steps * ss.time_step if ss.duration is None else ss.duration
    import tomli_w

    attrs: dict[str, Any] = {
        "svbi_version": __version__,
        "dimensions": 3,
        "method": ss.method,
        "backend": backend,
        "backend_requested": ss.backend,
        "time_step": ss.time_step,
        "steps": int(recorder.steps - 1),
        "output_every": every,
        "constraint_kappa": ss.constraint_kappa,
        "constraint_zeta": ss.constraint_zeta,
        "contact_model": CONTACT_MODEL.format(
            normal=scenario.contact.normal,
            creep="Kalker creep with Shen-Hedrick-Elkins saturation"
            if scenario.contact.creep
            else "no creep",
        ),
        "conicity": run.geometry.conicity,
        "flange_clearance": run.geometry.flange_clearance,
        "setup_time_s": t_loop - t_start,
        "loop_time_s": t_end_loop - t_loop,
        "scenario": tomli_w.dumps(data),
        "complete": 0 if message else 1,
    }
    if message:
        attrs["incomplete"] = message
    ds = dataset3d(
        recorder.histories(system.speed),
        attrs,
        every,
        scenario.output.force_filter_hz,
        base=recorder.base(),
    )
    if variables is not None:
        ds = ds[[v for v in variables if v in ds.variables and v not in ds.coords]]
    ds.attrs["wall_time_s"] = time.perf_counter() - t_start
    if interrupted is not None:
        raise RunInterrupted(getattr(interrupted, "signum", 2), ds) from None
    if message:
        warnings.warn(message, SimulationIncomplete, stacklevel=2)
    return ds
