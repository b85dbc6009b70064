"""`svbi derive` and `svbi modes` from the command line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import sympy as sp
from typer.testing import CliRunner

from svbi.codegen.vehicle import derive_vehicle
from svbi.runtime.cli.app import _register, app

_register()
runner = CliRunner()


def test_derive_json_has_every_documented_key_and_parses_back() -> None:
    result = runner.invoke(app, ["derive", "pioneer-2d", "--format", "json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    for key in (
        "dofs",
        "mass_matrix",
        "damping_matrix",
        "stiffness_matrix",
        "contact_normal",
        "contact_tangential",
        "b_vectors",
        "constraint_masses",
    ):
        assert key in data
    model = derive_vehicle("pioneer-2d")
    assert data["dofs"] == [q.name for q in model.dofs]
    names = {s.name: s for s in model.stiffness_matrix.free_symbols}
    parsed = sp.Matrix([[sp.sympify(e, locals=names) for e in row] for row in data["stiffness_matrix"]])
    assert sp.simplify(parsed - model.stiffness_matrix) == sp.zeros(14, 14)
    assert len(data["b_vectors"]) == 14 + 4 and len(data["b_vectors"][0]) == 4


def test_derive_text_and_latex() -> None:
    for fmt in ("text", "latex"):
        result = runner.invoke(app, ["derive", "sprung-mass", "-f", fmt])
        assert result.exit_code == 0, result.output
        assert ("stiffness\\_matrix" if fmt == "latex" else "stiffness_matrix") in result.output


def test_modes_json_with_span_frequencies() -> None:
    result = runner.invoke(
        app,
        [
            "modes",
            "sprung-mass",
            "--json",
            "--set",
            "span_length=25",
            "--set",
            "youngs_modulus=2.87e9",
            "--set",
            "second_moment=2.9",
            "--set",
            "mass_per_length=2303",
        ],
    )
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    # Sprung mass on rigid track: sqrt(k / M).
    assert np.isclose(data["frequencies_hz"][0], np.sqrt(1.595e6 / 5750.0) / (2 * np.pi), rtol=1e-12)
    closed = (np.pi / 25) ** 2 * np.sqrt(2.87e9 * 2.9 / 2303) / (2 * np.pi)
    assert np.isclose(data["span_frequencies_hz"][0], closed, rtol=1e-3)


def test_bad_model_file_is_a_clear_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\n[parameters.m]\nvalue = 1.0\n[[bodies]]\nname = "b"\ndofs = ["z"]\n')
    result = runner.invoke(app, ["derive", str(bad)])
    assert result.exit_code == 2
    assert "bodies[0].mass" in result.output and "Traceback" not in result.output


def test_the_cli_runs_one_blas_thread_unless_the_user_says_otherwise():
    """The loop is in C and svbi's dense algebra is small: a multi-threaded BLAS only spins on the
    other cores (benchmarks/bench_sweep.py section 4). The CLI sets one thread before NumPy loads;
    a user's own setting wins."""
    import os
    import subprocess
    import sys

    code = (
        "import svbi.runtime.cli.app, numpy, os; "
        "print(os.environ['OPENBLAS_NUM_THREADS'], os.environ['OMP_NUM_THREADS'])"
    )
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["1", "1"]
    env["OPENBLAS_NUM_THREADS"] = "2"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["2", "1"]


def test_a_command_runs_without_cyclic_collection_but_a_sweep_turns_it_on(tmp_path):
    """`svbi` commands are short processes: no cyclic garbage collection (its full passes over the
    imported libraries cost about 5 % of a paper run). The sweep's client, which runs as long as the
    study, collects as usual."""
    import subprocess
    import sys

    def enabled_after(*args: str) -> str:
        code = (
            "import gc, sys\n"
            "from svbi.runtime.cli import app as cli\n"
            f"sys.argv = ['svbi', *{list(args)!r}]\n"
            "try:\n"
            "    cli.main()\n"
            "except SystemExit:\n"
            "    pass\n"
            "print('on' if gc.isenabled() else 'off')\n"
        )
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
        return done.stdout.split()[-1]

    assert enabled_after("--help") == "off"
    assert enabled_after("sweep", str(tmp_path / "missing.toml"), "-o", str(tmp_path / "out.nc")) == "on"
