"""End-to-end cost of ``svbi run`` as a user meets it: a fresh process, the README's command.

    .venv/bin/python benchmarks/bench_startup.py [--quick]

1. **Paper scenario** (``svbi run examples/paper-2020.toml``), fresh process each time, warm compile
   cache: the process's wall time against the ``setup_time_s`` / ``loop_time_s`` / ``wall_time_s``
   the results carry (median of 3). The gap between the process time and ``wall_time_s`` is the
   interpreter start, the imports before the clock starts and the NetCDF write.
2. **Cold compile cache**: the same with an empty ``SVBI_CACHE_DIR`` (the C loop is compiled once).
3. **100 cars on 1000 spans** at dt = 1e-3 s through ``svbi run`` (1 s of simulated time; the
   set-up is what this measures, plus the loop's real-time factor with the whole train on the bridge
   part of the time). Peak memory from ``ru_maxrss`` of the child.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py

REPO = Path(__file__).resolve().parents[1]
PAPER = REPO / "examples" / "paper-2020.toml"
SVBI = Path(sys.executable).with_name("svbi")


def run(args: list[str], env: dict[str, str] | None = None) -> tuple[float, dict[str, float]]:
    """Wall time of one fresh ``svbi run`` process and the timing attributes of its results."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "r.nc"
        t0 = time.perf_counter()
        subprocess.run(
            [str(SVBI), "run", *args, "-o", str(out)],
            check=True,
            capture_output=True,
            env={**os.environ, **(env or {})},
        )
        wall = time.perf_counter() - t0
        with h5py.File(out, "r") as f:
            attrs = {
                k: float(f.attrs[k].ravel()[0]) if hasattr(f.attrs[k], "ravel") else float(f.attrs[k])
                for k in ("setup_time_s", "loop_time_s", "wall_time_s", "steps")
            }
    return wall, attrs


def line(label: str, wall: float, a: dict[str, float]) -> None:
    print(
        f"{label:<34}{wall:>9.2f}{a['setup_time_s']:>9.2f}{a['loop_time_s']:>9.2f}"
        f"{a['wall_time_s']:>9.2f}{wall / a['loop_time_s']:>14.2f}"
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one repeat, no 100 x 1000 case")
    quick = parser.parse_args().quick
    repeats = 1 if quick else 3
    print(f"{'case':<34}{'process':>9}{'set-up':>9}{'loop':>9}{'wall':>9}{'process/loop':>14}  (s)")
    run([str(PAPER)])  # warm the compile cache and the OS file cache
    samples = [run([str(PAPER)]) for _ in range(repeats)]
    k = sorted(range(repeats), key=lambda i: samples[i][0])[repeats // 2]
    line("paper, warm cache (median)", *samples[k])
    with tempfile.TemporaryDirectory() as cache:
        line("paper, cold compile cache", *run([str(PAPER)], {"SVBI_CACHE_DIR": cache}))
    if not quick:
        big = [
            str(PAPER),
            "--set", "train.cars=100",
            "--set", "bridge.spans=1000",
            "--set", "solver.time_step=1e-3",
            "--set", "solver.duration=1.0",
        ]  # fmt: skip
        before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
        wall, a = run(big)
        rss = max(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, before) / 1024**2
        line("100 cars x 1000 spans, dt 1e-3, 1 s", wall, a)
        per_step = a["loop_time_s"] / a["steps"]
        print(
            f"  100 x 1000: {per_step * 1e6:.0f} us/step, loop {1e-3 / per_step:.2f}x faster than real "
            f"time, peak memory {rss:.2f} GiB"
        )
    ratio = samples[k][0] / samples[k][1]["loop_time_s"]
    loop = statistics.median(s[1]["loop_time_s"] for s in samples)
    print(f"median process wall / loop time, paper scenario: {ratio:.2f} (loop {loop:.2f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
