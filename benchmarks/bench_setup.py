"""Set-up of long bridges: how the time to build the bridge grows with spans, piers and elements.

    .venv/bin/python benchmarks/bench_setup.py [--quick]

The bridge's set-up (``scenario.build.bridge_from_scenario``: substructure matrices, Rayleigh
damping from the lowest modes, the global sparse matrices, the quasi-static field of every support,
the dead-load reactions) and the memory estimate (``run.memory.estimate_memory``, which sizes a run
from the layout alone), for

1. N simply supported 32 m spans on 12 m piers (every interior support line), N = 100, 400, 1000
   (and 2000 without ``--quick``), 16 elements per span;
2. one girder continuous over N spans, N = 100, 300;
3. 4 spans on piers with 2000 elements per span.

Times are the process's CPU time (``time.process_time``, robust when other jobs share the cores),
best of 3 (1 above 400 spans), and the wall time of that run; ``per span`` is CPU ms per span, flat
when the set-up is linear.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from bench_bridges import on_piers  # noqa: E402
from bench_solver import on_bridge  # noqa: E402

from svbi.runtime.run.memory import estimate_memory  # noqa: E402
from svbi.runtime.scenario.build import bridge_from_scenario  # noqa: E402
from svbi.runtime.scenario.schema import validate_scenario  # noqa: E402


def continuous(spans: int):
    """``on_bridge``'s paper section as one girder continuous over ``spans`` 32 m spans."""
    data = on_bridge(10, spans, 16, "localized-dynamic", "c", dt=1e-3).to_dict()
    b = data["bridge"]
    span = b.pop("span_length")
    b.pop("spans")
    b["girders"] = [dict(spans=[span] * spans)]
    return validate_scenario(data)


def fine(elements: int):
    """Four spans on piers with ``elements`` elements per span."""
    data = on_piers(4).to_dict()
    data["bridge"]["elements_per_span"] = elements
    return validate_scenario(data)


def timed(fn, repeats: int) -> tuple[float, float]:
    """Best CPU time of ``repeats`` calls, and the wall time of that call."""
    best = (float("inf"), 0.0)
    for _ in range(repeats):
        c0, w0 = time.process_time(), time.perf_counter()
        fn()
        best = min(best, (time.process_time() - c0, time.perf_counter() - w0))
    return best


def row(label: str, spans: int, scenario) -> None:
    repeats = 3 if spans <= 400 else 1
    cpu, wall = timed(lambda: bridge_from_scenario(scenario), repeats)
    est, _ = timed(lambda: estimate_memory(scenario), repeats)
    print(f"{label:<28}{spans:>6}{cpu:>10.2f}{wall:>10.2f}{1e3 * cpu / spans:>10.1f}{est:>12.2f}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="up to 1000 spans on piers")
    args = parser.parse_args()
    print("Bridge set-up (bridge_from_scenario) and memory estimate: CPU s, best of 3 (1 above 400 spans)")
    print(f"{'bridge':<28}{'spans':>6}{'cpu s':>10}{'wall s':>10}{'ms/span':>10}{'estimate s':>12}")
    for n in (100, 400, 1000) if args.quick else (100, 400, 1000, 2000):
        row("spans on piers", n, on_piers(n))
    for n in (100, 300):
        row("continuous girder", n, continuous(n))
    row("4 spans, 2000 elements each", 4, fine(2000))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
