"""``svbi.simulate(scenario)``: assemble the model, run the Newmark loop, return the results.

Backends plug in through :func:`register_backend`: a backend maps a method name to a stepper class
with ``__init__(model, state)``, ``step(n) -> State`` and a ``contacts`` attribute (the geometry of
the last step). A stepper that also has ``run_loop(recorder, guard, bar)`` runs the whole loop
itself (the ``"c"`` backend, ``svbi.runtime.backends.c.stepper``: chunks of steps in C); a ``backend``
attribute on the stepper overrides the name recorded in the results (a fallback says so).
``"numpy"`` is the reference; ``"c"`` and ``"casadi"`` (``svbi.runtime.backends.casadi``) register
themselves on first use.

A run that goes unstable (NaN or Inf, a runaway gap, an absurd contact force) stops with a message
naming the time, the quantity and the likely cause. What was computed until then is returned,
marked ``complete = 0`` with the message in the ``incomplete`` attribute; nothing non-finite is
stored. Ctrl-C (or SIGTERM under ``svbi run``) during the loop raises
:class:`~svbi.runtime.run.output.RunInterrupted` carrying the results computed so far, marked the
same way.
"""

from __future__ import annotations

import functools
import math
import signal
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from svbi.runtime.methods.initial import initial_state
from svbi.runtime.model.bridge import Bridge
from svbi.runtime.model.creep_law import CreepParameters
from svbi.runtime.model.system import Ground, GroundAtRest, Model, Settings, crossing_duration
from svbi.runtime.model.train import Train, vehicle_model
from svbi.runtime.run.output import RunInterrupted, signal_name
from svbi.runtime.run.results import ImportAhead, Recorder
from svbi.runtime.scenario.schema import (
    Problem,
    Scenario,
    ScenarioError,
    load_scenario,
    validate_scenario,
    vehicle_ref,
)

if TYPE_CHECKING:
    import xarray as xr

"""|gap| (m) beyond which a run is declared diverged: a wheel a metre off its rail is no longer a
constraint violation but a failed integration."""
FORCE_LIMIT_FACTOR = 1.0e3
"""A contact force beyond this multiple of the largest static wheel load stops the run. Joint
impulses give peaks of tens of static loads at dt = 1e-4 s (method-notes section 4)."""


IRREGULARITY_TABLE_DIVISIONS = 50
"""Table spacing of the rail profile: at most ``track.wavelength_min / 50``. The quintic table then
differs from the exact spectral sum by at most about 5e-13 (r), 6e-10 (r') and 1.4e-7 (r'') of their
RMS (docs/excitations.md)."""


class SimulationIncomplete(RuntimeWarning):
    """The run stopped early (diverged); the returned results are partial."""


class BackendFallback(UserWarning):
    """The requested backend is not available; the NumPy backend runs instead."""


class Diverged(RuntimeError):
    """Raised inside the loop; caught by :func:`simulate`."""


# --------------------------------------------------------------------------------------------------
# backends

_BACKENDS: dict[str, dict[str, Callable[..., Any]]] = {}
_WARNED: set[str] = set()


def register_backend(name: str, steppers: Mapping[str, Callable[..., Any]]) -> None:
    """Register a backend: ``steppers`` maps each method name to a stepper class."""
    _BACKENDS[name] = dict(steppers)


def numpy_steppers() -> dict[str, Callable[..., Any]]:
    from svbi.runtime.methods.coupled_classic import CoupledClassic
    from svbi.runtime.methods.coupled_dynamic import CoupledDynamic
    from svbi.runtime.methods.localized import LocalizedDynamic

    return {
        "localized-dynamic": LocalizedDynamic,
        "coupled-dynamic": CoupledDynamic,
        "coupled-classic": CoupledClassic,
    }


def stepper_class(backend: str, method: str) -> tuple[str, Callable[..., Any]]:
    """The stepper for ``method`` on ``backend``, or the NumPy one (warning once)."""
    if "numpy" not in _BACKENDS:
        register_backend("numpy", numpy_steppers())
    if backend == "c" and "c" not in _BACKENDS:
        from svbi.runtime.backends.c.stepper import register  # the whole loop in C (docs/c-backend.md)

        register()
    if backend == "casadi" and "casadi" not in _BACKENDS:
        from svbi.runtime.backends.casadi import register as register_casadi

        register_casadi()
    if backend not in _BACKENDS or method not in _BACKENDS[backend]:
        if backend not in _WARNED:
            _WARNED.add(backend)
            warnings.warn(
                f"solver.backend = {backend!r} is not available in this version; running the NumPy "
                "backend (same results, slower)",
                BackendFallback,
                stacklevel=3,
            )
        backend = "numpy"
    return backend, _BACKENDS[backend][method]


# --------------------------------------------------------------------------------------------------
# model assembly


def bridge_from_scenario(scenario: Scenario) -> Bridge:
    """The :class:`Bridge` of ``[bridge]``: the shorthand, or the long form's girders and piers."""
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
    )


def run_extent(scenario: Scenario, hold_train: bool = False) -> tuple[Bridge, Train, float, int]:
    """Bridge, train, duration (s) and number of steps of a run: the cheap part of
    :func:`build_model`, which sizes the run (``svbi.runtime.run.memory``) before the tables exist."""
    ts, ss = scenario.train, scenario.solver
    bridge = bridge_from_scenario(scenario)
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


def hslm_parameters(name: str) -> dict[str, Any]:
    """Axle layout of an EN 1991-2 HSLM-A train (``svbi.runtime.model.hslm``) as moving-load parameters."""
    from svbi.runtime.model.hslm import hslm_axles

    loads, offsets, length = hslm_axles(name)
    return {"axle_loads": tuple(loads), "axle_offsets": tuple(offsets), "car_length": length}


def _irregularity(scenario: Scenario, train: Train, duration: float, end_time: float):  # noqa: ANN202
    """The rail profile as the loop evaluates it: the spectral sample tabulated as a quintic
    piecewise polynomial from the ramp start (``train.start_position``) to where the leading axle is
    at the last step (docs/excitations.md: table spacing and error)."""
    spec = scenario.track
    if spec.irregularity == "none":
        return None
    if spec.is_profile:  # measured: used as given, no onset ramp, no table of our own
        from svbi.runtime.excitation.irregularity import measured_profile

        return measured_profile(scenario.resolve_path(spec.irregularity))
    length = max(train.travel(duration), 1.0)
    dx = spec.wavelength_min / IRREGULARITY_TABLE_DIVISIONS
    x0 = train.start_position
    x1 = x0 + max(train.travel(end_time), 1.0) + 4 * dx
    return _irregularity_table(
        spec.irregularity, spec.seed, length, spec.wavelength_min, spec.wavelength_max, x0, x1, dx
    )


@functools.lru_cache(maxsize=4)
def _irregularity_table(
    kind: str, seed: int, length: float, wl_min: float, wl_max: float, x0: float, x1: float, dx: float
):  # noqa: ANN202
    """The tabulated profile, kept per process: runs of a sweep that share the track (e.g. records
    and intensities of a fragility study) tabulate it once per worker (the table is read-only)."""
    from svbi.runtime.excitation.irregularity import SpectralIrregularity, make_irregularity

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
    from svbi.runtime.excitation.ground import ground_from_scenario

    return ground_from_scenario(scenario, duration)


# --------------------------------------------------------------------------------------------------
# the loop


def simulate(
    scenario: Scenario | str | Path | Mapping[str, Any],
    *,
    progress: bool = False,
    hold_train: bool = False,
    start: str | None = None,
    model: Model | None = None,
    clock_start: float | None = None,
    import_ahead: Sequence[str] = (),
    variables: Sequence[str] | None = None,
) -> xr.Dataset:
    """Run a scenario and return the results (DESIGN.md section 4).

    ``scenario`` is a :class:`Scenario`, a path to a scenario file, or a TOML-shaped dict.
    Python-API-only options: ``hold_train`` keeps the train at its start position (speed 0, needs
    ``solver.duration``); ``start`` ("auto", "static" or "rigid-track") replaces the scenario's
    ``train.initial``; ``model`` replaces the assembled model (e.g. with
    an analytic ground motion) — the scenario then only provides the echo and attributes;
    ``clock_start`` is the ``time.perf_counter()`` at which the caller began (``svbi run`` passes
    the time before it loaded the scenario), so that ``setup_time_s`` counts it; ``import_ahead``
    names modules the caller needs after the run (``svbi run``: the NetCDF writer), imported in the
    background with the results' own while a compiled loop runs (``results.ImportAhead``);
    ``variables`` keeps only those results variables (a sweep's metrics need a few of them).

    Timing attributes (DESIGN.md section 4): ``setup_time_s`` from the start (``clock_start`` or
    the call) to the first step (scenario, model build, initial state, stepper set-up),
    ``loop_time_s`` the time loop alone, ``wall_time_s`` everything until the results exist.
    """
    t_start = time.perf_counter() if clock_start is None else clock_start
    scenario = _as_scenario(scenario)
    if model is None:
        model = build_model(scenario, hold_train=hold_train)
    s = model.settings
    requested = s.backend
    if requested == "c" and not model.bridge.uniform and s.method != "localized-dynamic":
        warnings.warn(
            f"solver.backend = 'c' runs localized-dynamic on any bridge, the other methods on the "
            "paper's bridge (identical simply supported spans on rigid supports); this bridge "
            f"(continuous girders, unequal spans or piers) runs {s.method} on the NumPy backend",
            BackendFallback,
            stacklevel=2,
        )
        requested = "numpy"
    if requested == "casadi" and model.accelerating:
        warnings.warn(
            f"solver.backend = {requested!r} runs trains at constant speed; this one accelerates or "
            "brakes (train.acceleration) and runs on the NumPy backend",
            BackendFallback,
            stacklevel=2,
        )
        requested = "numpy"
    backend, cls = stepper_class(requested, s.method)
    state = initial_state(model, scenario.train.initial if start is None else start)
    stepper = cls(model, state)
    backend = getattr(stepper, "backend", backend)  # a compiled backend that fell back says so
    recorder = Recorder(model)
    aux_is_wheel = s.method == "coupled-classic"
    recorder.force(0, state.P, state.contact_state)
    recorder.record(state, model.contacts(0.0), aux_is_wheel)
    guard = DivergenceGuard(model)
    message = ""
    interrupted: KeyboardInterrupt | None = None
    bar = _Progress(s.steps) if progress else None
    run_loop = getattr(stepper, "run_loop", None)
    ahead = None
    t_loop = time.perf_counter()
    t_end_loop = t_loop
    try:
        if run_loop is not None:  # a compiled loop: whole chunks of steps per call, GIL released
            ahead = ImportAhead(recorder.modules_after_loop(), optional=import_ahead)
            run_loop(recorder, guard, bar)
        for n in range(s.steps if run_loop is None else 0):
            st = stepper.step(n)
            guard.check_finite(st)
            recorder.force(n + 1, st.P, st.contact_state)
            if (n + 1) % s.output_every == 0:
                gaps = recorder.record(st, stepper.contacts, aux_is_wheel)
                guard.check_gaps(st, gaps)
                if bar is not None:
                    bar.update(s.output_every)
    except Diverged as exc:
        message = str(exc)
        _drop_bad_rows(recorder)
    except KeyboardInterrupt as exc:  # Ctrl-C, or SIGTERM under `svbi run`: keep what was computed
        interrupted = exc
        _drop_bad_rows(recorder)  # the signal may fall between a chunk's rows and its step count
        message = (
            f"interrupted by {signal_name(exc)} at t = {recorder.steps_done * s.time_step:.6g} s "
            f"(step {recorder.steps_done} of {s.steps})"
        )
    finally:
        t_end_loop = time.perf_counter()
        if bar is not None:
            bar.close()
    from svbi import __version__

    attrs: dict[str, Any] = {
        "svbi_version": __version__,
        "method": s.method,
        "backend": backend,
        "backend_requested": s.backend,
        "time_step": s.time_step,
        "steps": int(recorder.steps_done),
        "output_every": s.output_every,
        "constraint_kappa": s.kappa,
        "constraint_zeta": s.zeta,
        "contact_split": s.split,
        "setup_time_s": t_loop - t_start,
        "loop_time_s": t_end_loop - t_loop,
        "scenario": _echo(scenario, model),
        "complete": 0 if message else 1,
    }
    numpy_steps = getattr(stepper, "numpy_steps", None)
    if numpy_steps is not None:  # a compiled loop that handed steps to NumPy (contact events)
        attrs["numpy_steps"] = int(numpy_steps)
    if message:
        attrs["incomplete"] = message
    if ahead is not None:
        ahead.join()
    ds = recorder.dataset(attrs, variables)
    ds.attrs["wall_time_s"] = time.perf_counter() - t_start
    if interrupted is not None:  # the caller gets the exception, and the partial results with it
        raise RunInterrupted(getattr(interrupted, "signum", signal.SIGINT), ds) from None
    if message:
        warnings.warn(message, SimulationIncomplete, stacklevel=2)
    return ds


def _as_scenario(scenario: Scenario | str | Path | Mapping[str, Any]) -> Scenario:
    if isinstance(scenario, Scenario):
        return scenario
    if isinstance(scenario, str | Path):
        return load_scenario(scenario)
    return validate_scenario(dict(scenario))


def _echo(scenario: Scenario, model: Model) -> str:
    data = scenario.to_dict()
    data["solver"]["duration"] = model.settings.steps * model.settings.time_step
    if scenario.solver.duration is not None:
        data["solver"]["duration"] = scenario.solver.duration
    import tomli_w

    return tomli_w.dumps(data)


class _Progress:
    """tqdm's progress bar of the steps, shown once the run has lasted ``delay`` seconds.

    tqdm's own ``delay`` hides a bar as long, but importing tqdm costs about 0.03 s of every run,
    shown a bar or not (a tenth of the paper example's fixed costs): the bar, and the import, come
    at the first update after ``delay``, counting from the start and with the steps done so far.
    """

    def __init__(self, total: int, delay: float = 1.0) -> None:
        self.total, self.delay, self.done = total, delay, 0
        self.start, self.wall_start = time.perf_counter(), time.time()  # tqdm's clock: time.time
        self.bar: Any = None

    def update(self, steps: int) -> None:
        self.done += steps
        if self.bar is not None:
            self.bar.update(steps)
        elif time.perf_counter() - self.start >= self.delay:
            from tqdm.auto import tqdm

            self.bar = tqdm(
                total=self.total, initial=self.done, unit="step", mininterval=0.5, dynamic_ncols=True
            )
            # the elapsed time and the rate of the whole loop, as if the bar had been there
            self.bar.start_t, self.bar.initial = self.wall_start, 0
            self.bar.refresh()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _drop_bad_rows(recorder: Recorder) -> None:
    """Safety net: the guard runs before anything is stored, but never keep a non-finite row."""
    f = recorder.forces[: recorder.steps_done + 1]
    bad = ~np.isfinite(f).all(axis=1)
    if bad.any():
        recorder.steps_done = max(int(np.argmax(bad)) - 1, 0)
    k = min(recorder.count, 1 + recorder.steps_done // recorder.model.settings.output_every)
    while k > 0 and not all(np.isfinite(a[k - 1]).all() for a in recorder.data.values()):
        k -= 1
    recorder.count = k


MECHANISM_HZ = 0.05
"""A bridge whose lowest natural frequency is below this (Hz) is reported as nearly a mechanism
when a run diverges (no railway bridge is that soft: the lowest are about 1 Hz)."""


class DivergenceGuard:
    """Stops a run that has gone unstable, with the time, the quantity and the likely cause."""

    def __init__(self, model: Model) -> None:
        self.model = model
        tr = model.train
        static = tr.axle_loads if tr.moving_load else tr.static_loads()
        self.force_limit = FORCE_LIMIT_FACTOR * max(float(np.abs(static).max(initial=0.0)), 1.0)
        self.classic = model.settings.method == "coupled-classic"

    def _cause(self) -> str:
        s = self.model.settings
        if self.classic:
            return (
                "coupled-classic imposes the constraints at acceleration level only, so the gaps drift "
                "(use localized-dynamic or coupled-dynamic)"
            )
        if s.kappa > 2:
            return (
                f"constraint_kappa = {s.kappa:g} > 2 makes the gap correction overshoot and oscillate; "
                "use 0.5 <= kappa <= 2"
            )
        # a bridge that is nearly a mechanism (a bearing or pier of almost no stiffness) drifts
        # away at any time step: look before blaming the step
        try:
            f1 = float(self.model.bridge.natural_frequencies(1)[0])
        except Exception:  # noqa: BLE001 - a diagnosis must not hide the divergence it explains
            f1 = float("nan")
        if f1 < MECHANISM_HZ:
            return (
                f"the bridge is nearly a mechanism: its lowest natural frequency is {f1:.3g} Hz "
                "(supports held); check the stiffness of its bearings and piers"
            )
        return f"the time step ({s.time_step:g} s) may be too large for this model; try a smaller one"

    def check_finite(self, st: Any) -> None:
        total = st.P.sum() + st.uB.sum() + st.uV.sum()
        if not math.isfinite(total):
            which = (
                "contact_force"
                if not np.isfinite(st.P).all()
                else ("bridge displacement" if not np.isfinite(st.uB).all() else "vehicle displacement")
            )
            raise Diverged(
                f"run diverged at t = {st.t:.6g} s: {which} is not finite (NaN or Inf); "
                f"likely cause: {self._cause()}"
            )
        P = max(st.P.max(initial=0.0), -st.P.min(initial=0.0))
        if P > self.force_limit:
            raise Diverged(
                f"run diverged at t = {st.t:.6g} s: contact_force = {P:.4g} N exceeds "
                f"{self.force_limit:.3g} N ({FORCE_LIMIT_FACTOR:g} x the static wheel load); "
                f"likely cause: {self._cause()}"
            )

    def check_gaps(self, st: Any, gaps: Mapping[str, np.ndarray]) -> None:
        """Constraint violations beyond ``solver.max_gap`` stop the run. The bridge gap counts the
        wheels in contact only: an airborne wheel's gap is its uplift, not a violation, and it
        stops the run only when the wheel flies higher than the limit (derailment, reported so)."""
        limit = self.model.settings.max_gap
        state = getattr(st, "contact_state", None)
        for name, g in gaps.items():
            g = np.asarray(g, dtype=float)
            if name == "bridge" and state is not None:
                flying = ~np.asarray(state, dtype=bool).reshape(g.shape)
                uplift = np.where(flying, g, 0.0)
                if not float(uplift.max(initial=0.0)) <= limit:
                    j = int(np.argmax(uplift))
                    car, wheel = divmod(j, self.model.train.wheels)
                    raise Diverged(
                        f"run stopped at t = {st.t:.6g} s: wheel {wheel + 1} of car {car + 1} flies "
                        f"{uplift[j]:.4g} m above its rail (more than solver.max_gap = {limit:g} m): "
                        "derailment is likely; a vertical model cannot follow the wheel off the rail"
                    )
                g = np.where(flying, 0.0, g)
            worst = float(np.abs(g).max(initial=0.0))
            if not worst <= limit:
                raise Diverged(
                    f"run diverged at t = {st.t:.6g} s: |gap_{name}| = {worst:.4g} m exceeds "
                    f"{limit:g} m (solver.max_gap); likely cause: {self._cause()}"
                )
