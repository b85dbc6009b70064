"""Run every benchmark script in this folder (``make bench``) and print their tables.

Each ``bench_*.py`` is a stand-alone script that prints a table of medians and of ratios measured in
the same run. Pass names to run a subset: ``python benchmarks/run.py codegen methods``.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path


def main(argv: list[str]) -> int:
    here = Path(__file__).resolve().parent
    scripts = sorted(here.glob("bench_*.py"))
    if argv:
        scripts = [s for s in scripts if any(s.stem == f"bench_{a}" for a in argv)]
    failed = []
    for script in scripts:
        print(f"\n=== {script.stem} ===", flush=True)
        # One process per script: each measures from a clean interpreter, and a script that exits
        # does not end the others.
        if subprocess.run([sys.executable, str(script)], check=False).returncode:
            failed.append(script.stem)
    if failed:
        print(f"\nfailed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
