"""Input files that are not regular files, or absurdly large, are refused before they are read.

``/dev/zero`` as a rail profile was read until memory ran out (24 GB), and a FIFO as the scenario
file blocked for ever. Every loader (scenario, study, topology, profile, record) goes through one
helper (``svbi.codegen.input_files``) that refuses a FIFO, a device, a folder, a symbolic-link
loop and a file above the size limit in one line, exit 2.

Each loader runs in a subprocess with a memory limit and a time limit: on the unfixed code the
FIFO hangs and ``/dev/zero`` runs out of memory, and neither may take the test run down with it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

SCENARIO = """\
[bridge]
spans = 1
span_length = 25.0
mass_per_length = 2303.0
youngs_modulus = 2.87e9
area = 1.0
second_moment = 2.9
elements_per_span = 4

[train]
vehicle = "{vehicle}"
speed_kmh = 100.0

[track]
irregularity = "{profile}"

[earthquake]
vertical = "{record}"

[solver]
time_step = 2.0e-3
duration = 0.1

[contact]
creep = false
"""

# runs inside the subprocess: each case through the CLI, one JSON line per case
DRIVER = """
import json, signal, sys
from typer.testing import CliRunner
from svbi.runtime.cli.app import _register, app

_register()

def alarm(signum, frame):
    raise TimeoutError("hung")

signal.signal(signal.SIGALRM, alarm)
for name, args in json.loads(sys.argv[1]):
    signal.alarm(20)
    try:
        result = CliRunner().invoke(app, args)
        code, output = result.exit_code, result.output
        if result.exception is not None and not isinstance(result.exception, SystemExit):
            output += f"\\nTraceback: {type(result.exception).__name__}: {result.exception}"
    except TimeoutError:
        code, output = None, "hung for 20 s"
    signal.alarm(0)
    print(json.dumps([name, code, output]), flush=True)
"""


def _special_files(tmp_path: Path, suffix: str, limit: int) -> dict[str, str]:
    """The hostile inputs: a device that never ends, a FIFO with no writer, a folder, a
    symbolic-link loop and a sparse file one byte above the size limit (no disk used)."""
    folder = tmp_path / f"special{suffix.replace('.', '_')}"
    folder.mkdir()
    fifo = folder / f"fifo{suffix}"
    os.mkfifo(fifo)
    directory = folder / f"folder{suffix}"
    directory.mkdir()
    loop = folder / f"loop{suffix}"
    loop.symlink_to(loop.name)
    big = folder / f"big{suffix}"
    with open(big, "wb") as f:
        f.truncate(limit + 1)
    return {
        "/dev/zero": "/dev/zero",
        "fifo": str(fifo),
        "folder": str(directory),
        "symlink loop": str(loop),
        "too large": str(big),
    }


def _run_cases(cases: list[tuple[str, list[str]]]) -> dict[str, tuple[int | None, str]]:
    def limits() -> None:
        import resource

        resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))  # /dev/zero must not eat the machine

    done = subprocess.run(
        [sys.executable, "-c", DRIVER, json.dumps(cases)],
        capture_output=True,
        text=True,
        timeout=300,
        preexec_fn=limits,
        check=False,
    )
    results = {}
    for line in done.stdout.splitlines():
        if line.startswith("["):
            name, code, output = json.loads(line)
            results[name] = (code, output)
    for name, _ in cases:  # a case that crashed the subprocess (out of memory) has no line
        results.setdefault(name, (None, f"no result: {done.stderr[-2000:]}"))
    return results


def _check(results: dict[str, tuple[int | None, str]], expected: dict[str, tuple[str, ...]]) -> None:
    failures = []
    for name, words in expected.items():
        code, output = results[name]
        lines = [line for line in output.splitlines() if line.strip()]
        ok = (
            code == 2
            and "Traceback" not in output
            and len([line for line in lines if line.startswith("error")]) == 1
            and all(w in output for w in words)
        )
        if not ok:
            failures.append(f"{name}: exit {code}: {output[-600:]}")
    assert not failures, "\n".join(failures)


MiB = 2**20
WHY = {  # what each message says about the file
    "/dev/zero": ("character device",),
    "fifo": ("FIFO",),
    "folder": ("folder",),
    "symlink loop": ("symbolic links",),
    "too large": ("limit",),
}


def _scenario(
    tmp_path: Path, name: str, vehicle: str = "sprung-mass", profile: str = "none", record: str = "none"
) -> str:
    path = tmp_path / name
    path.write_text(SCENARIO.format(vehicle=vehicle, profile=profile, record=record), encoding="utf-8")
    return str(path)


def test_special_files_as_the_scenario_file(tmp_path: Path) -> None:
    files = _special_files(tmp_path, ".toml", 16 * MiB)
    out = str(tmp_path / "out.nc")
    results = _run_cases([(kind, ["run", path, "-o", out]) for kind, path in files.items()])
    _check(results, {kind: (files[kind], *WHY[kind]) for kind in files})
    assert not (tmp_path / "out.nc").exists()


@pytest.mark.parametrize("key", ["profile", "record"])
def test_special_files_as_a_profile_or_a_record(tmp_path: Path, key: str) -> None:
    files = _special_files(tmp_path, ".txt", 256 * MiB)
    cases = []
    for kind, path in files.items():
        scenario = _scenario(
            tmp_path, f"{key}-{kind.replace('/', '_').replace(' ', '_')}.toml", **{key: path}
        )
        cases.append((kind, ["run", scenario, "-o", str(tmp_path / "out.nc")]))
    results = _run_cases(cases)
    name = "track.irregularity" if key == "profile" else "earthquake.vertical"
    # a folder or a FIFO is not an existing profile or record file: the scenario's own check says so
    _check(results, {kind: (name,) for kind in files})


def test_special_files_as_a_topology(tmp_path: Path) -> None:
    files = _special_files(tmp_path, ".toml", 16 * MiB)
    cases = [(f"derive {kind}", ["derive", path]) for kind, path in files.items()]
    for kind, path in files.items():
        scenario = _scenario(
            tmp_path, f"vehicle-{kind.replace('/', '_').replace(' ', '_')}.toml", vehicle=path
        )
        cases.append((f"run {kind}", ["run", scenario, "-o", str(tmp_path / "out.nc")]))
    results = _run_cases(cases)
    _check(results, {name: () for name, _ in cases})


def test_special_files_as_the_study_file(tmp_path: Path) -> None:
    files = _special_files(tmp_path, ".toml", 16 * MiB)
    store = str(tmp_path / "store.nc")
    results = _run_cases([(kind, ["sweep", path, "-o", store, "-q"]) for kind, path in files.items()])
    _check(results, {kind: (files[kind], *WHY[kind]) for kind in files})
