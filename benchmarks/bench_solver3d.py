"""Cost of the 3D time step: the compiled loop against the NumPy step, and the 2D C step.

    .venv/bin/python benchmarks/bench_solver3d.py [--quick]

The 3D paper case (``examples/paper-2020-3d.toml``'s bridge, track and earthquake, with 10
manchester-3d cars and the synthetic record at its full level, as the figures of docs/performance.md
were measured: 10 spans x 32 m x 16 elements, 300 km/h, every wheelset on the deck, German-low track
in three directions, a three-component synthetic earthquake, creep, unilateral contact, dt = 1e-4
s; the example itself runs crh380a-3d cars at 0.2 of that level): microseconds per
step of the loop alone (set-up excluded), median of 3 blocks after a warm-up, timed with the
thread's CPU clock (``time.thread_time``: robust when other jobs share the cores):

* ``3D C``: :meth:`LocalizedDynamic3DC.advance` of a block: the excitation of the block (the
  elements under the wheelsets, the ground under them and the supports' targets, built in Python,
  vectorised over the block's steps) and the C call (with its Python wrapper: the output arrays);
* ``3D NumPy``: :class:`LocalizedDynamic3D` steps (the kernels' irregularity set per step);
* ``2D C``: the 2D paper case's C localized-dynamic step, all 40 wheels on the bridge
  (``bench_solver.py``'s machinery, same process).

Ratios (3D C / 2D C, NumPy / C) come from the same run. Targets: 3D C within 3x the 2D C step,
at least 30x faster than NumPy, a whole run faster than real time (under 100 us per step at
dt = 1e-4 s).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from bench_solver import on_bridge, per_step_us  # noqa: E402

from svbi.runtime.backends.c.stepper3d import LocalizedDynamic3DC  # noqa: E402
from svbi.runtime.methods.coupled3d import State3D, static_state  # noqa: E402
from svbi.runtime.methods.localized3d import LocalizedDynamic3D  # noqa: E402
from svbi.runtime.run.simulate3d import build_run3d  # noqa: E402
from svbi.runtime.scenario.schema import load_scenario  # noqa: E402

PAPER3D = HERE.parents[0] / "examples" / "paper-2020-3d.toml"


def _copy(st: State3D) -> State3D:
    return State3D(**{k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in vars(st).items()})


def case():
    # the whole train on the deck at t = 0 (the example starts on the approach track), the
    # earthquake from t = 0
    overrides = {
        "solver.duration": 0.3,
        "train.start_position": 230.0,
        "earthquake.arrival": 0.0,
        "train.vehicle": "manchester-3d",
        "earthquake.scale": 1.0,
    }
    scenario = load_scenario(PAPER3D, overrides=overrides)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = build_run3d(scenario)
    return scenario, run, static_state(run.system)


def c_per_step(run, state, dt: float, steps: int, warmup: int = 20) -> tuple[float, float, int]:
    """(us per step of the excitation built in Python, us per step of the C call of
    :meth:`LocalizedDynamic3DC.advance` with it, bandwidth of the span's factor), medians of 3 blocks."""
    stepper = LocalizedDynamic3DC(run.system, _copy(state), dt)
    level = lambda n0, k: np.array([run.irregularity_at((n + 1) * dt) for n in range(n0, n0 + k)])  # noqa: E731
    stepper.advance(0, warmup, level(0, warmup), 10, reuse=True)
    n0, excite, loop = warmup, [], []
    build = stepper.excitation
    for _ in range(3):
        irr = level(n0, steps)
        t0 = time.thread_time()
        ex = build(n0, steps, irr)
        t1 = time.thread_time()
        stepper.excitation = lambda *_, ex=ex: ex  # type: ignore[method-assign]
        stepper.advance(n0, steps, irr, 10, reuse=True)
        t2 = time.thread_time()
        assert stepper.stopped is None, stepper.stopped
        excite.append(t1 - t0)
        loop.append(t2 - t1)
        n0 += steps
    return 1e6 * statistics.median(excite) / steps, 1e6 * statistics.median(loop) / steps, stepper.bandwidth


def numpy_per_step(run, state, dt: float, steps: int) -> float:
    stepper = LocalizedDynamic3D(run.system, _copy(state), dt)
    times = []
    n = 0
    for _ in range(3):
        t0 = time.thread_time()
        for _ in range(steps):
            for kernel, r in zip(stepper.kernels, run.irregularity_at((n + 1) * dt), strict=True):
                kernel.irregularity = r
            stepper.step(n)
            n += 1
        times.append(time.thread_time() - t0)
    return 1e6 * statistics.median(times) / steps


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer steps")
    args = parser.parse_args(argv)
    scenario, run, state = case()
    dt = scenario.solver.time_step
    nW = len(run.system.vehicle.wheelsets)
    print(
        f"3D paper case (examples/paper-2020-3d.toml): {run.cars} cars, {nW} wheelsets on the deck, "
        f"{run.system.vehicle.M.shape[0]} vehicle DOFs, {run.system.span.M.shape[0]} bridge DOFs, "
        f"dt = {dt:g} s"
    )
    c_steps = 100 if args.quick else 400
    c3_ex, c3_loop, bw = c_per_step(run, state, dt, c_steps)
    c3 = c3_ex + c3_loop
    np3 = numpy_per_step(run, state, dt, 3 if args.quick else 10)
    c2 = per_step_us(on_bridge(10, 10, 16, "localized-dynamic", "c"), "c", "localized-dynamic", 2000)
    print(f"{'step':<34}{'us/step':>10}")
    print(f"{'3D C (advance, excitation incl.)':<34}{c3:>10.1f}")
    print(f"{'  of which the excitation (Python)':<34}{c3_ex:>10.1f}")
    print(f"{'  of which the C call':<34}{c3_loop:>10.1f}")
    print(f"{'3D NumPy':<34}{np3:>10.1f}")
    print(f"{'2D C localized-dynamic (paper)':<34}{c2:>10.1f}")
    print(
        f"ratios: 3D C / 2D C {c3 / c2:.1f}x (loop alone {c3_loop / c2:.1f}x); NumPy / 3D C {np3 / c3:.0f}x "
        f"(loop alone {np3 / c3_loop:.0f}x); real-time factor at dt = {dt:g} s: {dt * 1e6 / c3:.2f} "
        f"(span factor half-bandwidth {bw})"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
