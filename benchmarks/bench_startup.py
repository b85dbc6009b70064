"""End-to-end cost of ``svbi run`` as a user meets it: a fresh process, the README's command.

    .venv/bin/python benchmarks/bench_startup.py [--quick | --no-crossing] [--big-output-every N]

1. **Paper scenario** (``svbi run examples/paper-2020.toml``), a fresh process each time, warm
   compile cache: the process's wall time against the ``setup_time_s`` / ``loop_time_s`` /
   ``wall_time_s`` the results carry (3 runs; the table shows the run with the median process time,
   and the ratio process / loop is that run's own). The process time adds to ``wall_time_s`` the
   interpreter start, the imports before the clock starts, the NetCDF write and the exit. Target
   (issue 11): process <= 2 x loop.
2. **Cold compile cache**: the same once with an empty ``SVBI_CACHE_DIR`` (the C loop is compiled).
3. **100 cars on 1000 spans** at dt = 1e-3 s through ``svbi run``: the paper's cars and spans,
   a whole crossing of the 32 km viaduct (until the last axle leaves: 414 s simulated, 414,306
   steps), results every ``--big-output-every`` steps (default 100, i.e. every 0.1 s: the contact
   forces are kept at every step for the filter anyway). Targets: set-up <= 10 s, the whole process
   faster than real time. The scenario is the paper file with ``--set`` overrides (nothing written
   to the repository); ``--quick`` (one warm run) and ``--no-crossing`` skip it.

Peak memory is each child's maximum resident set size (``os.wait4``, what ``/usr/bin/time -v``
reports as "Maximum resident set size").
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

REPO = Path(__file__).resolve().parents[1]
PAPER = REPO / "examples" / "paper-2020.toml"
SVBI = Path(sys.executable).with_name("svbi")
BIG = ("train.cars=100", "bridge.spans=1000", "solver.time_step=1e-3")
USER_ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
"""The children's environment: this one, but writing bytecode as a default Python does. With
``PYTHONDONTWRITEBYTECODE`` set (some sandboxes and CI images set it), every process compiles
svbi's own modules from source again: about 0.05 s of each paper run."""


@dataclass
class Run:
    """One fresh ``svbi run`` process."""

    process_s: float
    setup_s: float
    loop_s: float
    wall_s: float
    steps: int
    time_step: float
    peak_gib: float
    file_gib: float

    @property
    def ratio(self) -> float:
        """Process wall time over loop time (the target of issue 11: <= 2)."""
        return self.process_s / self.loop_s

    @property
    def simulated_s(self) -> float:
        return self.steps * self.time_step


def run(args: list[str], env: dict[str, str] | None = None) -> Run:
    """Time one fresh ``svbi run ARGS -o tmp.nc -q`` process; read its timings from the results."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "r.nc"
        log = Path(tmp) / "log.txt"
        with log.open("w") as sink:
            t0 = time.perf_counter()
            child = subprocess.Popen(
                [str(SVBI), "run", *args, "-o", str(out), "-q"],
                stdout=sink,
                stderr=subprocess.STDOUT,
                env={**USER_ENV, **(env or {})},
            )
            _, status, usage = os.wait4(child.pid, 0)
            process = time.perf_counter() - t0
        child.returncode = os.waitstatus_to_exitcode(status)
        if child.returncode:
            raise RuntimeError(f"svbi run {' '.join(args)} failed:\n{log.read_text()}")
        with h5py.File(out, "r") as f:  # attributes may be stored as 1-element arrays (h5netcdf) or scalars
            a = {k: float(np.ravel(f.attrs[k])[0]) for k in ("setup_time_s", "loop_time_s", "wall_time_s")}
            steps, time_step = int(np.ravel(f.attrs["steps"])[0]), float(np.ravel(f.attrs["time_step"])[0])
        return Run(
            process_s=process,
            setup_s=a["setup_time_s"],
            loop_s=a["loop_time_s"],
            wall_s=a["wall_time_s"],
            steps=steps,
            time_step=time_step,
            peak_gib=usage.ru_maxrss / 1024**2,  # kB on Linux
            file_gib=out.stat().st_size / 1024**3,
        )


def line(label: str, r: Run) -> None:
    print(
        f"{label:<40}{r.process_s:>9.2f}{r.setup_s:>9.2f}{r.loop_s:>9.2f}{r.wall_s:>9.2f}"
        f"{r.ratio:>11.2f}{r.peak_gib:>9.2f}"
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one warm run, no 100 x 1000 crossing")
    parser.add_argument("--no-crossing", action="store_true", help="the paper runs only (3 warm, 1 cold)")
    parser.add_argument("--big-output-every", type=int, default=100, help="output_every of 100 x 1000")
    opts = parser.parse_args()
    repeats = 1 if opts.quick else 3
    # other jobs on the machine stretch the loop and the rest differently: say how busy it was
    print("load average (1, 5, 15 min) at the start: {:.1f} {:.1f} {:.1f}".format(*os.getloadavg()))
    if "PYTHONDONTWRITEBYTECODE" in os.environ:
        print("PYTHONDONTWRITEBYTECODE is set here; the runs below write bytecode, as by default")
    print(f"{'case':<40}{'process':>9}{'set-up':>9}{'loop':>9}{'wall':>9}{'proc/loop':>11}{'peak':>9}")
    print(f"{'':<40}{'s':>9}{'s':>9}{'s':>9}{'s':>9}{'':>11}{'GiB':>9}")
    run([str(PAPER)])  # warm the compile cache and the OS file cache
    samples = sorted((run([str(PAPER)]) for _ in range(repeats)), key=lambda r: r.process_s)
    median = samples[repeats // 2]
    line(f"paper, warm cache (median of {repeats})", median)
    with tempfile.TemporaryDirectory() as cache:
        cold = run([str(PAPER)], {"SVBI_CACHE_DIR": cache})
    line("paper, cold compile cache (once)", cold)
    print(
        f"paper: process / loop {median.ratio:.2f} (target <= 2), median process "
        f"{statistics.median(r.process_s for r in samples):.2f} s, median loop "
        f"{statistics.median(r.loop_s for r in samples):.2f} s; a cold cache adds "
        f"{cold.process_s - median.process_s:.1f} s once"
    )
    if not (opts.quick or opts.no_crossing):
        sets = [*BIG, f"solver.output_every={opts.big_output_every}"]
        big = run([str(PAPER), *[arg for s in sets for arg in ("--set", s)]])
        line("100 cars x 1000 spans, dt 1e-3, crossing", big)
        post = big.process_s - big.setup_s - big.loop_s
        print(
            f"100 x 1000: {big.simulated_s:.0f} s simulated in {big.process_s:.0f} s "
            f"({big.simulated_s / big.process_s:.2f}x faster than real time end to end, loop "
            f"{big.simulated_s / big.loop_s:.2f}x, {big.loop_s / big.steps * 1e6:.0f} us/step); "
            f"set-up {big.setup_s:.2f} s (target <= 10), before the clock and after the loop "
            f"{post:.1f} s; peak memory {big.peak_gib:.2f} GiB, results file {big.file_gib:.2f} GiB"
        )
    print("load average (1, 5, 15 min) at the end: {:.1f} {:.1f} {:.1f}".format(*os.getloadavg()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
