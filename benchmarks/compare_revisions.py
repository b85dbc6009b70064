"""The C loop's all-on step of this checkout against another revision, measured in the same run.

    .venv/bin/python benchmarks/compare_revisions.py REV [--rounds 7] [--steps 2000]

A change that must not slow the loop is judged against the revision before it on the same machine,
at the same time: the two are measured in alternation (A B A B ...), each round in a fresh process,
so that a load that comes and goes on the machine falls on both alike. The other revision is
checked out into a temporary ``git worktree`` and imported through a staged ``svbi`` package (its
folders linked under ``svbi/``, first on the path), with this checkout's virtual environment: no
second installation. Each process times ``bench_solver.per_step_us`` of its own revision on the
paper's case with all 40 wheels on the bridge (10 cars, 10 spans x 16 elements), for
localized-dynamic and coupled-dynamic on the C backend, with the thread's CPU clock.

Prints the medians over the rounds and the ratio this / REV per method.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
FOLDERS = ("codegen", "runtime", "templates", "generated", "examples")
METHODS = ("localized-dynamic", "coupled-dynamic")

PROBE = """
import json, sys, warnings
sys.path.insert(1, sys.argv[1])
import bench_solver as b
steps = int(sys.argv[2])
out = {}
for method in sys.argv[3:]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out[method] = b.per_step_us(b.on_bridge(10, 10, 16, method, "c"), "c", method, steps)
print(json.dumps(out))
"""


def stage(repo: Path, where: Path) -> dict[str, str]:
    """An environment that imports ``svbi`` from ``repo``'s folders (linked under ``where/svbi``)."""
    package = where / "svbi"
    package.mkdir(parents=True)
    (package / "__init__.py").write_bytes((repo / "svbi" / "__init__.py").read_bytes())
    for name in FOLDERS:
        if (repo / name).is_dir():
            (package / name).symlink_to(repo / name, target_is_directory=True)
    return dict(os.environ, PYTHONPATH=os.pathsep.join([str(where), os.environ.get("PYTHONPATH", "")]))


def measure(repo: Path, env: dict[str, str], steps: int) -> dict[str, float]:
    # run from the stage (first on the path), not from the checkout, whose own svbi/ would shadow it
    done = subprocess.run(
        [sys.executable, "-c", PROBE, str(repo / "benchmarks"), str(steps), *METHODS],
        cwd=env["PYTHONPATH"].split(os.pathsep)[0],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode:
        raise SystemExit(f"measurement in {repo} failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("rev", help="the revision to compare against (a commit, tag or branch)")
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--steps", type=int, default=2000)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="svbi-compare-") as tmp:
        other = Path(tmp) / "other"
        subprocess.run(
            ["git", "-C", str(HERE), "worktree", "add", "--detach", "-q", str(other), args.rev], check=True
        )
        try:
            envs = {"this": stage(HERE, Path(tmp) / "this"), args.rev: stage(other, Path(tmp) / "rev")}
            repos = {"this": HERE, args.rev: other}
            times: dict[str, dict[str, list[float]]] = {k: {m: [] for m in METHODS} for k in repos}
            for r in range(args.rounds):
                order = list(repos) if r % 2 == 0 else list(reversed(repos))
                for key in order:
                    for method, us in measure(repos[key], envs[key], args.steps).items():
                        times[key][method].append(us)
                print(f"round {r + 1}/{args.rounds} done", file=sys.stderr, flush=True)
        finally:
            subprocess.run(["git", "-C", str(HERE), "worktree", "remove", "--force", str(other)], check=False)
    print(f"C loop, all 40 wheels on the bridge, us/step (median of {args.rounds} alternating rounds)")
    print(f"{'method':<20}{'this':>10}{args.rev[:10]:>12}{'ratio':>8}")
    for method in METHODS:
        a, b = statistics.median(times["this"][method]), statistics.median(times[args.rev][method])
        print(f"{method:<20}{a:>10.2f}{b:>12.2f}{a / b:>8.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
