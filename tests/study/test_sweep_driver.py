"""`svbi sweep` as a driver: output paths resolved and checked before any run, an external cluster
whose workers run in another folder, SIGTERM and Ctrl-C, no worker alive, failed runs counted,
and lost runs reported with ``-q``.

Runs are tiny (one 20 m span, fractions of a second simulated) so that the file stays fast.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from svbi.runtime.study import sweep as sweep_module
from svbi.runtime.study.sweep import load_study, read_store, run_sweep

BRIDGE = """[bridge]
spans = 1
span_length = 20.0
mass_per_length = 15.0e3
youngs_modulus = 35.0e9
area = 6.0
second_moment = 1.5
elements_per_span = 8
"""
PIONEER = (
    BRIDGE
    + """[train]
vehicle = "pioneer-2d"
speed_kmh = 200.0
start_position = -5.0
[track]
irregularity = "german-low"
[solver]
time_step = 1.0e-3
duration = 0.3
"""
)
HSLM = (
    BRIDGE
    + """[train]
vehicle = "moving-load"
hslm = "A4"
speed_kmh = 200.0
[solver]
time_step = 2.0e-4
duration = 1.5
"""
)
# two runs succeed, two fail (time_step = 2e-3 is refused by the explicit creep force)
FAILING = '[axes]\n"train.speed_kmh" = [150.0, 200.0]\n"solver.time_step" = [1.0e-3, 2.0e-3]\n'


def write(folder: Path, name: str, text: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def svbi_cli(*args: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "svbi.runtime.cli", *args], capture_output=True, text=True, timeout=300, **kw
    )


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Cluster:
    """A Dask scheduler and workers started as processes (each worker in the folder ``cwd``)."""

    def __init__(self) -> None:
        self.address = f"tcp://127.0.0.1:{_free_port()}"
        self.procs: list[subprocess.Popen] = []
        self.dask = str(Path(sys.executable).parent / "dask")
        self.env = {**os.environ, "DASK_DISTRIBUTED__WORKER__DAEMON": "False"}

    def start(self, *args: str, cwd: Path | None = None) -> subprocess.Popen:
        p = subprocess.Popen(
            [self.dask, *args],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            env=self.env,
            cwd=cwd,
            start_new_session=True,
        )
        self.procs.append(p)
        return p

    def scheduler(self) -> None:
        port = self.address.rsplit(":", 1)[1]
        self.start("scheduler", "--host", "127.0.0.1", "--port", port, "--no-dashboard")

    def worker(self, cwd: Path) -> subprocess.Popen:
        cwd.mkdir(parents=True, exist_ok=True)
        return self.start("worker", self.address, "--nthreads", "1", "--no-nanny", "--no-dashboard", cwd=cwd)

    def stop(self) -> None:
        for p in self.procs:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait(timeout=30)


@pytest.fixture
def cluster():
    c = Cluster()
    try:
        yield c
    finally:
        c.stop()


def _parts(out: Path) -> dict[str, int]:
    folder = Path(str(out) + ".parts")
    return {p.name: p.stat().st_mtime_ns for p in folder.glob("*.nc")} if folder.is_dir() else {}


def _interruptible() -> None:
    """In the child before exec: SIGINT back to its default. A shell runs background jobs with SIGINT
    ignored, and a child inherits that (Python then keeps it ignored): a test suite started in the
    background would otherwise send a Ctrl-C nobody hears."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _wait_for_parts(out: Path, count: int, proc: subprocess.Popen, limit: float = 120.0) -> None:
    t0 = time.monotonic()
    while len(_parts(out)) < count:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() - t0 < limit, "no progress"
        time.sleep(0.05)


# --------------------------------------------------------------------------------------------------
# an external cluster whose workers run elsewhere; failed runs counted in the exit status


def test_relative_output_on_an_external_cluster_equals_a_local_sweep(tmp_path, cluster):
    base = tmp_path / "study"
    write(base, "base.toml", PIONEER)
    study = write(base, "s.toml", 'scenario = "base.toml"\n' + FAILING)
    # the same sweep on the LocalCluster of `svbi sweep`, the reference
    local = tmp_path / "local"
    local.mkdir()
    ref = svbi_cli("sweep", str(study), "-o", "ref.nc", "-q", "--workers", "1", cwd=local)
    assert ref.returncode == 4, ref.stderr
    assert "2 of 4 runs failed" in ref.stderr, ref.stderr
    # an external cluster: its worker's working folder is not the driver's
    cluster.scheduler()
    cluster.worker(tmp_path / "elsewhere")
    driver = tmp_path / "driver"
    driver.mkdir()
    r = svbi_cli("sweep", str(study), "-o", "out.nc", "-q", "--scheduler", cluster.address, cwd=driver)
    assert r.returncode == 4, r.stderr
    assert not list((tmp_path / "elsewhere").iterdir())  # nothing written in the worker's folder
    a, b = read_store(driver / "out.nc"), read_store(local / "ref.nc")
    assert a.status.values.tolist() == b.status.values.tolist()
    assert sorted(set(a.status.values.ravel().tolist())) == ["failed", "ok"]
    for name in ("peak_deck_acceleration", "peak_carbody_az", "max_unloading_ratio", "peak_midspan_uz"):
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)


# --------------------------------------------------------------------------------------------------
# the output path, checked before any run


@pytest.mark.parametrize(
    ("make", "expected"),
    [
        (lambda d: "/proc/svbi-sweep-test.nc", "not writable"),
        (lambda d: str(d / "missing" / "deeper" / "out.nc"), "does not exist"),
        (lambda d: (d / "afolder.nc").mkdir() or str(d / "afolder.nc"), "is a folder"),
        (lambda d: (d / "file.txt").write_text("x") and str(d / "file.txt" / "out.nc"), "is a file"),
        (lambda d: str(d / "out.csv"), "give a name ending in .nc or .zarr"),
        (lambda d: str(d / "s.toml"), "give a name ending in .nc or .zarr"),
    ],
)
def test_output_is_checked_before_any_run(tmp_path, make, expected):
    write(tmp_path, "base.toml", HSLM)
    study = write(tmp_path, "s.toml", 'scenario = "base.toml"\n[axes]\n"train.speed_kmh" = [150.0, 200.0]\n')
    target = make(tmp_path)
    r = svbi_cli("sweep", str(study), "-o", target, "-q", "--workers", "1")
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr and expected in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not Path(target + ".parts").exists() and not (tmp_path / "missing").exists()


# --------------------------------------------------------------------------------------------------
# interrupts, dead clusters, lost runs


def test_sigterm_stops_the_sweep_and_no_part_is_written_after(tmp_path, cluster):
    write(tmp_path, "base.toml", HSLM)
    speeds = ", ".join(f"{v:.1f}" for v in np.linspace(150.0, 300.0, 10))
    study = write(tmp_path, "s.toml", f'scenario = "base.toml"\n[axes]\n"train.speed_kmh" = [{speeds}]\n')
    out = tmp_path / "out.nc"
    cluster.scheduler()
    cluster.worker(tmp_path)
    driver = subprocess.Popen(
        [sys.executable, "-m", "svbi.runtime.cli", "sweep", str(study), "-o", str(out), "-q"]
        + ["--scheduler", cluster.address],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    _wait_for_parts(out, 2, driver)
    driver.send_signal(signal.SIGTERM)
    _, err = driver.communicate(timeout=60)
    assert driver.returncode == 128 + signal.SIGTERM, (driver.returncode, err)
    text = err.decode()
    assert "interrupted by SIGTERM" in text and "run the same command to resume" in text, text
    assert "Traceback" not in text
    kept = _parts(out)
    time.sleep(3.0)  # a run in flight on the worker when the driver stopped would finish in this time
    assert _parts(out) == kept and len(kept) < 10


def test_ctrl_c_stops_a_local_sweep_without_worker_tracebacks(tmp_path):
    write(tmp_path, "base.toml", HSLM)
    speeds = ", ".join(f"{v:.1f}" for v in np.linspace(150.0, 300.0, 10))
    study = write(tmp_path, "s.toml", f'scenario = "base.toml"\n[axes]\n"train.speed_kmh" = [{speeds}]\n')
    out = tmp_path / "out.nc"
    driver = subprocess.Popen(
        [sys.executable, "-m", "svbi.runtime.cli", "sweep", str(study), "-o", str(out), "-q", "-w", "2"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
        preexec_fn=_interruptible,
    )
    _wait_for_parts(out, 3, driver)
    assert driver.poll() is None, "the sweep finished before the interrupt"
    os.killpg(driver.pid, signal.SIGINT)  # a terminal's Ctrl-C: the whole process group
    _, err = driver.communicate(timeout=60)
    text = err.decode()
    assert driver.returncode == 130, (driver.returncode, text)
    assert "interrupted by SIGINT" in text and "Traceback" not in text and "KeyboardInterrupt" not in text, (
        text
    )


def test_no_worker_alive_is_a_clear_error(tmp_path, cluster):
    write(tmp_path, "base.toml", HSLM)
    study = write(tmp_path, "s.toml", 'scenario = "base.toml"\n[axes]\n"train.speed_kmh" = [150.0, 200.0]\n')
    cluster.scheduler()
    r = svbi_cli(
        "sweep", str(study), "-o", str(tmp_path / "out.nc"), "-q", "--scheduler", cluster.address,
        "--worker-timeout", "3",
    )  # fmt: skip
    assert r.returncode == 3, r.stderr
    assert f"no worker is alive on {cluster.address}" in r.stderr and "Traceback" not in r.stderr, r.stderr


def test_lost_runs_are_reported_without_a_progress_bar(tmp_path, monkeypatch, capsys):
    """``-q`` (no progress bar) still says which runs were lost, and how to resume."""
    from dask.distributed import LocalCluster

    write(tmp_path, "base.toml", HSLM.replace("time_step = 2.0e-4", "time_step = 1.0e-3"))
    study = load_study(
        write(
            tmp_path, "s.toml", 'scenario = "base.toml"\n[axes]\n"train.speed_kmh" = [150.0, 200.0, 250.0]\n'
        )
    )

    def dies(*args, **kwargs):
        raise RuntimeError("the worker died")

    monkeypatch.setattr(sweep_module, "run_batch", dies)
    with LocalCluster(n_workers=1, processes=False, dashboard_address=None) as lc:
        report = run_sweep(study, tmp_path / "out.nc", scheduler=lc.scheduler_address, progress=False)
    assert report.statuses.get("missing") == 2  # the probe ran in the driver
    err = capsys.readouterr().err
    assert "runs lost (RuntimeError: the worker died)" in err and "run the sweep again to resume" in err
