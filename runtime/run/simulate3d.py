"""The run of a 3D scenario (docs/three-d.md, "3D runs"): ``svbi.simulate`` and ``svbi run`` come
here when ``scenario.dimensions == 3``.

The scenario becomes a :class:`~svbi.runtime.model.bridge3d.Bridge3D` (shorthand or long form, piers
included), a train of ``train.cars`` 3D cars (:func:`~svbi.runtime.model.system3d.vehicle3d`,
:func:`~svbi.runtime.model.train3d.train3d`, spaced by the vehicle's ``car_length`` as 2D trains
are), the cone-and-knife-edge track of :func:`~svbi.runtime.scenario.build.track_geometry_3d` and a
:class:`~svbi.runtime.model.system3d.System3D`. The steps are those of
:mod:`svbi.runtime.methods.localized3d`, :mod:`svbi.runtime.methods.coupled3d` and
:mod:`svbi.runtime.methods.classic3d`, called through
their public interface (constructor, ``step(n)``, the state's ``t``, ``q``, ``qdd``, ``u``, ``udd``,
``P``, ``gaps()``). Every step fills a row of :class:`~svbi.runtime.run.results3d.Histories3D`; the
vertical variables of the 2D results (``midspan_uz``, ``deck_acceleration``, ``carbody_az``, ...)
are recorded every ``output_every`` steps and given to
:func:`~svbi.runtime.run.results3d.dataset3d` as its ``base``.

The ground of ``[earthquake]`` (vertical, longitudinal and lateral components, per support line or
travelling) moves the 3D bridge's supports; wheelsets before and after the deck run on rigid track
moving with the ground. What the 3D step cannot do yet is refused before anything is built, in one
line naming the key (:class:`NotRun3D`): a braking or accelerating train,
``train.initial = "rigid-track"``, spans whose elements differ in length. A ``solver.backend`` other
than ``numpy`` runs on NumPy with a :class:`~svbi.runtime.backends.base.BackendFallback` warning. The
contact is the step's: ``contact.normal`` unilateral (lift-off and landing, the default) or
bilateral, flange contact at ``contact.flange_clearance``, and with ``contact.creep`` Kalker's creep
forces with Shen-Hedrick-Elkins saturation (``[contact]``'s material and friction, as in 2D).

Rail irregularities (``[track]``) are set on the step's contact kernels (their ``irregularity``
argument) under each wheelset at t_{n+1} before each step: a German spectrum gives the vertical
profile (the 2D run's table), the alignment and the cross-level; a measured profile its vertical
column. The static state at t = 0 is on level track (a spectral profile's onset ramp starts at the
leading wheelset, so every wheel stands on level rail then).
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
from ..excitation.irregularity import (
    GermanSpectrum,
    Irregularity,
    OnsetRamp,
    SpectralIrregularity,
    measured_profile_3d,
)
from ..methods.classic3d import CoupledClassic3D
from ..methods.coupled3d import CoupledDynamic3D, State3D, static_state
from ..methods.localized3d import LocalizedDynamic3D
from ..model.bridge3d import Bridge3D
from ..model.ground import Ground, ground_from_scenario
from ..model.kernels import FRAME3D, load
from ..model.system3d import GROUND, System3D, Track3D, Vehicle3DNumeric, vehicle3d
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
from ..scenario.schema import Scenario
from ..toolchain import load_topology3d
from .output import RunInterrupted, signal_name
from .results3d import SIDE_SIGN, Histories3D, dataset3d

if TYPE_CHECKING:
    import xarray as xr

STEPS_3D = {
    "localized-dynamic": LocalizedDynamic3D,
    "coupled-dynamic": CoupledDynamic3D,
    "coupled-classic": CoupledClassic3D,
}
"""The 3D step of each ``solver.method`` that has one."""
CONTACT_MODEL = "coned wheels on knife-edge rails: {normal} normal contact, flange contact, {creep}"
"""The results' ``contact_model`` attribute (filled in per run)."""
"""The ``contact_model`` attribute of a 3D run's results."""
COMPONENTS = ("vertical", "alignment", "cross-level")
"""The irregularity components, in the order of the contact kernels' ``[r_v, r_a, r_c]``."""
RAMP_LENGTH = 20.0
"""m: the onset ramp of a spectral irregularity, from the leading axle at t = 0 (as in 2D)."""


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

    def irregularity_at(self, t: float) -> np.ndarray:
        """``(wheelsets, 9)``: ``[r_v, r_a, r_c]``, their slopes and curvatures along x under each
        wheelset at ``t`` (the contact kernels' irregularity argument)."""
        sys_ = self.system
        x = sys_.start + sys_.speed * t - np.array([w.offset for w in sys_.vehicle.wheelsets])
        out = np.zeros((x.size, 9))
        for j, name in enumerate(COMPONENTS):
            if name in self.irregularity:
                r = self.irregularity[name].evaluate(x)
                for d in range(3):
                    out[:, 3 * d + j] = r[d]
        return out


def refuse(scenario: Scenario) -> None:
    """Raise :class:`NotRun3D` for what the 3D run cannot do yet (the checks that need no model)."""
    where = scenario.source or ""
    ss, t = scenario.solver, scenario.train

    def no(key: str, message: str) -> NotRun3D:
        return NotRun3D(key, message, where)

    if ss.method not in STEPS_3D:
        raise no(
            "solver.method",
            f"{ss.method!r} has no 3D step: use one of {', '.join(map(repr, STEPS_3D))}",
        )
    if t.acceleration != 0.0:
        raise no("train.acceleration", "the 3D step runs trains at constant speed: remove it (or set 0)")
    if t.initial == "rigid-track":
        raise no(
            "train.initial",
            "'rigid-track': a 3D run starts from the static state on the deck: use 'auto' or 'static'",
        )


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
    topo = load_topology3d(ref)
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
    try:
        _ = bridge.element_length
    except ValueError:
        raise NotRun3D(
            "bridge.girders",
            "spans of different lengths: the 3D contact takes one element length for the whole deck "
            "(give every span the same length)",
            where,
        ) from None

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
    functions of the 3D frame element)."""
    rows = load(FRAME3D).shape_functions(bridge.element_length, float(xi))
    dofs = bridge.element_dofs(element)
    return {name: (dofs, rows[k]) for k, name in enumerate(("u", "v", "w", "phi"))}


def _point_matrix(bridge: Bridge3D, points: list[tuple[int, float]], name: str) -> np.ndarray:
    """``R`` (points x bridge DOFs): ``R @ u`` is DOF ``name`` of the deck at each point."""
    out = np.zeros((len(points), bridge.ndof))
    for i, (e, xi) in enumerate(points):
        dofs, weights = deck_rows(bridge, e, xi)[name]
        np.add.at(out[i], dofs, weights)
    return out


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
        self.mid = {n: _point_matrix(b, mids, n) for n in ("u", "v", "w", "phi")}
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
        self.lines = np.asarray(b.line_x, dtype=float)
        self.pier_line = np.array([p.support for p in b.piers], dtype=np.intp)
        self.lam = math.atan(sys_.track.conicity)
        self.h_t = sys_.track.rail_height
        self.ws = veh.wheelsets
        self.start = sys_.start
        self.offsets = np.array([w.offset for w in veh.wheelsets])
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

    def record(self, st: State3D, gaps: Any, irregularity: np.ndarray) -> None:
        """Row ``self.steps`` of the histories from the state; ``gaps`` (a callable) at outputs;
        ``irregularity`` (wheelsets x 9) under the wheelsets at the state's time."""
        i = self.steps
        sys_, run = self.run.system, self.run
        b = run.bridge
        self.time[i] = st.t
        self.normal[i] = st.P
        if st.flange is not None:
            self.flange[i] = st.flange
        if st.creep is not None:
            self.fx[i] = st.creep[:, :, 0].reshape(-1)
            self.fy[i] = st.creep[:, :, 1].reshape(-1)
        if st.contact is not None:  # 4 per wheelset: normal left, right, flange left, right
            closed = np.asarray(st.contact, dtype=bool).reshape(-1, 4)
            self.tread[i] = closed[:, :2].reshape(-1)
            self.flange_closed[i] = closed[:, 2:].reshape(-1)
        for w, (ws, (e, xi)) in enumerate(zip(self.ws, sys_.contact_location(st.t), strict=True)):
            if e == GROUND:  # on the approach track: the ground under the wheelset
                phi_d = 0.0
                x = self.start + sys_.speed * st.t - self.offsets[w]
                y_r = float(self.ground.lateral(st.t, np.array([x]))[0][0]) + irregularity[w, 1]
            else:
                rows = deck_rows(b, e, xi)
                dofs, rv = rows["v"]
                _, rphi = rows["phi"]
                ue = st.u[dofs]
                phi_d = float(rphi @ ue)
                y_r = float(rv @ ue) - self.h_t * phi_d + irregularity[w, 1]  # the track centreline
            phi_t = phi_d + irregularity[w, 2]  # the track plane's roll: the deck's and the cross-level
            self.lateral[i, w] = st.q[ws.dofs[0]] - y_r
            self.angle[i, 2 * w : 2 * w + 2] = self.lam + SIDE_SIGN * (st.q[ws.dofs[2]] - phi_t)
        for k, body in enumerate(run.carbody):
            if "y" in body:
                self.ay[i, k] = st.qdd[body["y"]]
            if "phi" in body:
                self.roll[i, k] = st.q[body["phi"]] - self.q_rigid[body["phi"]]
        self.mid_v[i] = self.mid["v"] @ st.u
        self.mid_phi[i] = self.mid["phi"] @ st.u
        # relative to the ground the span moves with as a rigid body: the mean of its two support
        # lines' motion at midspan (the ground does not rotate)
        gy = self.ground.lateral(st.t, self.lines)[0]
        self.mid_v_rel[i] = self.mid_v[i] - 0.5 * (gy[:-1] + gy[1:])
        if len(self.pier_v):
            self.pier_uy[i] = st.u[self.pier_v]
            self.pier_uy_rel[i] = self.pier_uy[i] - gy[self.pier_line]
        if i % self.every == 0:
            k = self.count
            d = self.v
            d["midspan_uz"][k] = self.mid["w"] @ st.u
            d["midspan_ux"][k] = self.mid["u"] @ st.u
            d["deck_acceleration"][k] = self.mid["w"] @ st.udd
            d["end_rotation"][k] = st.u[self.ends]
            d["deck_twist"][k] = st.u[self.twist_dofs]
            for c, body in enumerate(run.carbody):
                if "z" in body:
                    d["carbody_uz"][k, c] = st.q[body["z"]] - self.q_rigid[body["z"]]
                    d["carbody_az"][k, c] = st.qdd[body["z"]]
                if "theta" in body:
                    d["carbody_pitch"][k, c] = st.q[body["theta"]] - self.q_rigid[body["theta"]]
            d["normal_gap"][k] = gaps()
            d["wheelset_position"][k] = self.start + sys_.speed * st.t - self.offsets
            (gz, _, _), (gx, _, _) = self.ground.motion(st.t, self.lines)
            d["midspan_uz_rel"][k] = d["midspan_uz"][k] - 0.5 * (gz[:-1] + gz[1:])
            d["midspan_ux_rel"][k] = d["midspan_ux"][k] - 0.5 * (gx[:-1] + gx[1:])
            d["ground_uz"][k], d["ground_ux"][k] = gz[0], gx[0]
            if len(self.pier_u):
                d["pier_top_ux"][k] = st.u[self.pier_u]
                d["pier_drift"][k] = d["pier_top_ux"][k] - gx[self.pier_line]
            self.count += 1
        self.steps += 1

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
    backend = "numpy"
    if ss.backend != "numpy":
        warnings.warn(
            f"solver.backend = {ss.backend!r}: 3D scenarios run on the NumPy backend only for now",
            BackendFallback,
            stacklevel=2,
        )
    system = run.system
    state = static_state(system)
    stepper = STEPS_3D[ss.method](
        system, state, ss.time_step, ss.constraint_kappa, ss.constraint_zeta, normal=scenario.contact.normal
    )
    every = ss.output_every
    recorder = _Recorder3D(run, state, run.steps + 1, every)
    level = run.irregularity_at(0.0)
    for kernel, r in zip(stepper.kernels, level, strict=True):
        kernel.irregularity = r  # the kernels' irregularity argument (zero when the track has none)
    recorder.record(stepper.state, stepper.gaps, level)
    bar = _Progress(run.steps) if progress else None
    message = ""
    interrupted: KeyboardInterrupt | None = None
    t_loop = time.perf_counter()
    try:
        for n in range(run.steps):
            if run.irregularity:  # under each wheelset at t_{n+1}, where the step imposes its gaps
                level = run.irregularity_at((n + 1) * ss.time_step)
                for kernel, r in zip(stepper.kernels, level, strict=True):
                    kernel.irregularity = r
            st = stepper.step(n)
            if not (np.isfinite(st.q).all() and np.isfinite(st.u).all() and np.isfinite(st.P).all()):
                message = (
                    f"the 3D step diverged at t = {st.t:.6g} s (step {n + 1} of {run.steps}): "
                    "non-finite state"
                )
                break
            recorder.record(st, stepper.gaps, level)
            if bar is not None and (n + 1) % every == 0:
                bar.update(every)
    except np.linalg.LinAlgError as exc:
        message = f"the 3D step failed at step {recorder.steps} of {run.steps}: {exc}"
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
