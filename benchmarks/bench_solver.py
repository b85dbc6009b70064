"""Cost of the time loop: backends x methods on the paper's case, and how it scales.

    .venv/bin/python benchmarks/bench_solver.py [--quick]

1. **Paper scenario** (``examples/paper-2020.toml``: 10 Pioneer cars, 10 spans x 16 elements,
   300 km/h, dt = 1e-4 s until the last axle leaves, German-low track, synthetic earthquake, creep):
   * ``us/step``: the loop alone, with all 40 wheels on the bridge (the train starts on the deflected
     bridge, leading axle at 250 m), median of 3 blocks, after a warm-up; set-up excluded. Timed
     with the thread's CPU clock (``time.thread_time``): the same as wall time on an idle machine,
     and robust when other jobs share the two cores;
   * ``total s``: a complete ``svbi.simulate`` (model assembly, initial state, loop, results), median
     of 3, in a process that has already run it once (the symbolic set-up, cached per process, is
     the ``cold`` column of localized/c). Runs marked ``~`` are extrapolated: measured set-up plus the
     all-on ``us/step`` times the full number of steps, an upper bound (a third of the steps have
     fewer wheels on the bridge).
2. **Scaling** (C backend): ``us/step`` with the bridge full of wheels, for 1, 10, 100 cars on 10
   spans and for 10 cars on 10, 100, 1000 spans, and 100 cars on 1000 spans at dt = 1e-3 (real time
   factor = dt / time per step).

3. **Unilateral contact** (``--unilateral`` runs only this): C localized-dynamic with nothing
   separating against the bilateral run, loop time per step (target: at most 1.1x).

Ratios (C vs NumPy, localized vs coupled-dynamic) come from the same run.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from svbi.examples import paper_section_keys
from svbi.runtime.methods.initial import initial_state
from svbi.runtime.methods.steppers import numpy_steppers
from svbi.runtime.run.results import Recorder
from svbi.runtime.run.simulate import DivergenceGuard, build_model
from svbi.runtime.scenario.schema import load_scenario, validate_scenario

PAPER = Path(__file__).resolve().parents[1] / "examples" / "paper-2020.toml"
METHODS = ("localized-dynamic", "coupled-dynamic", "coupled-classic")
BACKENDS = ("c", "numpy", "casadi")


def paper(method: str, backend: str, **overrides: object):
    """The paper scenario with solver.method, solver.backend and dotted-key overrides."""
    return load_scenario(PAPER, overrides={"solver.method": method, "solver.backend": backend, **overrides})


def on_bridge(cars: int, spans: int, elements: int, method: str, backend: str, dt: float = 1e-4):
    """The paper's bridge and cars, with the train on the bridge (as many wheels as fit)."""
    start = min(spans * 32.0 - 5.0, (cars - 1) * 25.0 + 20.0 + 5.0)
    return validate_scenario(
        {
            "bridge": dict(
                spans=spans,
                span_length=32.0,
                **paper_section_keys(),
                elements_per_span=elements,
                rail_height=2.0,
            ),
            "train": dict(vehicle="pioneer-2d", cars=cars, speed_kmh=300.0, start_position=start),
            "track": dict(irregularity="german-low", seed=1),
            "earthquake": dict(vertical="synthetic", longitudinal="synthetic"),
            # the paper's rigid contact, as the paper example: the loop's own cost, without the
            # landing steps a unilateral run hands to NumPy
            "contact": dict(normal="bilateral"),
            "solver": dict(method=method, backend=backend, time_step=dt, duration=0.4, output_every=10),
        }
    )


def _stepper(model, backend: str, method: str):
    # the static start (train at rest on the deflected bridge) is sparse (SuperLU) and linear in
    # cars and spans: 0.3 s for 100 cars on 1000 spans, so every case starts from it
    state = initial_state(model, "static")
    if backend == "c":
        from svbi.runtime.backends.c.stepper import CStepper

        return CStepper(model, state, method)
    if backend == "casadi":
        from svbi.runtime.backends.casadi import casadi_stepper

        return casadi_stepper(method)(model, state)
    return numpy_steppers()[method](model, state)


def per_step_us(scenario, backend: str, method: str, steps: int, warmup: int = 10) -> float:
    """Median microseconds per step over 3 blocks of ``steps`` (loop only)."""
    dt = scenario.solver.time_step
    data = scenario.to_dict()
    data["solver"]["duration"] = (warmup + 3 * steps + 2) * dt
    scenario = validate_scenario(data, check=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = build_model(scenario)
        stepper = _stepper(model, backend, method)
    times = []
    if backend == "c":
        recorder = Recorder(model)
        stepper.setup.force_limit = DivergenceGuard(model).force_limit
        out = stepper._outputs(recorder)
        n0 = 0
        stepper._call(out, n0, warmup)
        n0 += warmup
        for _ in range(3):
            out.row = 1
            t0 = time.thread_time()
            status = stepper._call(out, n0, steps)
            times.append(time.thread_time() - t0)
            assert status == 0, status
            n0 += steps
    else:
        for n in range(warmup):
            stepper.step(n)
        n0 = warmup
        for _ in range(3):
            t0 = time.thread_time()
            for n in range(n0, n0 + steps):
                stepper.step(n)
            times.append(time.thread_time() - t0)
            n0 += steps
    return 1e6 * statistics.median(times) / steps


def total_s(
    scenario, repeats: int = 3, inner_attr: str = "wall_time_s", backend: str | None = None
) -> tuple[float, float, int]:
    """Median wall time of complete runs, and of simulate's own timer ``inner_attr`` (its
    loop-and-results time by default); steps. With ``backend``, the runs must have run on it."""
    import svbi

    walls, inner = [], []
    steps = 0
    for _ in range(repeats):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t0 = time.perf_counter()
            ds = svbi.simulate(scenario)
            walls.append(time.perf_counter() - t0)
        assert backend is None or ds.attrs["backend"] == backend, ds.attrs["backend"]
        inner.append(float(ds.attrs[inner_attr]))
        steps = int(ds.attrs["steps"])
    return statistics.median(walls), statistics.median(inner), steps


def setup_s(method: str, backend: str) -> float:
    """Wall time of a one-step run (everything but the loop), warm process."""
    # one step; the quake then arrives at t = 0 (it must start within the run)
    w, _, _ = total_s(
        paper(
            method, backend, **{"solver.duration": 1e-4, "solver.output_every": 1, "earthquake.arrival": 0.0}
        ),
        repeats=2,
    )
    return w


def paper_table(quick: bool) -> dict[tuple[str, str], float]:
    print(
        "Paper scenario (examples/paper-2020.toml): 10 pioneer-2d cars, 10 spans x 16 elements, "
        "dt = 1e-4 s, quake, German-low track, creep"
    )
    import svbi

    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        svbi.simulate(paper("localized-dynamic", "c"))
    cold = time.perf_counter() - t0
    steps_of = {"numpy": 100 if quick else 300, "casadi": 20 if quick else 60, "c": 2000}
    rows = {}
    print(f"{'backend':<8}{'method':<20}{'us/step':>10}{'total s':>10}   note")
    full_steps = None
    for backend in BACKENDS:
        for method in METHODS:
            steps = steps_of[backend] if not (backend == "c" and method != "localized-dynamic") else 500
            us = per_step_us(on_bridge(10, 10, 16, method, backend), backend, method, steps)
            rows[(backend, method)] = us
            if backend == "c" and method == "localized-dynamic":
                wall, inner, full_steps = total_s(paper(method, backend))
                note = (
                    f"complete runs, median of 3 (simulate's own timer {inner:.2f} s; first run in a "
                    f"fresh process {cold:.1f} s, symbolic set-up included)"
                )
                total = f"{wall:>10.2f}"
            else:
                setup = setup_s(method, backend)
                est = setup + us * 1e-6 * (full_steps or 71460)
                total = f"{'~' + format(est, '.1f'):>10}"
                note = f"extrapolated: set-up {setup:.2f} s + {full_steps} steps x all-on cost"
            print(f"{backend:<8}{method:<20}{us:>10.1f}{total}   {note}")
    c, npy = rows[("c", "localized-dynamic")], rows[("numpy", "localized-dynamic")]
    print(
        f"ratios: C vs NumPy (localized) {npy / c:.0f}x, (coupled-dynamic) "
        f"{rows[('numpy', 'coupled-dynamic')] / rows[('c', 'coupled-dynamic')]:.0f}x; "
        f"localized vs coupled-dynamic: C {rows[('c', 'coupled-dynamic')] / c:.1f}x, NumPy "
        f"{rows[('numpy', 'coupled-dynamic')] / npy:.1f}x, CasADi "
        f"{rows[('casadi', 'coupled-dynamic')] / rows[('casadi', 'localized-dynamic')]:.1f}x"
    )
    return rows


def scaling_table(quick: bool) -> None:
    print("\nScaling, C backend, bridge full of wheels (us per step; per car / per span in brackets)")
    print(f"{'cars':>6}{'spans':>7}{'dt':>8}{'localized':>12}{'coupled-dyn':>13}{'real-time x':>13}")
    cases = [
        (1, 10, 1e-4),
        (10, 10, 1e-4),
        (100, 10, 1e-4),
        (10, 100, 1e-4),
        (10, 1000, 1e-4),
        (100, 1000, 1e-3),
    ]
    if quick:
        cases = [(1, 10, 1e-4), (10, 10, 1e-4), (10, 100, 1e-4), (100, 1000, 1e-3)]
    for cars, spans, dt in cases:
        steps = 200 if spans < 1000 else 40
        loc = per_step_us(
            on_bridge(cars, spans, 16, "localized-dynamic", "c", dt), "c", "localized-dynamic", steps
        )
        cpl = per_step_us(
            on_bridge(cars, spans, 16, "coupled-dynamic", "c", dt),
            "c",
            "coupled-dynamic",
            max(steps // 4, 10),
        )
        print(
            f"{cars:>6}{spans:>7}{dt:>8g}{loc:>12.1f}{cpl:>13.1f}{1e6 * dt / loc:>13.1f}   "
            f"[{loc / cars:.2f} us/car, {loc / spans:.3f} us/span]"
        )


def unilateral_overhead(quick: bool) -> float:
    """C localized-dynamic, unilateral contact with nothing separating, against bilateral.

    10 Pioneer cars standing (speed 0) on 10 spans under the synthetic earthquake, static start:
    no wheel unloads, so the unilateral run stays on the C loop, whose steps are those of the
    bilateral run plus, per chunk, the test that no contact force went tensile
    (docs/method.md section 12). Complete ``svbi.simulate`` runs, loop time per step
    (``loop_time_s``, recording included), median of 3 alternating pairs.
    """
    import svbi

    steps = 5000 if quick else 20000
    base = on_bridge(10, 10, 16, "localized-dynamic", "c").to_dict()
    base["train"]["speed_kmh"] = 0.0
    base["solver"]["duration"] = steps * base["solver"]["time_step"]
    base["earthquake"]["arrival"] = 0.0
    per_step: dict[str, list[float]] = {"bilateral": [], "unilateral": []}
    for _ in range(3):
        for normal in per_step:
            data = {**base, "contact": {**base.get("contact", {}), "normal": normal}}
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ds = svbi.simulate(validate_scenario(data), start="static")
            assert ds.attrs["backend"] == "c" and ds.attrs["liftoffs"] == 0, ds.attrs["backend"]
            per_step[normal].append(1e6 * ds.attrs["loop_time_s"] / ds.attrs["steps"])
    bi, uni = (statistics.median(per_step[k]) for k in ("bilateral", "unilateral"))
    print(
        f"\nUnilateral contact, nothing separating (C localized-dynamic, 10 cars standing on 10 spans, "
        f"quake, {steps} steps): bilateral {bi:.1f} us/step, unilateral {uni:.1f} us/step, "
        f"ratio {uni / bi:.3f} (target <= 1.1)"
    )
    return uni / bi


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer steps and cases")
    parser.add_argument("--unilateral", action="store_true", help="only the unilateral-contact overhead")
    args = parser.parse_args()
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} CPUs, numpy {np.__version__}")
    if not args.unilateral:
        paper_table(args.quick)
        scaling_table(args.quick)
    unilateral_overhead(args.quick)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
