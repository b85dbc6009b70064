"""Time per step of the three methods on the paper's case: 10 Pioneer cars on 10 spans of 32 m.

    .venv/bin/python benchmarks/bench_methods.py [--steps 1000] [--elements 16]

All 40 wheels are on the bridge during the timed steps (the train starts in static equilibrium on
the deflected bridge, leading axle at 250 m). Only the time loop is timed, after a short warm-up:
set-up (factorisations, symbolic kernels) is excluded. The paper reports localized-dynamic about 2x
faster than coupled-dynamic.
"""

from __future__ import annotations

import argparse
import time

from svbi.examples import paper_section_keys
from svbi.runtime.methods.initial import initial_state
from svbi.runtime.run.simulate import build_model, stepper_class
from svbi.runtime.scenario.schema import validate_scenario

METHODS = ("localized-dynamic", "coupled-dynamic", "coupled-classic")


def scenario(method: str, elements: int):
    return validate_scenario(
        {
            "bridge": dict(
                spans=10,
                span_length=32.0,
                **paper_section_keys(),
                elements_per_span=elements,
            ),
            "train": dict(vehicle="pioneer-2d", cars=10, speed_kmh=300.0, start_position=250.0),
            "solver": dict(method=method, backend="numpy", time_step=1e-4, duration=1.0),
        }
    )


def time_method(method: str, steps: int, elements: int, warmup: int = 20) -> float:
    """Microseconds per step of ``method`` (best of three blocks)."""
    model = build_model(scenario(method, elements))
    state = initial_state(model, "static")
    _, cls = stepper_class("numpy", method)
    stepper = cls(model, state)
    for n in range(warmup):
        stepper.step(n)
    assert model.contacts(model.dt * (warmup + 3 * steps)).on.all(), "a wheel left the bridge"
    best = float("inf")
    n0 = warmup
    for _ in range(3):
        t0 = time.perf_counter()
        for n in range(n0, n0 + steps):
            stepper.step(n)
        best = min(best, time.perf_counter() - t0)
        n0 += steps
    return best / steps * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=1000, help="steps per timed block (3 blocks)")
    parser.add_argument("--elements", type=int, default=16, help="elements per span")
    args = parser.parse_args()
    times = {m: time_method(m, args.steps, args.elements) for m in METHODS}
    ref = times["coupled-dynamic"]
    print(
        f"10 pioneer-2d cars (140 DOFs, 40 contacts) on 10 spans x {args.elements} elements, "
        f"dt = 1e-4 s, NumPy backend"
    )
    print(f"{'method':<20} {'us/step':>10} {'vs coupled-dynamic':>20}")
    for m, us in times.items():
        print(f"{m:<20} {us:>10.0f} {ref / us:>19.2f}x")
    print(f"localized / coupled-dynamic speed-up: {ref / times['localized-dynamic']:.2f}x")


if __name__ == "__main__":
    main()
