"""Bridges of substructures in the C loop (runtime/csrc/substructures.c): the viaduct example, and scaling.

    .venv/bin/python benchmarks/bench_bridges.py [--quick]

1. **Viaduct example** (``examples/viaduct.toml``: 5 x 32 m spans on piers + a continuous 40-56-40 m
   unit on piers, 10 Pioneer cars at 300 km/h, the paper's earthquake): complete ``svbi.simulate``
   runs, localized-dynamic on the C and NumPy backends: loop time (``loop_time_s``) and total, and
   their ratio, median of 3 (NumPy: 1) in a warm process.
2. **Scaling**: ``us/step`` of the C loop with the bridge full of wheels (10 cars), for N simply
   supported 32 m spans on 12 m piers (every interior line; links: the bearings) against the paper's
   bridge of N spans on rigid supports (the blocked path of localized.c), N = 10, 100 (and 400
   without ``--quick``), dt = 1e-3 s. Timed with the thread's CPU clock, median of 3 blocks.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from bench_solver import on_bridge, per_step_us, total_s  # noqa: E402

from svbi.runtime.scenario.schema import load_scenario, validate_scenario  # noqa: E402

VIADUCT = HERE.parent / "examples" / "viaduct.toml"
PIER = dict(height=12.0, mass_per_length=22.5e3, youngs_modulus=34.0e9, area=9.0, second_moment=6.1)


def on_piers(spans: int, dt: float = 1e-3):
    """``on_bridge``'s paper bridge and train, every interior support line on a 12 m pier."""
    data = on_bridge(10, spans, 16, "localized-dynamic", "c", dt=dt).to_dict()
    b = data["bridge"]
    span = b.pop("span_length")
    b.pop("spans")
    b["girders"] = [dict(spans=[span])] * spans
    b["piers"] = [dict(support=j, **PIER) for j in range(1, spans)]
    return validate_scenario(data)


def viaduct_table(repeats: int) -> None:
    print("Viaduct example (examples/viaduct.toml), localized-dynamic, complete runs")
    print(f"{'backend':<8}{'loop s':>10}{'total s':>10}{'steps':>9}")
    loops = {}
    for backend, n in (("c", repeats), ("numpy", 1)):
        sc = load_scenario(VIADUCT, overrides={"solver.backend": backend})
        wall, loops[backend], steps = total_s(sc, n, "loop_time_s", backend)
        print(f"{backend:<8}{loops[backend]:>10.2f}{wall:>10.2f}{steps:>9}")
    print(f"ratio: C vs NumPy (loop) {loops['numpy'] / loops['c']:.0f}x")


def scaling_table(quick: bool) -> None:
    print("\nScaling (C, localized-dynamic, 10 cars on the bridge, dt = 1e-3 s): us/step")
    print(f"{'spans':>6}{'on piers':>11}{'paper bridge':>14}{'ratio':>8}{'real time x':>13}")
    for spans in (10, 100) if quick else (10, 100, 400):
        steps = 300 if spans <= 100 else 100
        general = per_step_us(on_piers(spans), "c", "localized-dynamic", steps)
        paper = per_step_us(
            on_bridge(10, spans, 16, "localized-dynamic", "c", dt=1e-3), "c", "localized-dynamic", steps
        )
        print(f"{spans:>6}{general:>11.1f}{paper:>14.1f}{general / paper:>8.1f}{1e3 / general:>13.1f}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one C run, spans up to 100")
    args = parser.parse_args()
    viaduct_table(1 if args.quick else 3)
    scaling_table(args.quick)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
