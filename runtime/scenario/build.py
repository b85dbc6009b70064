"""A scenario becomes a :class:`~svbi.runtime.model.system.Model`: the bridge of ``[bridge]``, the
train of ``[train]``, the rail profile of ``[track]``, the ground motion of ``[earthquake]``, the
creep law of ``[contact]`` and the solver settings (docs/scenario.md)."""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

from ..excitation.irregularity import SpectralIrregularity, make_irregularity, measured_profile
from ..model.bridge import Bridge
from ..model.creep_law import CreepParameters
from ..model.ground import ground_from_scenario
from ..model.hslm import hslm_parameters
from ..model.span3d import POISSON_DEFAULT, Section3D
from ..model.system import Ground, GroundAtRest, Model, Settings, crossing_duration
from ..model.train import Train, vehicle_model
from .kinds import NOT_RUN_3D
from .schema import (
    CONICITY_DEFAULT,
    FLANGE_CLEARANCE_DEFAULT,
    Problem,
    Scenario,
    ScenarioError,
    vehicle_ref,
)

IRREGULARITY_TABLE_DIVISIONS = 50
"""Table spacing of the rail profile: at most ``track.wavelength_min / 50``. The quintic table then
differs from the exact spectral sum by at most about 5e-13 (r), 6e-10 (r') and 1.4e-7 (r'') of their
RMS (docs/excitations.md)."""


def bridge_from_scenario(scenario: Scenario, matrices: bool = True) -> Bridge:
    """The :class:`Bridge` of ``[bridge]``: the shorthand, or the long form's girders and piers
    (``matrices=False``: its layout only, see :class:`Bridge`)."""
    bs = scenario.bridge
    return Bridge(
        bs.spans,
        bs.span_length,
        bs.mass_per_length,
        bs.youngs_modulus,
        bs.area,
        bs.second_moment,
        bs.damping_ratio,
        bs.elements_per_span,
        bs.rail_height,
        *(bs.layout() if bs.girders is not None else ()),
        matrices=matrices,
    )


def run_extent(
    scenario: Scenario, hold_train: bool = False, matrices: bool = True
) -> tuple[Bridge, Train, float, int]:
    """Bridge, train, duration (s) and number of steps of a run: the cheap part of
    :func:`build_model`, which sizes the run (``svbi.runtime.run.memory``, with ``matrices=False``:
    the bridge's layout only) before the tables exist."""
    ts, ss = scenario.train, scenario.solver
    bridge = bridge_from_scenario(scenario, matrices)
    ref = vehicle_ref(scenario)
    model_sym = vehicle_model(ref)
    values = model_sym.topology.values(ts.parameters, where="train.parameters")
    if ts.hslm is not None:
        values.update(hslm_parameters(ts.hslm))
    vehicle = model_sym.numeric(values)
    speed = 0.0 if hold_train else ts.speed_ms
    acceleration = 0.0 if hold_train else ts.acceleration
    train = Train(vehicle, ts.cars, speed, ts.start_position, ss.contact_split, ref, values, acceleration)
    duration = ss.duration if ss.duration is not None else crossing_duration(bridge, train)
    if not math.isfinite(duration):
        raise ValueError(
            "a held train needs solver.duration"
            if hold_train or (train.speed == 0.0 and train.acceleration == 0.0)
            else "train.acceleration: the train stops before its last axle leaves the bridge; give "
            "solver.duration"
        )
    steps = max(int(math.ceil(duration / ss.time_step - 1e-9)), 1)
    return bridge, train, duration, steps


def build_model(scenario: Scenario, hold_train: bool = False) -> Model:
    """Numbers for everything: bridge, train, excitations and solver settings."""
    if scenario.dimensions == 3:  # the 3D run builds its own model (run/simulate3d.py)
        message = NOT_RUN_3D.format(vehicle=scenario.train.vehicle, file=scenario.source or "FILE")
        raise ScenarioError([Problem("train.vehicle", message, scenario.source)], scenario.source)
    refused = scenario.bridge.long_form_problems()
    if refused:
        # a scenario validated with check=False still may not run a bridge the mechanics lacks
        raise ScenarioError([Problem(k, m, scenario.source) for k, m in refused], scenario.source)
    ss = scenario.solver
    bridge, train, duration, steps = run_extent(scenario, hold_train)
    settings = Settings(
        method=ss.method,
        backend=ss.backend,
        time_step=ss.time_step,
        steps=steps,
        output_every=ss.output_every,
        kappa=ss.constraint_kappa,
        zeta=ss.constraint_zeta,
        split=ss.contact_split,
        force_filter_hz=scenario.output.force_filter_hz,
        max_gap=ss.max_gap,
        normal=scenario.contact.normal,
    )
    irregularity = _irregularity(scenario, train, duration, steps * ss.time_step)
    ground = _ground(scenario, duration)
    if not train.moving_load:  # the wheels on the approach track stand still at t = 0
        check_start = getattr(ground, "check_start", None)
        if check_start is not None:
            check_start(train.positions(0.0))
    return Model(bridge, train, settings, irregularity, ground, creep=creep_parameters(scenario))


def creep_parameters(scenario: Scenario) -> CreepParameters | None:
    """Creep-law parameters of ``[contact]`` (None when creep is off); the wheel radius comes from
    the vehicle topology (``runtime.wheel_creep``)."""
    c = scenario.contact
    if not c.creep:
        return None
    return CreepParameters(
        youngs_modulus=c.youngs_modulus,
        poisson_ratio=c.poisson_ratio,
        rail_head_radius=c.rail_head_radius,
        friction=c.friction,
    )


def _irregularity(scenario: Scenario, train: Train, duration: float, end_time: float):  # noqa: ANN202
    """The rail profile as the loop evaluates it: the spectral sample tabulated as a quintic
    piecewise polynomial from the ramp start (``train.start_position``) to where the leading axle is
    at the last step (docs/excitations.md: table spacing and error)."""
    spec = scenario.track
    if spec.irregularity == "none":
        return None
    if spec.is_profile:  # measured: used as given, no onset ramp, no table of our own
        return measured_profile(scenario.resolve_path(spec.irregularity))
    length = max(train.travel(duration), 1.0)
    dx = spec.wavelength_min / IRREGULARITY_TABLE_DIVISIONS
    x0 = train.start_position
    x1 = x0 + max(train.travel(end_time), 1.0) + 4 * dx
    return irregularity_table(
        spec.irregularity, spec.seed, length, spec.wavelength_min, spec.wavelength_max, x0, x1, dx
    )


@functools.lru_cache(maxsize=4)
def irregularity_table(
    kind: str, seed: int, length: float, wl_min: float, wl_max: float, x0: float, x1: float, dx: float
):  # noqa: ANN202
    """The tabulated profile, kept per process: runs of a sweep that share the track (e.g. records
    and intensities of a fragility study) tabulate it once per worker (the table is read-only)."""
    exact = make_irregularity(
        kind, seed=seed, length=length, wavelength_min=wl_min, wavelength_max=wl_max, start=x0
    )
    if not isinstance(exact, SpectralIrregularity):
        return exact
    return exact.tabulate(x0, x1, dx)


def _ground(scenario: Scenario, duration: float) -> Ground:
    eq = scenario.earthquake
    if eq is None or (eq.vertical == "none" and eq.longitudinal == "none"):
        return GroundAtRest()
    return ground_from_scenario(scenario, duration)


# --------------------------------------------------------------------------------------------------
# 3D scenarios (docs/three-d.md): their sections and track geometry (run/simulate3d.py builds the run)


def _shear(table: Any, fallback: Any, youngs_modulus: float) -> tuple[float, float | None]:
    """(Poisson's ratio, shear modulus or None) of a section: its own keys, else ``fallback``'s
    (``[bridge]`` for a girder), else Poisson's ratio 0.2."""
    for source in (table, fallback):
        if source is None:
            continue
        if source.shear_modulus is not None:
            return POISSON_DEFAULT, float(source.shear_modulus)
        if source.poisson_ratio is not None:
            return float(source.poisson_ratio), None
    return POISSON_DEFAULT, None


def _pick(table: Any, fallback: Any, name: str) -> Any:
    value = getattr(table, name, None)
    return getattr(fallback, name, None) if value is None else value


def section3d(scenario: Scenario, girder: int | None = None) -> Section3D:
    """The 3D section of ``[bridge]`` (``girder`` None) or of ``[[bridge.girders]]`` number
    ``girder`` (its keys, ``[bridge]``'s otherwise), defaults filled in (docs/scenario.md)."""
    b = scenario.bridge
    g = None if girder is None else (b.girders or [])[girder]
    i_z, j = _pick(g, b, "lateral_second_moment"), _pick(g, b, "torsion_constant")
    if i_z is None or j is None:
        raise ValueError("a 3D section needs bridge.lateral_second_moment and bridge.torsion_constant")
    e = float(_pick(g, b, "youngs_modulus"))
    nu, shear = _shear(g, b, e)
    torsional = _pick(g, b, "torsional_mass_per_length")
    return Section3D(
        E=e,
        A=float(_pick(g, b, "area")),
        I_y=float(_pick(g, b, "second_moment")),
        I_z=float(i_z),
        J=float(j),
        mass_per_length=float(_pick(g, b, "mass_per_length")),
        poisson_ratio=nu,
        G=shear,
        torsional_mass=None if torsional is None else float(torsional),
    )


@dataclass(frozen=True)
class Span3DSpec:
    """One distinct span of a 3D scenario: its length, section and where it occurs."""

    length: float
    section: Section3D
    spans: tuple[int, ...]
    """Indices of the spans (0 = the first in the direction of travel) that are this one."""


def distinct_spans_3d(scenario: Scenario) -> list[Span3DSpec]:
    """The distinct spans (length and 3D section) of a 3D scenario's bridge, in order of first
    occurrence: one for the shorthand ``spans x span_length``."""
    b = scenario.bridge
    if b.girders is None:
        return [Span3DSpec(float(b.span_length), section3d(scenario), tuple(range(b.spans)))]
    found: dict[tuple[float, Section3D], list[int]] = {}
    index = 0
    for i, g in enumerate(b.girders):
        section = section3d(scenario, i)
        for length in g.spans:
            found.setdefault((float(length), section), []).append(index)
            index += 1
    return [Span3DSpec(length, section, tuple(ids)) for (length, section), ids in found.items()]


@dataclass(frozen=True)
class Pier3D:
    """A pier of a 3D scenario: its section in both planes and its bearings' lateral stiffness."""

    support: int
    section: Section3D
    """``I_y``: the sway along the track (``second_moment``), ``I_z``: across it."""
    bearing_stiffness_lateral: float | None
    """N/m; None: rigid."""


def piers_3d(scenario: Scenario) -> list[Pier3D]:
    """The piers of a 3D scenario's long form, defaults filled in (docs/scenario.md)."""
    out = []
    for p in scenario.bridge.piers or []:
        i_z = float(p.lateral_second_moment if p.lateral_second_moment is not None else p.second_moment)
        j = float(p.torsion_constant if p.torsion_constant is not None else p.second_moment + i_z)
        nu, shear = _shear(p, None, float(p.youngs_modulus))
        section = Section3D(
            E=float(p.youngs_modulus),
            A=float(p.area),
            I_y=float(p.second_moment),
            I_z=i_z,
            J=j,
            mass_per_length=float(p.mass_per_length),
            poisson_ratio=nu,
            G=shear,
            torsional_mass=p.torsional_mass_per_length,
        )
        out.append(Pier3D(p.support, section, p.bearing_stiffness_lateral))
    return out


@dataclass(frozen=True)
class TrackGeometry3D:
    """The wheel-rail geometry of a 3D scenario (``svbi.runtime.model.system3d.Track3D`` and the
    flange clearance of ``codegen/contact3d.py``), SI units."""

    conicity: float
    eccentricity: float
    rail_height: float
    flange_clearance: float


def track_geometry_3d(scenario: Scenario) -> TrackGeometry3D:
    """``[contact]`` conicity and flange clearance (given, else the vehicle's parameters of those
    names, else :data:`CONICITY_DEFAULT` and :data:`FLANGE_CLEARANCE_DEFAULT`), ``[bridge]``
    track eccentricity (default 0) and rail height."""
    from ..model.system3d import vehicle_parameters3d  # a built-in vehicle's generated DATA

    params = vehicle_parameters3d(vehicle_ref(scenario)).parameters
    given = scenario.train.parameters

    def default(name: str, fallback: float) -> float:
        if name in given:
            return float(given[name])  # type: ignore[arg-type]
        if name in params and not isinstance(params[name].value, tuple):
            return float(params[name].value)  # type: ignore[arg-type]
        return fallback

    c, b = scenario.contact, scenario.bridge
    return TrackGeometry3D(
        conicity=float(c.conicity) if c.conicity is not None else default("conicity", CONICITY_DEFAULT),
        eccentricity=float(b.track_eccentricity or 0.0),
        rail_height=float(b.rail_height),
        flange_clearance=(
            float(c.flange_clearance)
            if c.flange_clearance is not None
            else default("flange_clearance", FLANGE_CLEARANCE_DEFAULT)
        ),
    )
