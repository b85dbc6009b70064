"""Honest timings (docs/design.md section 7) and deferred heavy imports.

* results carry ``setup_time_s`` (everything before the first step), ``loop_time_s`` (the time loop)
  and ``wall_time_s`` (all of it): positive, and set-up plus loop within the wall time;
* ``svbi run`` prints the three on one line, the same numbers as in the file;
* the command line (all its commands registered) and the run path up to the first step import
  neither matplotlib, scipy.signal, scipy.interpolate (0.08 s: the rail and ground tables are
  ``excitation.piecewise`` tables), dask, xarray, SymPy nor CasADi (checked in a fresh interpreter:
  ``sys.modules``); a whole run never imports matplotlib, SymPy or CasADi (xarray loads dask.array
  when it builds the results, if dask is installed);
* a compiled (C) run imports the results' modules (scipy.signal, xarray) in a background thread
  started at the loop, so that they overlap it, and the C run path imports none of them before.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
import xarray as xr
from typer.testing import CliRunner

import svbi

SCENARIO = {
    "bridge": dict(
        spans=1,
        span_length=20.0,
        mass_per_length=1.0e4,
        youngs_modulus=3.0e10,
        area=5.0,
        second_moment=2.0,
        damping_ratio=0.02,
        elements_per_span=4,
    ),
    "train": dict(vehicle="moving-load", speed=20.0, start_position=-1.0),
    "earthquake": dict(vertical="synthetic", arrival=0.0),
    "track": dict(irregularity="german-low"),
    "solver": dict(backend="numpy", time_step=1e-3, duration=0.05),
}

TOML = """
[bridge]
spans = 1
span_length = 20.0
mass_per_length = 1.0e4
youngs_modulus = 3.0e10
area = 5.0
second_moment = 2.0
damping_ratio = 0.02
elements_per_span = 4

[train]
vehicle = "moving-load"
speed = 20.0
start_position = -1.0

[solver]
backend = "numpy"
time_step = 1.0e-3
duration = 0.05
"""

METHODS = ("localized-dynamic", "coupled-dynamic", "coupled-classic")
HEAVY = (
    "matplotlib",
    "scipy.signal",
    "scipy.interpolate",
    "scipy.fft",
    "scipy.special",
    "dask",
    "xarray",
    "sympy",
    "casadi",
)


def test_results_carry_setup_loop_and_wall_time():
    ds = svbi.simulate(SCENARIO)
    setup, loop, wall = (float(ds.attrs[k]) for k in ("setup_time_s", "loop_time_s", "wall_time_s"))
    assert setup > 0 and loop > 0 and wall > 0
    assert setup + loop <= wall


def test_svbi_run_prints_the_timings(tmp_path: Path):
    from svbi.runtime.cli.app import _register, app

    _register()
    scenario = tmp_path / "s.toml"
    scenario.write_text(TOML)
    out = tmp_path / "r.nc"
    result = CliRunner().invoke(app, ["run", str(scenario), "-o", str(out)])
    assert result.exit_code == 0, result.output
    line = re.search(r"set-up ([0-9.]+) s, loop ([0-9.]+) s, total ([0-9.]+) s", result.output)
    assert line is not None, result.output
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        for value, key in zip(line.groups(), ("setup_time_s", "loop_time_s", "wall_time_s"), strict=True):
            assert abs(float(value) - ds.attrs[key]) <= 0.005 + 1e-9
        assert ds.attrs["setup_time_s"] + ds.attrs["loop_time_s"] <= ds.attrs["wall_time_s"]


def test_console_script_ends_quickly_and_keeps_exit_status(tmp_path: Path, monkeypatch):
    """``svbi`` (``cli.main``): `svbi run` ends without the interpreter's shutdown (``os._exit``
    once the results are written; atexit handlers still run) with the command's exit status and a
    complete file, 2 for an invalid scenario; the other commands freeze the garbage collector as
    the process ends, so that shutdown skips the cyclic collections over the libraries' objects."""
    import gc

    from svbi.runtime.cli import app as cli

    scenario = tmp_path / "s.toml"
    scenario.write_text(TOML)
    out = tmp_path / "r.nc"

    def svbi(*args: str) -> subprocess.CompletedProcess:
        probe = (
            "import atexit, sys\nfrom svbi.runtime.cli.app import main\n"
            "atexit.register(lambda: print('atexit ran'))\n"
            f"sys.argv = {['svbi', *args]!r}\nmain()\n"
        )
        return subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=False)

    done = svbi("run", str(scenario), "-o", str(out), "-q")
    assert done.returncode == 0 and "atexit ran" in done.stdout, done.stdout + done.stderr
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds.attrs["complete"] == 1 and ds.attrs["steps"] == 50
        assert ds.sizes["time"] == 50 // ds.attrs["output_every"] + 1
    bad = tmp_path / "bad.toml"
    bad.write_text(TOML.replace("duration = 0.05", "duration = -1.0"))
    failed = svbi("run", str(bad), "-o", str(tmp_path / "x.nc"))
    assert failed.returncode == 2 and "duration" in failed.stderr, failed.stderr
    monkeypatch.setattr(sys, "argv", ["svbi", "metrics", str(out)])
    try:
        with pytest.raises(SystemExit) as metrics:
            cli.main()
        assert gc.get_freeze_count() > 0
    finally:
        gc.unfreeze()
    assert metrics.value.code in (0, None)


def _fresh(code: str) -> dict[str, bool]:
    """Run ``code`` in a fresh interpreter; which HEAVY modules it left in ``sys.modules``."""
    probe = f"import json, sys\n{code}\nprint(json.dumps({{m: m in sys.modules for m in {HEAVY!r}}}))"
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_cli_and_run_path_defer_heavy_imports():
    before_loop = _fresh(
        "import svbi.runtime.cli.app as cli\n"
        "cli._register()\n"
        "from svbi.runtime.cli import run as cli_run\n"
        "from svbi.runtime.run import results\n"
        "from svbi.runtime.methods.initial import initial_state\n"
        "from svbi.runtime.run.simulate import build_model, stepper_class, validate_scenario\n"
        f"model = build_model(validate_scenario({SCENARIO!r}))\n"
        "_, cls = stepper_class('numpy', model.settings.method)\n"
        "cls(model, initial_state(model))\n"
        "results.Recorder(model)\n"
    )
    assert not any(before_loop.values()), before_loop
    # xarray imports dask.array itself when it builds a Dataset (duck-array detection) if dask is
    # installed (the optional [sweep] extra), so only matplotlib and the symbolic tools are checked
    # over a whole run
    whole = _fresh(f"import svbi\nsvbi.simulate({SCENARIO!r})\n")
    assert not (whole["matplotlib"] or whole["sympy"] or whole["casadi"]), whole


def test_every_command_is_registered_by_the_module_the_cli_names():
    """`svbi COMMAND` registers only COMMAND's module (cli.COMMAND_MODULES): every module's commands
    are the ones the table gives it, and the table has every command."""
    import importlib

    import typer

    from svbi.runtime.cli import app as cli

    for module in set(cli.COMMAND_MODULES.values()):
        group = typer.Typer()
        importlib.import_module(f"svbi.runtime.cli.{module}").register(group)
        names = {c.name for c in group.registered_commands}
        assert names == {k for k, v in cli.COMMAND_MODULES.items() if v == module}, module
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys; from svbi.runtime.cli.app import main; sys.argv = ['svbi', 'run', '--help']; main()",
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0 and "Run a scenario" in done.stdout, done.stdout + done.stderr


def test_a_run_shorter_than_the_bar_delay_imports_no_progress_bar():
    """The progress bar (tqdm) shows after 1 s of loop; a shorter run does not import tqdm."""
    probe = (
        f"import sys\nimport svbi\nsvbi.simulate({SCENARIO!r}, progress=True)\nprint('tqdm' in sys.modules)"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert done.stdout.strip().splitlines()[-1] == "False", done.stdout + done.stderr


def test_compiled_run_imports_the_results_modules_during_the_loop():
    """A C-backend run imports xarray in the background thread that it starts at the loop
    (``results.ImportAhead``; the C loop releases the GIL), and not before the loop: the run-path
    check above holds for the C stepper too. With the force filter designed once on this machine
    (``zero_phase.design``, cached) and compiled, the run does not import scipy.signal at all.
    Recorded in a fresh interpreter by a meta-path hook that notes which thread first asked for
    each module."""
    from svbi.runtime import toolchain as kernel_cache
    from svbi.runtime.backends.c import build as c_solver_build
    from svbi.runtime.run import force_filter as zero_phase
    from svbi.runtime.run.results import FILTER_ORDER
    from svbi.runtime.run.simulate import build_model, validate_scenario

    try:
        c_solver_build.load_loop(c_solver_build.LoopSpec("moving-load", 0, 0))
    except kernel_cache.CompilerError:
        pytest.skip("no working C compiler: no compiled loop to overlap")
    c_run = {**SCENARIO, "solver": {**SCENARIO["solver"], "backend": "c"}}
    model = build_model(validate_scenario(c_run))
    zero_phase.design(FILTER_ORDER, model.settings.force_filter_hz, 1.0 / model.dt)  # as a first run
    assert zero_phase.compiled()
    before_loop = _fresh(
        "from svbi.runtime.methods.initial import initial_state\n"
        "from svbi.runtime.run.results import Recorder\n"
        "from svbi.runtime.run.simulate import build_model, stepper_class, validate_scenario\n"
        f"model = build_model(validate_scenario({c_run!r}))\n"
        "_, cls = stepper_class('c', model.settings.method)\n"
        "cls(model, initial_state(model))\n"
        "Recorder(model)\n"
    )
    assert not any(before_loop.values()), before_loop
    probe = (
        "import json, sys, threading\n"
        "first = {}\n"
        "class Probe:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        first.setdefault(name, threading.current_thread().name)\n"
        "sys.meta_path.insert(0, Probe())\n"
        "import svbi\n"
        f"ds = svbi.simulate({c_run!r})\n"
        "assert ds.attrs['backend'] == 'c', ds.attrs['backend']\n"
        "print(json.dumps({m: first.get(m) for m in ('scipy.signal', 'xarray')}))\n"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    threads = json.loads(done.stdout.strip().splitlines()[-1])
    assert threads == {"scipy.signal": None, "xarray": "svbi-import-ahead"}, threads


def test_demo_summary_compares_methods_by_loop_time():
    from svbi.runtime.plots.results import summary_text

    runs = [svbi.simulate({**SCENARIO, "solver": {**SCENARIO["solver"], "method": m}}) for m in METHODS]
    lines = {line.split("  ")[0].strip(): line.split()[-3:] for line in summary_text(runs).splitlines()}
    row = "loop time / localized-dynamic"
    assert row in lines and "set-up time (s)" in lines and "wall time (s)" in lines
    loops = [r.attrs["loop_time_s"] for r in runs]
    assert [float(x) for x in lines[row]] == pytest.approx([x / loops[0] for x in loops], rel=1e-5)
