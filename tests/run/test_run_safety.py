"""`svbi run` loses nothing (issue 15, data loss and resources).

* the output path is checked before any computation: not empty, a ``.nc`` file name, not a folder,
  not under a regular file, in a writable folder, and not one of the run's own inputs (same file by
  resolved path or inode);
* incomplete results (divergence, Ctrl-C, SIGTERM) never replace a results file: they go to
  ``<stem>.incomplete.nc`` and the run says so; SIGINT / SIGTERM during the loop (NumPy backend,
  and the C backend's chunked loop) stop cleanly with exit 130 / 143 and one line;
* no temporary file survives a signal or a failed write; a full disk (``ENOSPC`` from the writer,
  and a real ``RLIMIT_FSIZE`` limit in a subprocess) gives one line and keeps the previous file;
* a compile killed part-way leaves a ``.build-*`` folder that the next build removes;
* a run whose arrays would not fit in memory is refused before it starts, naming the keys that
  drive the size; the estimate of the stored arrays equals what the run allocates.
"""

from __future__ import annotations

import contextlib
import errno
import os
import resource
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

GOOD = """\
title = "one span"

[bridge]
spans = 1
span_length = 25.0
mass_per_length = 2303.0
youngs_modulus = 2.87e9
area = 1.0
second_moment = 2.9
elements_per_span = 4

[train]
vehicle = "sprung-mass"
speed_kmh = 100.0

[solver]
time_step = 2.0e-3
output_every = 5

[contact]
creep = false  # the sprung mass has no wheel spin: creep would only warn
"""

PREVIOUS = b"previous results: must survive\n"


def _app():
    from svbi.runtime.cli.app import _register, app

    _register()
    return app


def _scenario(tmp_path: Path, text: str = GOOD, name: str = "scenario.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def _invoke(args: list[str]):
    return CliRunner().invoke(_app(), ["run", *args])


def _error_line(output: str) -> str:
    lines = [line for line in output.splitlines() if line.strip()]
    assert len(lines) == 1, output  # one line, no traceback
    assert lines[0].startswith("error: "), output
    return lines[0]


def _debris(folder: Path) -> list[str]:
    """Hidden temporary files that an atomic write may leave behind."""
    return sorted(p.name for p in folder.iterdir() if p.name.startswith(".") and p.name.endswith(".tmp"))


@pytest.fixture
def no_simulation(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail the test if the run reaches the simulation (the check must come first). The command's
    module is imported first and patched where it looks the function up: imported for the first time
    under the patch, it would keep the refusing function for the tests that come after."""
    import svbi.runtime.cli.run as cli_run
    import svbi.runtime.run.simulate as sim

    def refuse(*args, **kwargs):
        raise AssertionError("simulate() was called: the output path was not checked first")

    monkeypatch.setattr(sim, "simulate", refuse)
    monkeypatch.setattr(cli_run, "simulate", refuse)


# --------------------------------------------------------------------------------------------------
# 1. the output path, before any computation


def test_output_onto_the_scenario_file_is_refused_and_the_file_kept(tmp_path: Path, no_simulation) -> None:
    scenario = _scenario(tmp_path)
    before = scenario.read_bytes()
    result = _invoke([str(scenario), "-o", str(scenario)])
    assert result.exit_code == 2
    line = _error_line(result.output)
    assert ".nc" in line
    assert scenario.read_bytes() == before


@pytest.mark.parametrize("how", ["symlink", "hardlink"])
def test_output_that_is_the_scenario_under_another_name_is_refused(
    tmp_path: Path, no_simulation, how: str
) -> None:
    scenario = _scenario(tmp_path)
    before = scenario.read_bytes()
    alias = tmp_path / "alias.nc"
    if how == "symlink":
        alias.symlink_to(scenario)
    else:
        os.link(scenario, alias)
    result = _invoke([str(scenario), "-o", str(alias)])
    assert result.exit_code == 2
    line = _error_line(result.output)
    assert "scenario" in line and "input" in line
    assert scenario.read_bytes() == before


def test_output_onto_the_vehicle_topology_is_refused(tmp_path: Path, no_simulation) -> None:
    import svbi.codegen.vehicles as vehicles

    text = (Path(vehicles.__file__).parent / "sprung-mass.toml").read_text(encoding="utf-8")
    car = tmp_path / "car.nc"  # a topology file may be called anything
    car.write_text(text, encoding="utf-8")
    scenario = _scenario(tmp_path, GOOD.replace('vehicle = "sprung-mass"', 'vehicle = "car.nc"'))
    result = _invoke([str(scenario), "-o", str(car)])
    assert result.exit_code == 2
    line = _error_line(result.output)
    assert "train.vehicle" in line
    assert car.read_text(encoding="utf-8") == text


@pytest.mark.parametrize(
    ("target", "words"),
    [
        ("", "empty"),
        ("r.csv", ".nc"),
        ("results", ".nc"),
        ("folder.nc", "folder"),
        ("scenario.toml/r.nc", "not a folder"),
    ],
)
def test_bad_output_paths_are_refused_before_the_run(
    tmp_path: Path, no_simulation, monkeypatch: pytest.MonkeyPatch, target: str, words: str
) -> None:
    monkeypatch.chdir(tmp_path)
    scenario = _scenario(tmp_path)
    (tmp_path / "folder.nc").mkdir()
    result = _invoke([str(scenario), "-o", target])
    assert result.exit_code == 2
    assert words in _error_line(result.output)


def test_output_in_an_unwritable_folder_is_refused_before_the_run(tmp_path: Path, no_simulation) -> None:
    scenario = _scenario(tmp_path)
    if os.getuid() == 0:  # root writes through permission bits; /sys refuses new files even to root
        folder = Path("/sys")
        if not folder.is_dir():
            pytest.skip("no /sys")
    else:
        folder = tmp_path / "locked"
        folder.mkdir()
        folder.chmod(0o500)
    result = _invoke([str(scenario), "-o", str(folder / "r.nc")])
    assert result.exit_code == 2
    line = _error_line(result.output)
    assert "writ" in line and str(folder) in line


# --------------------------------------------------------------------------------------------------
# 2. incomplete results never replace a file


class _Exploding:
    """A stepper that goes unstable after a few steps: exercises the divergence guard."""

    name = "localized-dynamic"

    def __init__(self, model, state):
        from svbi.runtime.methods.localized import LocalizedDynamic

        self.inner = LocalizedDynamic(model, state)
        self.contacts = None

    def step(self, n):
        st = self.inner.step(n)
        self.contacts = self.inner.contacts
        if n >= 12:
            st.P = st.P * np.nan
        return st


def test_a_diverged_run_keeps_the_previous_results_and_writes_incomplete_beside(tmp_path: Path) -> None:
    import svbi.runtime.run.simulate as sim
    from svbi.runtime.backends import registry

    sim.register_backend("casadi", {"localized-dynamic": _Exploding})
    try:
        scenario = _scenario(tmp_path)
        out = tmp_path / "run.nc"
        out.write_bytes(PREVIOUS)
        result = _invoke(
            [
                str(scenario),
                "-o",
                str(out),
                "-q",
                "--set",
                "solver.backend=casadi",
                "--set",
                "solver.output_every=1",
            ]
        )
    finally:
        registry.unregister_backend("casadi")
    assert result.exit_code == 3
    assert out.read_bytes() == PREVIOUS
    partial = tmp_path / "run.incomplete.nc"
    assert str(partial) in result.output and "diverged" in result.output
    with xr.open_dataset(partial, engine="h5netcdf") as ds:
        assert ds.attrs["complete"] == 0 and ds.sizes["time"] == 13
    assert _debris(tmp_path) == []


def test_a_full_disk_during_the_write_gives_one_line_and_keeps_the_previous_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import svbi.runtime.run.results as results

    real = results.write_atomic

    def full(path, write):
        def failing(tmp: Path) -> None:
            tmp.write_bytes(b"half a file")
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        return real(path, failing)

    monkeypatch.setattr(results, "write_atomic", full)
    scenario = _scenario(tmp_path)
    out = tmp_path / "run.nc"
    out.write_bytes(PREVIOUS)
    result = _invoke([str(scenario), "-o", str(out), "-q", "--set", "solver.duration=0.1"])
    assert result.exit_code == 4
    line = _error_line(result.output)
    assert "No space left on device" in line and str(out) in line and "kept" in line
    assert out.read_bytes() == PREVIOUS
    assert _debris(tmp_path) == []


def _svbi_command() -> list[str]:
    return [sys.executable, "-c", "from svbi.runtime.cli.app import main; main()"]


def test_a_file_size_limit_during_the_write_gives_one_line_not_a_crash(tmp_path: Path) -> None:
    """A real short write (``RLIMIT_FSIZE``, the closest to a full disk without root): h5py used to
    segfault here."""
    scenario = _scenario(tmp_path)
    out = tmp_path / "run.nc"
    out.write_bytes(PREVIOUS)
    limit = 20_000

    def limited() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a short write returns EFBIG instead of a kill
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    done = subprocess.run(
        [*_svbi_command(), "run", str(scenario), "-o", str(out), "-q", "--set", "solver.duration=2"],
        capture_output=True,
        text=True,
        timeout=300,
        preexec_fn=limited,
        check=False,
    )
    assert done.returncode == 4, done.stderr[-3000:]
    line = _error_line(done.stdout + done.stderr)
    assert "File too large" in line and "kept" in line
    assert out.read_bytes() == PREVIOUS
    assert _debris(tmp_path) == []


# --------------------------------------------------------------------------------------------------
# signals


def _start(tmp_path: Path, backend: str, out: Path) -> subprocess.Popen:
    # long enough to be interrupted in its loop: 1e7 steps of the sprung mass (the C loop runs 2e6
    # in about 1 s, so a shorter run can end before the signal arrives)
    scenario = _scenario(tmp_path)
    args = [
        "run",
        str(scenario),
        "-o",
        str(out),
        "--set",
        f"solver.backend={backend}",
        "--set",
        "solver.time_step=1e-5",
        "--set",
        "solver.duration=100.0",
        "--set",
        "solver.output_every=100",
        "--set",
        "train.speed_kmh=1.0",
    ]

    def default_signals() -> None:  # a background test runner may hand SIGINT down as ignored
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)

    return subprocess.Popen(
        [*_svbi_command(), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        preexec_fn=default_signals,
    )


class _Stderr:
    """Collects a child's stderr in a thread (tqdm redraws with carriage returns, not lines)."""

    def __init__(self, proc: subprocess.Popen) -> None:
        import threading

        self.text = ""
        self.thread = threading.Thread(target=self._read, args=(proc.stderr,), daemon=True)
        self.thread.start()

    def _read(self, stream) -> None:
        for chunk in iter(lambda: os.read(stream.fileno(), 4096), b""):
            self.text += chunk.decode(errors="replace")


def _wait_for_loop(proc: subprocess.Popen, err: _Stderr, timeout: float = 240.0) -> None:
    """Until the progress bar shows (tqdm draws it after 1 s of loop)."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if "step" in err.text and "%" in err.text:
            return
        if proc.poll() is not None:
            raise AssertionError(f"run ended before its loop was interrupted: {err.text[-2000:]}")
        time.sleep(0.1)
    proc.kill()
    raise AssertionError(f"no progress within {timeout} s: {err.text[-2000:]}")


@pytest.mark.parametrize(
    ("backend", "signum", "code", "name"),
    [
        ("numpy", signal.SIGINT, 130, "SIGINT"),
        ("numpy", signal.SIGTERM, 143, "SIGTERM"),
        ("c", signal.SIGINT, 130, "SIGINT"),
        ("c", signal.SIGTERM, 143, "SIGTERM"),
    ],
)
def test_a_signal_during_the_loop_saves_what_was_computed_as_incomplete(
    tmp_path: Path, backend: str, signum: int, code: int, name: str
) -> None:
    out = tmp_path / "run.nc"
    out.write_bytes(PREVIOUS)
    proc = _start(tmp_path, backend, out)
    err = _Stderr(proc)
    try:
        _wait_for_loop(proc, err)
        proc.send_signal(signum)
        proc.wait(timeout=120)
        err.thread.join(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    stderr = err.text
    assert proc.returncode == code, stderr[-3000:]
    assert "Traceback" not in stderr
    messages = [line for line in stderr.replace("\r", "\n").splitlines() if line.startswith("error")]
    assert len(messages) == 1, stderr[-3000:]
    partial = tmp_path / "run.incomplete.nc"
    assert name in messages[0] and str(partial) in messages[0]
    assert out.read_bytes() == PREVIOUS
    assert _debris(tmp_path) == []
    with xr.open_dataset(partial, engine="h5netcdf") as ds:
        assert ds.attrs["complete"] == 0 and name in ds.attrs["incomplete"]
        t = ds.time.values
        assert t.size > 1 and t[-1] < 100.0  # the loop had begun, and did not finish
        np.testing.assert_allclose(np.diff(t), 100 * 1e-5, rtol=1e-9)
        assert np.isfinite(ds.contact_force).all() and np.isfinite(ds.contact_force_filtered).all()
        assert ds.sizes["time"] == ds.contact_force_filtered.sizes["time"]


def test_sigterm_during_an_atomic_write_leaves_no_temporary_file(tmp_path: Path) -> None:
    """The write is slow (it sleeps inside); SIGTERM arrives while the temporary file exists. It is
    acted on once the write is done, before the rename (``run.atomic``): the temporary file is
    removed and the previous file kept."""
    target = tmp_path / "r.nc"
    target.write_bytes(PREVIOUS)
    code = textwrap.dedent(
        f"""
        import time
        from pathlib import Path
        from svbi.runtime.run.atomic import write_atomic
        from svbi.runtime.run.output import signals_interrupt

        def slow(tmp: Path) -> None:
            tmp.write_bytes(b"partial")
            print("writing", flush=True)
            time.sleep(3)

        with signals_interrupt():
            write_atomic({str(target)!r}, slow)
        """
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout.readline().strip() == "writing"
        assert len(_debris(tmp_path)) == 1  # the temporary file is there now
        proc.send_signal(signal.SIGTERM)
        proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode != 0  # the RunInterrupted of SIGTERM, raised before the rename
    assert _debris(tmp_path) == []
    assert target.read_bytes() == PREVIOUS


# --------------------------------------------------------------------------------------------------
# stale build folders of the kernel cache


SLOW_CC = """\
import os, sys, time
if "--version" in sys.argv:
    print("slow-cc 1.0")
    sys.exit(0)
with open(os.environ["SLOW_CC_MARK"] + ".tmp", "w") as f:  # the compile has started: its pid
    f.write(str(os.getpid()))
os.replace(os.environ["SLOW_CC_MARK"] + ".tmp", os.environ["SLOW_CC_MARK"])
time.sleep(120)
"""


def test_a_compile_killed_part_way_leaves_no_build_folder_for_good(tmp_path: Path) -> None:
    cache = tmp_path / "cache"
    cache.mkdir()
    cc = tmp_path / "slowcc.py"
    cc.write_text(SLOW_CC, encoding="utf-8")
    code = textwrap.dedent(
        f"""
        from svbi.runtime import toolchain as kernel_cache
        source = {{"a.c": b"int f(void) {{ return 1; }}\\n"}}
        kernel_cache.build_library(source, "probe", cache_dir={str(cache)!r})
        """
    )
    mark = tmp_path / "compiling"
    env = dict(os.environ, CC=f"{sys.executable} {cc}", SLOW_CC_MARK=str(mark))
    proc = subprocess.Popen([sys.executable, "-c", code], env=env)
    try:
        end = time.monotonic() + 120
        while not mark.exists() and time.monotonic() < end and proc.poll() is None:
            time.sleep(0.05)
        assert mark.exists()
        proc.kill()  # SIGKILL: no finally clause runs
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
        if mark.exists():  # the orphaned compiler
            with contextlib.suppress(ProcessLookupError):
                os.kill(int(mark.read_text()), signal.SIGKILL)
    stale = [p for p in cache.iterdir() if p.name.startswith(".build-")]
    assert len(stale) == 1  # what the killed compile left

    # the next build in the same cache, with a working compiler, removes it
    from svbi.runtime import toolchain as kernel_cache

    path = kernel_cache.build_library({"a.c": b"int f(void) { return 1; }\n"}, "probe", cache_dir=cache)
    assert path.is_file()
    assert not [p for p in cache.iterdir() if p.name.startswith(".build-")]


def test_a_live_build_folder_is_left_alone(tmp_path: Path) -> None:
    """A build of a running process (this one) is not stale, however the sweep is triggered."""
    from svbi.runtime import toolchain as kernel_cache

    live = kernel_cache.new_build_folder(tmp_path, "0123456789ab")
    kernel_cache.remove_stale_builds(tmp_path)
    assert live.is_dir()
    old = kernel_cache.new_build_folder(tmp_path, "ba9876543210")
    past = time.time() - kernel_cache.STALE_BUILD_S - 60
    os.utime(old, (past, past))
    kernel_cache.remove_stale_builds(tmp_path)
    assert live.is_dir() and not old.exists()  # too old to be a build in progress, whoever owns it


# --------------------------------------------------------------------------------------------------
# 3. resources


def test_a_run_too_large_for_memory_is_refused_with_its_keys(tmp_path: Path) -> None:
    scenario = _scenario(tmp_path)
    out = tmp_path / "run.nc"
    started = time.perf_counter()
    # within the step limit (2e7 steps of one run), beyond any machine's memory: ~35 GB of stored rows
    sets = ["solver.time_step=1e-6", "solver.duration=19", "solver.output_every=1", "train.cars=20"]
    result = _invoke([str(scenario), "-o", str(out), "-q", *(a for s in sets for a in ("--set", s))])
    assert time.perf_counter() - started < 60
    assert result.exit_code == 2
    line = _error_line(result.output)
    for key in ("solver.time_step", "solver.duration", "solver.output_every", "--max-memory", "GiB"):
        assert key in line
    assert not out.exists()


def test_max_memory_sets_the_limit(tmp_path: Path) -> None:
    scenario = _scenario(tmp_path)
    out = tmp_path / "run.nc"
    small = _invoke([str(scenario), "-o", str(out), "-q", "--max-memory", "10KiB"])
    assert small.exit_code == 2
    assert "10 KiB" in _error_line(small.output) or "10.0 KiB" in _error_line(small.output)
    assert not out.exists()
    enough = _invoke([str(scenario), "-o", str(out), "-q", "--max-memory", "1GiB"])
    assert enough.exit_code == 0, enough.output
    assert out.is_file()
    bad = _invoke([str(scenario), "-o", str(out), "-q", "--max-memory", "lots"])
    assert bad.exit_code == 2
    assert "--max-memory" in _error_line(bad.output)


def test_parse_size() -> None:
    from svbi.runtime.run.memory import parse_size

    assert parse_size("8GiB") == 8 * 2**30
    assert parse_size("1.5 GB") == 1_500_000_000
    assert parse_size("512M") == 512 * 2**20
    assert parse_size("100") == 100
    for bad in ("", "-1GiB", "nan", "inf", "GiB", "1 parsec"):
        with pytest.raises(ValueError):
            parse_size(bad)


def test_the_estimate_of_the_stored_arrays_is_what_the_run_allocates(tmp_path: Path) -> None:
    """Mid-size run (3 cars, 4 spans, creep and irregularity): the estimate of the recorder's arrays
    is their exact size, and the whole estimate is within a factor 2 of the traced peak of the run and
    its write (NumPy arrays are traced by ``tracemalloc``; the NetCDF library's image of the file is
    not)."""
    import tracemalloc

    import svbi.runtime.run.results as results
    from svbi.runtime.run.memory import estimate_memory
    from svbi.runtime.run.simulate import simulate
    from svbi.runtime.scenario.schema import load_scenario

    text = (
        GOOD.replace("spans = 1", "spans = 4")
        .replace('vehicle = "sprung-mass"', 'vehicle = "pioneer-2d"\ncars = 3')
        .replace("time_step = 2.0e-3", "time_step = 2.0e-4\nduration = 1.0")
        + '\n[track]\nirregularity = "german-low"\n'
    )
    sc = load_scenario(_scenario(tmp_path, text))
    estimate = estimate_memory(sc)

    recorders: list = []

    class Spy(results.Recorder):
        def __init__(self, model) -> None:
            super().__init__(model)
            recorders.append(self)

    import svbi.runtime.run.simulate as sim

    real = sim.Recorder
    sim.Recorder = Spy
    try:
        # compile (if needed) and import the writer outside the traced run
        results.write_netcdf(simulate(sc), tmp_path / "run.nc")
        from svbi.runtime.scenario import build

        build.irregularity_table.cache_clear()  # the traced run tabulates the profile again
        tracemalloc.start()
        base = tracemalloc.get_traced_memory()[0]
        results.write_netcdf(simulate(sc), tmp_path / "run.nc")  # what `svbi run` does
        peak = tracemalloc.get_traced_memory()[1] - base
        tracemalloc.stop()
    finally:
        sim.Recorder = real
    rec = recorders[-1]
    stored = sum(a.nbytes for a in rec.data.values())
    assert estimate.parts["results"] == stored
    assert estimate.parts["force buffer"] == rec.forces.nbytes
    in_contact = rec.in_contact.nbytes if rec.in_contact is not None else rec.forces.size  # bool per wheel
    assert estimate.parts["contact states"] == in_contact
    assert 0.5 * peak <= estimate.total <= 2.0 * peak, (estimate.parts, peak)


def test_sigterm_during_the_compile_stops_in_one_line_and_leaves_no_build_folder(tmp_path: Path) -> None:
    """`svbi run` with an empty compile cache and a slow compiler, stopped while it compiles."""
    cache = tmp_path / "cache"
    cc = tmp_path / "slowcc.py"
    cc.write_text(SLOW_CC, encoding="utf-8")
    mark = tmp_path / "compiling"
    out = tmp_path / "run.nc"
    out.write_bytes(PREVIOUS)
    scenario = _scenario(tmp_path)
    env = dict(os.environ, CC=f"{sys.executable} {cc}", SLOW_CC_MARK=str(mark), SVBI_CACHE_DIR=str(cache))
    proc = subprocess.Popen(
        [*_svbi_command(), "run", str(scenario), "-o", str(out), "-q"],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        end = time.monotonic() + 120
        while not mark.exists() and time.monotonic() < end and proc.poll() is None:
            time.sleep(0.05)
        assert mark.exists(), proc.stderr.read() if proc.poll() is not None else "no compile"
        proc.send_signal(signal.SIGTERM)
        _, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
        if mark.exists():
            with contextlib.suppress(ProcessLookupError, ValueError):
                os.kill(int(mark.read_text()), signal.SIGKILL)
    assert proc.returncode == 143, stderr[-3000:]
    assert _error_line(stderr) == "error: interrupted by SIGTERM; nothing written"
    assert out.read_bytes() == PREVIOUS
    assert not list(tmp_path.glob("run.incomplete.nc"))
    assert not [p for p in cache.iterdir() if p.name.startswith(".build-")]
