"""Signals and kills around the results write of `svbi run`.

* a signal during the write deadlocked (7 tries in 12): SIGINT / SIGTERM raised inside a lock of
  the NetCDF writer, whose clean-up takes the same lock. The write now holds the signals back and
  acts on them once the temporary file is complete: the previous file is kept, exit 130 / 143;
* SIGHUP (the terminal closed) stops a run like SIGTERM: partial results written, exit 129;
* a SIGKILL during the write left a hidden temporary file beside the results for ever: the next
  write of the same file removes temporaries whose process is gone.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import xarray as xr

PREVIOUS = b"previous results: must survive\n"

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
vehicle = "sprung-mass"
speed_kmh = 100.0

[solver]
time_step = 2.0e-3
output_every = 5

[contact]
creep = false
"""


def _debris(folder: Path) -> list[str]:
    """Hidden temporary files that an atomic write may leave behind."""
    return sorted(p.name for p in folder.iterdir() if p.name.startswith(".") and p.name.endswith(".tmp"))


def _default_signals() -> None:  # a background test runner may hand signals down as ignored
    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, signal.SIG_DFL)


def _svbi(*args: str, **kwargs) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-c", "from svbi.runtime.cli.app import main; main()", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        preexec_fn=_default_signals,
        **kwargs,
    )


# --------------------------------------------------------------------------------------------------
# a signal during the write


LOCKED_WRITE = """
import os, signal, sys, threading
from pathlib import Path
from svbi.runtime.run.atomic import write_atomic
from svbi.runtime.run.output import RunInterrupted, signals_interrupt

lock = threading.Lock()

def write(tmp: Path) -> None:
    # the NetCDF writer's pattern: work under a lock, and a clean-up that takes the lock again;
    # the signal arrives while the lock is held (as it did, at random, in the real writer)
    try:
        lock.acquire()
        os.kill(os.getpid(), signal.{name})
        for _ in range(1000):  # a handler that raises does so here, with the lock held
            pass
        tmp.write_bytes(b"new results")
        lock.release()
    finally:
        with lock:
            pass

try:
    with signals_interrupt():
        write_atomic(sys.argv[1], write)
except RunInterrupted as exc:
    print("interrupted", exc.signal_name, flush=True)
    sys.exit(exc.exit_code)
print("written", flush=True)
"""


@pytest.mark.parametrize(("name", "code"), [("SIGINT", 130), ("SIGTERM", 143), ("SIGHUP", 129)])
def test_a_signal_inside_the_writers_lock_does_not_deadlock(tmp_path: Path, name: str, code: int) -> None:
    target = tmp_path / "run.nc"
    target.write_bytes(PREVIOUS)
    proc = subprocess.Popen(
        [sys.executable, "-c", LOCKED_WRITE.replace("{name}", name), str(target)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_default_signals,
    )
    try:
        out, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        pytest.fail(f"{name} during the write deadlocked the process")
    assert proc.returncode == code, err[-3000:]
    assert out.split() == ["interrupted", name]
    assert target.read_bytes() == PREVIOUS  # the write is abandoned: the previous file is kept
    assert _debris(tmp_path) == []


def _long_output_scenario(tmp_path: Path) -> Path:
    """A short run with many stored rows (1e5): building and writing its NetCDF image takes a
    moment, long enough to signal the process while it writes."""
    path = tmp_path / "scenario.toml"
    path.write_text(SCENARIO, encoding="utf-8")
    return path


def test_sigterm_while_svbi_run_writes_keeps_the_previous_file(tmp_path: Path) -> None:
    out = tmp_path / "run.nc"
    out.write_bytes(PREVIOUS)
    scenario = _long_output_scenario(tmp_path)
    proc = _svbi(
        "run",
        str(scenario),
        "-o",
        str(out),
        "-q",
        "--set",
        "solver.time_step=1e-5",
        "--set",
        "solver.duration=1.0",
        "--set",
        "solver.output_every=1",
    )
    try:
        end = time.monotonic() + 240
        while not _debris(tmp_path) and proc.poll() is None and time.monotonic() < end:
            time.sleep(0.002)
        assert _debris(tmp_path), "the write's temporary file never showed"
        proc.send_signal(signal.SIGTERM)
        try:
            _, err = proc.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
            pytest.fail("SIGTERM during the write deadlocked svbi run")
    finally:
        if proc.poll() is None:
            proc.kill()
    stderr = err.decode(errors="replace")
    assert proc.returncode == 143, stderr[-3000:]
    assert "Traceback" not in stderr
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert lines == [f"error: interrupted by SIGTERM while writing {out}; the previous file is kept"]
    assert out.read_bytes() == PREVIOUS
    assert _debris(tmp_path) == []
    assert not (tmp_path / "run.incomplete.nc").exists()


# --------------------------------------------------------------------------------------------------
# SIGHUP during the loop


def test_sighup_during_the_loop_writes_partial_results_like_sigterm(tmp_path: Path) -> None:
    out = tmp_path / "run.nc"
    out.write_bytes(PREVIOUS)
    scenario = _long_output_scenario(tmp_path)
    proc = _svbi(
        "run",
        str(scenario),
        "-o",
        str(out),
        "--set",
        "solver.backend=numpy",
        "--set",
        "solver.time_step=1e-5",
        "--set",
        "solver.duration=100.0",
        "--set",
        "solver.output_every=100",
        "--set",
        "train.speed_kmh=1.0",
    )
    os.set_blocking(proc.stderr.fileno(), False)
    text = b""
    try:
        end = time.monotonic() + 240
        while time.monotonic() < end and proc.poll() is None:  # until the progress bar shows
            text += proc.stderr.read() or b""
            if b"step" in text and b"%" in text:
                break
            time.sleep(0.1)
        assert proc.poll() is None, text.decode(errors="replace")[-2000:]
        proc.send_signal(signal.SIGHUP)
        proc.wait(timeout=120)
        os.set_blocking(proc.stderr.fileno(), True)
        text += proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
    stderr = text.decode(errors="replace")
    assert proc.returncode == 129, stderr[-3000:]
    assert "Traceback" not in stderr
    messages = [line for line in stderr.replace("\r", "\n").splitlines() if line.startswith("error")]
    partial = tmp_path / "run.incomplete.nc"
    assert len(messages) == 1 and "SIGHUP" in messages[0] and str(partial) in messages[0], stderr[-3000:]
    assert out.read_bytes() == PREVIOUS
    with xr.open_dataset(partial, engine="h5netcdf") as ds:
        assert ds.attrs["complete"] == 0 and "SIGHUP" in ds.attrs["incomplete"]
        assert ds.sizes["time"] > 1 and float(ds.time[-1]) < 100.0
    assert _debris(tmp_path) == []


# --------------------------------------------------------------------------------------------------
# the temporary file of a killed write


SLOW_WRITE = """
import sys, time
from pathlib import Path
from svbi.runtime.run.atomic import write_atomic

def slow(tmp: Path) -> None:
    tmp.write_bytes(b"x" * 100_000)
    print("writing", flush=True)
    time.sleep(120)

write_atomic(sys.argv[1], slow)
"""


def test_the_temporary_file_of_a_killed_write_is_removed_by_the_next_write(tmp_path: Path) -> None:
    from svbi.runtime.run.atomic import write_atomic

    target = tmp_path / "run.nc"
    target.write_bytes(PREVIOUS)
    other = tmp_path / "other.nc"
    proc = subprocess.Popen(
        [sys.executable, "-c", SLOW_WRITE, str(target)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout.readline().strip() == "writing"
        proc.kill()  # SIGKILL: no clean-up runs
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    left = _debris(tmp_path)
    assert len(left) == 1 and left[0].startswith(".run.nc.")  # what the killed write left

    # a write in progress of this process (alive), and the temporary file of another target
    live = tmp_path / left[0].replace(f"-{proc.pid}-", f"-{os.getpid()}-")
    live.write_bytes(b"live")
    foreign = tmp_path / left[0].replace(".run.nc.", ".other.nc.")
    foreign.write_bytes(b"another file's")

    write_atomic(target, lambda tmp: tmp.write_bytes(b"new"))
    assert target.read_bytes() == b"new"
    assert _debris(tmp_path) == sorted([live.name, foreign.name])  # the dead one only is gone

    # the other target's temporary file goes with that target's next write
    write_atomic(other, lambda tmp: tmp.write_bytes(b"other"))
    assert _debris(tmp_path) == [live.name]


def test_an_old_temporary_file_of_the_same_target_is_removed(tmp_path: Path) -> None:
    """Whoever made it (a crash of an earlier version, another machine on a shared disk): a write
    never leaves its temporary file untouched for hours."""
    from svbi.runtime.run import atomic

    target = tmp_path / "run.nc"
    old = tmp_path / ".run.nc.k2j3h4g5.tmp"  # an earlier version's name: no process id
    old.write_bytes(b"stale")
    past = time.time() - atomic.STALE_TEMPORARY_S - 60
    os.utime(old, (past, past))
    recent = tmp_path / ".run.nc.a1b2c3d4.tmp"
    recent.write_bytes(b"maybe someone's write in progress")
    atomic.write_atomic(target, lambda tmp: tmp.write_bytes(b"new"))
    assert _debris(tmp_path) == [recent.name]


def test_the_sweep_touches_only_temporaries_of_the_target(tmp_path: Path) -> None:
    """Files that only look alike (no leading dot, another suffix) are never touched."""
    from svbi.runtime.run.atomic import write_atomic

    keep = [tmp_path / "run.nc.12345.tmp", tmp_path / ".run.nc.notes", tmp_path / ".run.ncx.1-2-3.tmp"]
    for path in keep:
        path.write_bytes(b"user data")
        past = time.time() - 10 * 86400
        os.utime(path, (past, past))
    write_atomic(tmp_path / "run.nc", lambda tmp: tmp.write_bytes(b"new"))
    assert all(path.read_bytes() == b"user data" for path in keep)


def test_write_atomic_under_a_signal_handler_that_does_not_raise(tmp_path: Path) -> None:
    """A handler that only records the signal: the write completes (the signal is delivered after)."""
    from svbi.runtime.run.atomic import write_atomic

    seen: list[int] = []
    previous = signal.signal(signal.SIGTERM, lambda signum, frame: seen.append(signum))
    try:

        def write(tmp: Path) -> None:
            os.kill(os.getpid(), signal.SIGTERM)
            tmp.write_bytes(b"new")

        write_atomic(tmp_path / "r.nc", write)
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert seen == [signal.SIGTERM]
    assert (tmp_path / "r.nc").read_bytes() == b"new"
    assert _debris(tmp_path) == []
