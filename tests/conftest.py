"""Shared test fixtures: paths to the repository and to the read-only ../shared folder."""

from __future__ import annotations

import ctypes
import functools
import os
import re
from pathlib import Path
from typing import Any

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"

BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
_OPENBLAS_SETTERS = (
    "scipy_openblas_set_num_threads64_",
    "scipy_openblas_set_num_threads",
    "openblas_set_num_threads64_",
    "openblas_set_num_threads",
)


def _one_blas_thread() -> None:
    """The tests run NumPy's and SciPy's OpenBLAS on one thread (unless the environment says
    otherwise), as ``svbi`` itself does (runtime/cli/app.py, ``BLAS_THREADS``). The suite runs on two
    workers on two cores: a BLAS thread per core in each worker spins on the core of the other one,
    and an in-process run of small dense solves then took 20 times as long (measured 40-51 s instead
    of 2 s for the 600 steps of tests/methods/test_classic3d_step.py's crossing, one other process
    busy). pytest's plugins import NumPy before this file, so the variables, which a BLAS library
    reads when it loads, come too late for NumPy's: its thread count is set through OpenBLAS's own
    call; SciPy's library and the processes the tests start read the variables."""
    for name in BLAS_THREADS:
        os.environ.setdefault(name, "1")
    threads = int(os.environ["OPENBLAS_NUM_THREADS"])
    try:
        maps = Path("/proc/self/maps").read_text()
    except OSError:  # not Linux: the variables only
        return
    for path in sorted(set(re.findall(r"(/\S*openblas\S*\.so\S*)", maps))):
        library = ctypes.CDLL(path)
        for name in _OPENBLAS_SETTERS:
            setter = getattr(library, name, None)
            if setter is not None:
                setter(ctypes.c_int(threads))
                break


_one_blas_thread()


@pytest.fixture
def shared_dir() -> Path:
    """The ../shared folder beside the repository; tests that need it skip cleanly without it."""
    if not SHARED.is_dir():
        pytest.skip(f"../shared not found at {SHARED}: reference data (papers, records) unavailable")
    return SHARED


@functools.cache
def c_compiler_works() -> bool:
    """Whether a C compiler works here (the C backend falls back to NumPy without one; tests of the
    C loop skip). Where one works, the loop must build: a build error of svbi's own sources fails
    the tests that ask, instead of skipping every test of the C loop."""
    from svbi.runtime import toolchain as kernel_cache
    from svbi.runtime.backends.c import build as c_solver_build

    try:
        kernel_cache.load_library(
            {"probe.c": b"int svbi_probe(void) { return 1; }\n"}, "svbi_probe", flags=("-fPIC", "-shared")
        )
    except kernel_cache.CompilerError:
        return False
    c_solver_build.load_loop(c_solver_build.LoopSpec("moving-load", 0, 0))  # raises with the message
    return True


def export_and_run(tmp_path: Path, scenario: dict | None = None) -> tuple[Any, Any, str]:
    """`svbi export pioneer-2d DIR --solver` with ``scenario`` baked in (None: the built-in example),
    built with `make` and run with no Python (its CSV), and the same scenario through `svbi run`:
    ``(table, results, make's output)``."""
    import subprocess
    import warnings

    import numpy as np
    import tomli_w
    import xarray as xr
    from typer.testing import CliRunner

    from svbi.runtime.cli import app as cli
    from svbi.runtime.run import export as solver_export

    scenario_file = tmp_path / "exported.toml"
    scenario_file.write_text(tomli_w.dumps(scenario or solver_export.example_scenario("pioneer-2d")))
    cli._register()
    runner = CliRunner()
    folder = tmp_path / "solver"
    args = ["export", "pioneer-2d", str(folder), "--solver"]
    done = runner.invoke(cli.app, args + (["--scenario", str(scenario_file)] if scenario else []))
    assert done.exit_code == 0, done.output
    build = subprocess.run(["make", "-C", str(folder)], capture_output=True, text=True, check=False)
    assert build.returncode == 0, build.stdout + build.stderr
    csv = tmp_path / "out.csv"
    ran = subprocess.run(
        [str(folder / solver_export.PROGRAM), str(csv)], capture_output=True, text=True, check=False
    )
    assert ran.returncode == 0, ran.stderr
    results = tmp_path / "run.nc"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        done = runner.invoke(cli.app, ["run", str(scenario_file), "-o", str(results), "-q"])
    assert done.exit_code == 0, done.output
    return np.genfromtxt(csv, delimiter=",", names=True), xr.load_dataset(results), build.stdout
