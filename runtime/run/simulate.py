"""``svbi.simulate(scenario)``: assemble the model, run the Newmark loop, return the results.

The stepper of a method on a backend comes from ``svbi.runtime.backends.registry``; the model from
``svbi.runtime.scenario.build``.

A run that goes unstable (NaN or Inf, a runaway gap, an absurd contact force) stops with a message
naming the time, the quantity and the likely cause. What was computed until then is returned,
marked ``complete = 0`` with the message in the ``incomplete`` attribute; nothing non-finite is
stored. Ctrl-C (or SIGTERM under ``svbi run``) during the loop raises
:class:`~svbi.runtime.run.output.RunInterrupted` carrying the results computed so far, marked the
same way.
"""

from __future__ import annotations

import signal
import time
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ... import __version__
from ..backends.base import BackendFallback
from ..backends.registry import register_backend, stepper_class
from ..methods.guard import FORCE_LIMIT_FACTOR, Diverged, DivergenceGuard
from ..methods.initial import initial_state
from ..model.system import Model
from ..scenario.build import build_model, run_extent
from ..scenario.schema import Scenario, load_scenario, validate_scenario
from .output import RunInterrupted, signal_name
from .results import ImportAhead, Recorder

__all__ = [
    "FORCE_LIMIT_FACTOR",
    "BackendFallback",
    "Diverged",
    "DivergenceGuard",
    "SimulationIncomplete",
    "build_model",
    "register_backend",
    "run_extent",
    "simulate",
    "stepper_class",
    "validate_scenario",
]
"""Re-exported for callers of the run: the loop's errors, guard and model assembly have their homes
in ``svbi.runtime.methods.guard``, ``svbi.runtime.backends`` and ``svbi.runtime.scenario.build``."""

if TYPE_CHECKING:
    import xarray as xr


class SimulationIncomplete(RuntimeWarning):
    """The run stopped early (diverged); the returned results are partial."""


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
    """Run a scenario and return the results (docs/design.md section 7).

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

    Timing attributes (docs/design.md section 7): ``setup_time_s`` from the start (``clock_start`` or
    the call) to the first step (scenario, model build, initial state, stepper set-up),
    ``loop_time_s`` the time loop alone, ``wall_time_s`` everything until the results exist.
    """
    t_start = time.perf_counter() if clock_start is None else clock_start
    scenario = _as_scenario(scenario)
    if scenario.dimensions == 3 and model is None:  # the 3D run (docs/three-d.md, "3D runs")
        from .simulate3d import simulate3d

        return simulate3d(
            scenario, progress=progress, hold_train=hold_train, clock_start=t_start, variables=variables
        )
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
