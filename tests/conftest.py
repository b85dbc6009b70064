"""Shared test fixtures: paths to the repository and to the read-only ../shared folder."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"


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
