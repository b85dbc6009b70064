"""Early sanity limits of a scenario: sizes and magnitudes that no sensible run reaches.

They are checked with the scenario (``svbi.runtime.scenario.schema``), before anything is built, so that a
typing slip (``time_step = 1e-9``, ``speed_kmh = 1e30``) ends in one line naming the key instead of
a ``MemoryError``, a hang or a ``nan`` minutes later. Each limit is far beyond the paper's case and
the largest documented runs (README: 100 cars on 1000 spans); ``docs/scenario.md`` lists them. They
are not a memory estimate: a run within every limit can still be too large for the machine.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING, Any

from ...codegen.plain_types import TopologyError, builtin_topologies
from ..excitation.irregularity import read_profile_cached
from ..model.hslm import hslm_parameters
from ..model.train import Kinematics, vehicle_model
from .kinds import builtin_vehicles_3d

if TYPE_CHECKING:
    from .schema import Scenario

MAX_STEPS = 20_000_000
"""Time steps of one run: 2000 s of simulated time at 1e-4 s (the paper's run has 71,460). The
loop keeps the contact forces of every step for the force filter, so memory grows with steps."""

MAX_ELEMENTS = 100_000
"""Bridge frame elements, ``bridge.spans * bridge.elements_per_span``: 200 km of 32 m spans at the
default 16 elements per span (the longest bridge built is 164 km)."""

MAX_IRREGULARITY_POINTS = 5_000_000
"""Points of the rail-irregularity table: one every ``track.wavelength_min / 50`` over the track the
train covers. 32 km at the default 0.5 m make 3.2 million; each point sums about
``length / wavelength_min`` frequencies, so the table's cost grows with the square of the ratio."""

MAX_SPEED = 500.0
"""Train speed (m/s, 1800 km/h): three times the rail speed record (160 m/s); a larger value is a
unit slip, and it would carry the train across kilometres of table per time step."""

MAX_CONSTRAINT_COEFFICIENT = 1.0e6
"""``solver.constraint_kappa`` and ``constraint_zeta``: useful values are 0.5 … 2; beyond this the
stabilisation ``omega = kappa / dt`` overflows its square."""

CONTACT_SPLIT_RANGE = (0.01, 0.99)
"""``solver.contact_split``: the share does not change the results, but near 0 the aux point's mass
vanishes (a singular interface matrix) and near 1 the wheel's."""

MAX_DISTANCE = 1.0e6
"""``train.start_position`` (m, 1000 km either way): farther, the positions lose their resolution."""

MAX_RAIL_HEIGHT = 100.0
"""``bridge.rail_height`` (m): the rail head above the girder's neutral axis."""

MAX_FRICTION = 10.0
"""``contact.friction``: steel on steel is 0.1 … 0.5; far beyond, the creep law's saturation overflows."""

RADIUS_RATIO_RANGE = (1.0e-4, 1.0e4)
"""Wheel radius over ``contact.rail_head_radius``: the Hertz ellipse of the creep law
(``creep_law.hertz_coefficients``) is solved within this range of curvature ratios."""

MIN_FILTER_SHARE = 1.0e-5
"""``output.force_filter_hz`` over the Nyquist frequency: below, the Butterworth filter's initial
conditions form a singular system."""

MAX_GIRDER_RATIO = 2000.0
"""Longest span over the shortest element of one continuous girder (``bridge.girders[i].spans``,
``elements_per_span`` elements each): the girder's stiffness matrix has a condition number of about
this ratio to the fourth power, 1.6e13 at the limit, and its modes (which fit the girder's Rayleigh
damping) lose every digit at about 1e4. Real girders' spans differ by a factor of 5 at most."""

MAX_PGA = 50.0 * 9.81
"""Peak ground acceleration (m/s², 50 g): more than ten times the largest ever recorded (about 4 g)."""


def _geometry(s: Scenario, values: Mapping[str, Any]) -> tuple[list[float], float, list[float]] | None:
    """Wheel offsets behind the car's leading axle, the car length and the wheel radii (m), as
    ``Train`` places them; ``None`` when the vehicle cannot be evaluated (its own check says why)."""

    if s.dimensions == 3:  # its wheelsets, as the 3D run places them (run/simulate3d.py)
        return _geometry3d(s)
    vals = dict(values)
    if s.train.hslm is not None:
        vals.update(hslm_parameters(s.train.hslm))
    model = vehicle_model(vehicle_ref(s))
    if model.kind == "moving-load":
        return [float(x) for x in vals["axle_offsets"]], float(vals["car_length"]), []
    try:
        vehicle = model.numeric(vals)
    except TopologyError:
        return None
    radii = [float(r) for r in vehicle.wheel_radii]
    return [float(x) for x in vehicle.wheel_offsets], float(vals["car_length"]), radii


def _geometry3d(s: Scenario) -> tuple[list[float], float, list[float]] | None:
    """:func:`_geometry` of a 3D scenario: its wheelsets' offsets, car length and wheel radii with
    ``train.parameters``; ``None`` when the vehicle cannot be evaluated (its own check says why)."""
    from ..model.system3d import vehicle3d, vehicle_parameters3d  # a built-in's generated module

    numbers = {k: v for k, v in s.train.parameters.items() if not isinstance(v, list)}
    try:
        ref = vehicle_ref(s)
        vehicle = vehicle3d(ref, numbers)
        default = vehicle_parameters3d(ref).parameters["car_length"].value
        car_length = float(numbers.get("car_length", default))
    except (TopologyError, KeyError, TypeError, ValueError):
        return None
    wheelsets = vehicle.wheelsets
    return [w.offset for w in wheelsets], car_length, [w.radius for w in wheelsets]


def size_problems(s: Scenario, values: Mapping[str, Any]) -> Iterable[tuple[str, str]]:
    """(key, message) for every limit the scenario ``s`` exceeds; ``values`` are its vehicle
    parameters (for the car length of the default duration)."""
    b, sol, trk, t = s.bridge, s.solver, s.track, s.train
    speed = t.speed_ms
    speed_key = "train.speed" if t.speed is not None else "train.speed_kmh"
    if speed > MAX_SPEED:
        yield (
            speed_key,
            f"{speed:.3g} m/s ({speed * 3.6:.3g} km/h) is above the limit of {MAX_SPEED:g} m/s "
            f"({MAX_SPEED * 3.6:g} km/h), beyond any rail vehicle: a unit slip?",
        )
        return  # the sizes below all scale with the speed
    elements = b.spans * b.elements_per_span
    if elements > MAX_ELEMENTS:
        yield (
            "bridge.spans",
            f"{b.spans} spans x {b.elements_per_span} elements (bridge.elements_per_span) = {elements:,} "
            f"frame elements, above the limit of {MAX_ELEMENTS:,} (200 km of 32 m spans)",
        )
    geometry = _geometry(s, values)
    if geometry is None:
        return
    offsets, car_length, wheel_radii = geometry
    car_extent = max(offsets) if offsets else 0.0
    train_length = (t.cars - 1) * car_length + car_extent  # leading to last axle (Train.length)
    if t.cars > 1 and car_length <= car_extent:
        # car k + 1 starts car_length behind car k: its leading axle would sit among car k's axles
        key = (
            "train.parameters.car_length"
            if "car_length" in t.parameters
            else ("train.hslm" if t.hslm is not None else "train.vehicle")
        )
        yield (
            key,
            f"car_length = {car_length:g} m is not longer than the car itself ({car_extent:g} m from its "
            f"leading to its last axle): with {t.cars} cars they would overlap",
        )
    motion = Kinematics(speed, t.acceleration)
    if sol.duration is not None:
        duration, duration_from = sol.duration, "solver.duration"
    elif speed > 0.0 or t.acceleration > 0.0:  # assembly.crossing_duration: the last axle leaves
        way = b.line_positions()[-1] + train_length - t.start_position
        duration = motion.time_to_travel(max(way, 0.0))
        duration_from = "the crossing time; solver.duration is unset"
        if not math.isfinite(duration):
            duration, duration_from = None, ""
    else:
        duration, duration_from = None, ""
    if duration is not None and motion.speed_at(duration) > MAX_SPEED:
        yield (
            "train.acceleration",
            f"the train reaches {motion.speed_at(duration):.3g} m/s by the end of the run, above the limit "
            f"of {MAX_SPEED:g} m/s",
        )
        return
    # a standing train without solver.duration never ends: reported by the scenario's checks
    steps = duration / sol.time_step if duration is not None else math.nan
    if math.isfinite(steps) and steps <= MAX_STEPS:
        whole = max(math.ceil(steps - 1e-9), 1)  # simulate.build_model's count
        if sol.output_every > whole:
            yield (
                "solver.output_every",
                f"{sol.output_every} is more than the {whole} steps of the run ({duration_from} "
                f"{duration:.4g} s / solver.time_step {sol.time_step:g} s): only t = 0 would be stored",
            )
    nyquist = 0.5 / sol.time_step
    if s.output.force_filter_hz < MIN_FILTER_SHARE * nyquist:
        yield (
            "output.force_filter_hz",
            f"{s.output.force_filter_hz:g} Hz is below {MIN_FILTER_SHARE:g} of the Nyquist frequency "
            f"({nyquist:g} Hz): the low-pass filter cannot be built that narrow",
        )
    if s.output.force_filter_hz >= nyquist:
        yield (
            "output.force_filter_hz",
            f"{s.output.force_filter_hz:g} Hz is not below the Nyquist frequency 1 / (2 solver.time_step) "
            f"= {nyquist:g} Hz: the force could not be filtered there; lower it or the time step",
        )
    if duration is not None and (not math.isfinite(steps) or steps > MAX_STEPS):
        key = "solver.duration" if sol.duration is not None and sol.duration > 1.0 else "solver.time_step"
        yield (
            key,
            f"{duration:.4g} s ({duration_from}) at solver.time_step = {sol.time_step:g} s is "
            f"{steps:.3g} steps, above the limit of {MAX_STEPS:.0e} ({MAX_STEPS:,}) steps of one run",
        )
    if trk.is_profile and duration is not None:
        yield from _profile_coverage(s, speed, train_length, duration, speed_key, duration_from)
    elif trk.irregularity != "none" and duration is not None:
        covered = max(motion.travel(duration), 1.0)
        points = covered / (trk.wavelength_min / 50.0)
        if points > MAX_IRREGULARITY_POINTS:
            yield (
                "track.wavelength_min",
                f"{trk.wavelength_min:g} m over the {covered:.4g} m the train covers ({speed_key} x "
                f"{duration_from}) needs an irregularity table of {points:.3g} points (one every "
                f"wavelength_min / 50), above the limit of {MAX_IRREGULARITY_POINTS:,}: raise "
                "track.wavelength_min or shorten the run",
            )
    # the span's stiffness-to-mass ratios set its frequencies: they must be finite numbers
    for stiffness, name in ((b.youngs_modulus * b.area, "E A"), (b.youngs_modulus * b.second_moment, "E I")):
        ratio = stiffness / b.mass_per_length
        if not (math.isfinite(ratio) and ratio > 0 and math.isfinite(ratio * b.span_length**2)):
            yield (
                "bridge.mass_per_length",
                f"{name} / mass_per_length = {stiffness:.3g} / {b.mass_per_length:.3g} is not a finite "
                "positive number (bridge.youngs_modulus, area, second_moment, mass_per_length)",
            )
            break
    for key in ("constraint_kappa", "constraint_zeta"):
        value = getattr(sol, key)
        if value > MAX_CONSTRAINT_COEFFICIENT:
            yield (
                f"solver.{key}",
                f"{value:g} is above the limit of {MAX_CONSTRAINT_COEFFICIENT:g} (useful values: 0.5 … 2)",
            )
    lo, hi = CONTACT_SPLIT_RANGE
    if not lo <= sol.contact_split <= hi:
        yield (
            "solver.contact_split",
            f"{sol.contact_split:g} is outside {lo:g} … {hi:g}: the aux point or the wheel would keep "
            "almost no mass and the interface matrix would be singular (the share does not change the "
            "results; 0.5 is the default)",
        )
    if s.contact.friction > MAX_FRICTION:
        yield (
            "contact.friction",
            f"{s.contact.friction:g} is above the limit of {MAX_FRICTION:g} (steel on steel: 0.1 … 0.5)",
        )
    radii = [r for r in wheel_radii if r > 0]
    lo_r, hi_r = RADIUS_RATIO_RANGE
    if s.contact.creep and radii:
        for r in sorted(set(radii)):
            if not lo_r <= r / s.contact.rail_head_radius <= hi_r:
                key = (
                    "train.parameters.wheel_radius"
                    if "wheel_radius" in t.parameters
                    else "contact.rail_head_radius"
                )
                yield (
                    key,
                    f"wheel radius {r:g} m over contact.rail_head_radius {s.contact.rail_head_radius:g} m "
                    f"is outside {lo_r:g} … {hi_r:g}: no Hertz contact ellipse for the creep law",
                )
                break
    if abs(t.start_position) > MAX_DISTANCE:
        yield "train.start_position", f"{t.start_position:g} m is farther than {MAX_DISTANCE:g} m from x = 0"
    if abs(b.rail_height) > MAX_RAIL_HEIGHT:
        yield (
            "bridge.rail_height",
            f"{b.rail_height:g} m is above the limit of {MAX_RAIL_HEIGHT:g} m (rail head above the "
            "girder's neutral axis)",
        )
    eq = s.earthquake
    if eq is not None and eq.target_pga is not None and eq.target_pga > MAX_PGA:
        yield (
            "earthquake.target_pga",
            f"{eq.target_pga:.3g} m/s² is above the limit of {MAX_PGA:g} m/s² (50 g); it is in m/s², not g",
        )


def girder_problems(b: Any) -> Iterable[tuple[str, str]]:
    """(key, message) for each continuous girder of the long form ``b`` (``BridgeSpec``) whose spans
    differ too much for its matrices to be solved (:data:`MAX_GIRDER_RATIO`)."""
    for i, g in enumerate(b.girders or []):
        if len(g.spans) < 2:
            continue
        longest = max(g.spans)
        j = min(range(len(g.spans)), key=lambda k: g.spans[k])
        element = g.spans[j] / b.elements_per_span
        if longest / element > MAX_GIRDER_RATIO:
            yield (
                f"bridge.girders[{i}].spans[{j}]",
                f"{g.spans[j]:g} m in a girder continuous with a {longest:g} m span: with "
                f"{b.elements_per_span} elements per span its elements are {element:.3g} m long, and "
                f"longest span / shortest element = {longest / element:.3g} is above the limit of "
                f"{MAX_GIRDER_RATIO:g} (the girder's stiffness matrix cannot be solved accurately)",
            )


def creep_warnings(s: Scenario) -> list[str]:
    """With ``contact.creep`` on, name the wheels that have no spin DOF: no creep force acts there
    (``wheel_creep.CreepForces``: a wheel creeps only through a non-zero column of ``W_T^V``)."""

    if not s.contact.creep or s.dimensions == 3:
        return []
    model = vehicle_model(vehicle_ref(s))
    if model.kind == "moving-load":
        return []
    try:
        vehicle = model.numeric(model.topology.values(s.train.parameters))
    except TopologyError:
        return []
    names = [w.name for w in model.topology.wheels]
    still = [names[j] for j in range(vehicle.nwheels) if not abs(vehicle.W_T[:, j]).sum() > 0]
    if not still:
        return []
    listed = ", ".join(repr(n) for n in still)
    return [
        f"contact.creep = true, but wheel(s) {listed} of {model.name} have no spin DOF (a 'theta' "
        "DOF of the wheel's body with a wheel radius): no creep force acts there; set "
        "contact.creep = false to run without creep knowingly"
    ]


def _profile_coverage(
    s: Scenario, speed: float, train_length: float, duration: float, speed_key: str, duration_from: str
) -> Iterable[tuple[str, str]]:
    """Every wheel's path must lie inside a measured profile: from the last axle at t = 0 to the
    leading axle at the last step (a profile is used as given, nothing is extrapolated)."""
    path = s.resolve_path(s.track.irregularity)
    try:
        xs, _ = read_profile_cached(path)
    except (OSError, ValueError):
        return  # reported by the scenario's own check of the file
    steps = max(math.ceil(duration / s.solver.time_step - 1e-9), 1)
    lo = s.train.start_position - train_length
    hi = s.train.start_position + Kinematics(speed, s.train.acceleration).travel(steps * s.solver.time_step)
    if lo < xs[0] or hi > xs[-1]:
        yield (
            "track.irregularity",
            f"{path} covers x = {xs[0]:.6g} .. {xs[-1]:.6g} m, but the wheels run over x = {lo:.6g} .. "
            f"{hi:.6g} m (train.start_position, the train's {train_length:.6g} m from leading to last "
            f"axle, {speed_key} x {duration_from}): extend the profile or shorten the run",
        )


def vehicle_ref(s: Scenario) -> str:
    """The scenario's vehicle: a built-in topology's name, or its topology file's resolved path."""
    name = s.train.vehicle
    builtin = builtin_vehicles_3d() if s.dimensions == 3 else builtin_topologies()
    return name if name in builtin else str(s.resolve_path(name))
