"""A scenario becomes a :class:`~svbi.runtime.model.system.Model`: the bridge of ``[bridge]``, the
train of ``[train]``, the rail profile of ``[track]``, the ground motion of ``[earthquake]``, the
creep law of ``[contact]`` and the solver settings (docs/scenario.md)."""

from __future__ import annotations

import functools
import math

from ..excitation.irregularity import SpectralIrregularity, make_irregularity, measured_profile
from ..model.bridge import Bridge
from ..model.creep_law import CreepParameters
from ..model.ground import ground_from_scenario
from ..model.hslm import hslm_parameters
from ..model.system import Ground, GroundAtRest, Model, Settings, crossing_duration
from ..model.train import Train, vehicle_model
from .schema import Problem, Scenario, ScenarioError, vehicle_ref

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
    return Model(bridge, train, settings, irregularity, ground, creep=_creep(scenario))


def _creep(scenario: Scenario) -> CreepParameters | None:
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
