"""`svbi sweep`: study files, the grid, agreement with `svbi run`, failures, resume after an
interrupt and after a killed worker (a scheduler and workers started here as processes).

Runs are short (one 20 m span, fractions of a second simulated) so that the whole file stays fast.
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
import xarray as xr

from svbi.runtime.study.metrics import METRIC_DIMS, compute_metrics
from svbi.runtime.study.sweep import StudyError, load_study, read_store, run_sweep

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
duration = 0.4
"""
)
HSLM = (
    BRIDGE
    + """[train]
vehicle = "moving-load"
hslm = "A4"
speed_kmh = 200.0
[solver]
time_step = 1.0e-3
duration = 1.5
"""
)


def write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def svbi_cli(*args: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "svbi.runtime.cli", *args],
        capture_output=True,
        text=True,
        timeout=300,
        **kw,
    )


# --------------------------------------------------------------------------------------------------
# study files


def test_study_errors_name_key_file_and_line(tmp_path):
    write(tmp_path, "base.toml", HSLM)
    bad = write(
        tmp_path,
        "bad.toml",
        'scenario = "base.toml"\n[axes]\n"train.speed_kmh" = [100.0, -5.0]\n[zip]\n'
        '"train.hslm" = ["A1", "A2"]\n"bridge.damping_ratio" = [0.01]\n[outptu]\nhistories = true\n',
    )
    with pytest.raises(StudyError) as info:
        load_study(bad)
    text = str(info.value)
    assert f"{bad}:7: outptu" in text  # unknown table, with its line
    bad.write_text(bad.read_text().replace("[outptu]", "[output]"))
    with pytest.raises(StudyError) as info:
        load_study(bad)
    text = str(info.value)
    assert f"{bad}:4: zip: the lists must have the same length" in text
    assert f"{bad}:3: axes.train.speed_kmh: value -5.0" in text and "greater than or equal to 0" in text
    write(tmp_path, "types.toml", 'scenario = "base.toml"\n[axes]\n"train.speed_kmh" = [1.0, {a = 1}]\n')
    with pytest.raises(StudyError) as info:
        load_study(tmp_path / "types.toml")
    assert len(info.value.problems) == 1  # one problem per key, not one per member of the union
    assert "types.toml:3: axes.train.speed_kmh.1: expected a string, number, boolean" in str(info.value)
    write(tmp_path, "missing.toml", 'scenario = "nope.toml"\n[axes]\n"train.speed_kmh" = [1.0]\n')
    with pytest.raises(StudyError, match=r"missing.toml:1: scenario: file not found"):
        load_study(tmp_path / "missing.toml")
    r = svbi_cli("sweep", str(bad), "-o", str(tmp_path / "out.nc"))
    assert r.returncode == 2 and "zip: the lists must have the same length" in r.stderr


def test_grid_order_and_dimensions(tmp_path):
    write(tmp_path, "base.toml", HSLM)
    study = load_study(
        write(
            tmp_path,
            "s.toml",
            'scenario = "base.toml"\n[axes]\n"train.speed_kmh" = [100.0, 200.0, 300.0]\n'
            '"bridge.damping_ratio" = [0.01, 0.02]\n[zip]\n"train.hslm" = ["A1", "A2"]\n'
            '"solver.duration" = [1.0, 1.2]\n',
        )
    )
    assert study.keys == ["train.speed_kmh", "bridge.damping_ratio", "train.hslm"]
    assert study.dims == ["speed_kmh", "damping_ratio", "hslm"]  # names a user can type
    assert study.shape == (3, 2, 2) and len(study.runs) == 12
    r = study.runs[7]  # C order: index (1, 1, 1)
    assert r.index == (1, 1, 1)
    assert r.overrides == {
        "train.speed_kmh": 200.0,
        "bridge.damping_ratio": 0.02,
        "train.hslm": "A2",
        "solver.duration": 1.2,
    }
    assert len({x.run_id for x in study.runs}) == 12


# --------------------------------------------------------------------------------------------------
# a sweep against svbi run


def test_sweep_metrics_equal_svbi_run_and_failures_are_recorded(tmp_path):
    write(tmp_path, "base.toml", PIONEER)
    # time_step = 2e-3 is refused at run time by the explicit creep force (too large): a failed run
    study = load_study(
        write(
            tmp_path,
            "s.toml",
            'scenario = "base.toml"\n[axes]\n"train.speed_kmh" = [150.0, 200.0]\n'
            '"solver.time_step" = [1.0e-3, 2.0e-3]\n[output]\nhistories = true\n',
        )
    )
    out = tmp_path / "out.nc"
    report = run_sweep(study, out, workers=2, progress=False)
    assert report.statuses == {"ok": 2, "failed": 2}
    store = read_store(out)
    assert list(store.status.dims) == ["speed_kmh", "time_step"]
    with xr.open_dataset(out) as plain:  # a user's plain xarray reads it, the run times as dates
        assert (
            plain.started.dtype.kind == "M" and plain.status.values.tolist() == store.status.values.tolist()
        )
    assert store.status.sel(time_step=2e-3).values.tolist() == ["failed", "failed"]
    assert "contact.creep: the explicit creep force is unstable" in str(store.message.values[0, 1])
    assert np.isnan(store.peak_deck_acceleration.sel(time_step=2e-3)).all()
    # the same runs by `svbi run` and `svbi metrics`, in fresh processes
    for speed in (150.0, 200.0):
        res = tmp_path / f"run{speed:g}.nc"
        r = svbi_cli(
            "run", str(tmp_path / "base.toml"), "-o", str(res), "-q", f"--set=train.speed_kmh={speed}"
        )
        assert r.returncode == 0, r.stderr
        with xr.open_dataset(res) as m:
            ref = compute_metrics(m.load())
        point = store.sel(speed_kmh=speed, time_step=1e-3)
        assert point.status.item() == "ok"
        compared = 0
        for name in METRIC_DIMS:
            if name not in ref:
                continue
            for var in (name, f"{name}_time"):
                if var in ref:
                    np.testing.assert_allclose(
                        point[var].values, ref[var].values, rtol=1e-9, atol=0, err_msg=var
                    )
                    compared += 1
        assert compared >= 10
        assert float(point.peak_carbody_az.max()) > 0 and float(point.max_unloading_ratio.max()) > 0
    # histories kept beside the store, one per finished run
    assert len(list(Path(str(out) + ".histories").glob("*.nc"))) == 2
    # a worker process keeps its model between runs: some process ran more than one run
    runs = []
    for part in Path(str(out) + ".parts").glob("*.nc"):
        with xr.open_dataset(part) as p:
            runs.append(int(p.attrs["worker_run"]))
    assert max(runs) > 1


# --------------------------------------------------------------------------------------------------
# resume: an interrupted driver, a killed worker


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _parts(out: Path) -> dict[str, float]:
    folder = Path(str(out) + ".parts")
    return {p.name: p.stat().st_mtime_ns for p in folder.glob("*.nc")} if folder.is_dir() else {}


def _interruptible() -> None:
    """In the child before exec: SIGINT back to its default (a shell runs background jobs with SIGINT
    ignored, and a child inherits that: a suite started in the background could not interrupt)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _wait_for_parts(out: Path, count: int, proc: subprocess.Popen, limit: float = 120.0) -> None:
    t0 = time.monotonic()
    while len(_parts(out)) < count:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() - t0 < limit, "no progress"
        time.sleep(0.05)


def test_interrupt_and_killed_worker_lose_no_run_and_resume(tmp_path):
    # a finer step than elsewhere, so that runs are still in flight when the test intervenes
    write(tmp_path, "base.toml", HSLM.replace("time_step = 1.0e-3", "time_step = 2.0e-4"))
    speeds = ", ".join(f"{v:.1f}" for v in np.linspace(150.0, 300.0, 12))
    study = write(tmp_path, "s.toml", f'scenario = "base.toml"\n[axes]\n"train.speed_kmh" = [{speeds}]\n')
    out = tmp_path / "out.nc"
    bindir = Path(sys.executable).parent
    dask = str(bindir / "dask")
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "DASK_DISTRIBUTED__WORKER__DAEMON": "False"}
    procs: list[subprocess.Popen] = []

    def start(*args: str) -> subprocess.Popen:
        p = subprocess.Popen(
            args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, start_new_session=True
        )
        procs.append(p)
        return p

    try:
        start(dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard")
        workers = [
            start(dask, "worker", address, "--nthreads", "1", "--no-nanny", "--no-dashboard")
            for _ in range(2)
        ]
        cmd = [sys.executable, "-m", "svbi.runtime.cli", "sweep", str(study), "-o", str(out), "-q"]
        # 1. interrupt the driver part-way: the finished runs stay
        driver = subprocess.Popen(
            [*cmd, "--scheduler", address],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            preexec_fn=_interruptible,  # a background shell's SIG_IGN is not inherited
        )
        _wait_for_parts(out, 2, driver)
        assert driver.poll() is None, "the sweep finished before the interrupt"
        driver.send_signal(signal.SIGINT)
        _, err = driver.communicate(timeout=60)
        assert driver.returncode == 130 and b"the finished runs are kept" in err, err
        kept = _parts(out)
        assert 2 <= len(kept) < 12 and not out.exists()
        # 2. resume, and kill one worker part-way: its run moves to the other worker
        driver = subprocess.Popen(
            [*cmd, "--scheduler", address], stdout=subprocess.PIPE, stderr=subprocess.PIPE
        )
        _wait_for_parts(out, len(kept) + 1, driver)
        os.kill(workers[0].pid, signal.SIGKILL)
        stdout, stderr = driver.communicate(timeout=240)
        # 3. whatever that left, the same command again completes the study (a local cluster now)
        r = subprocess.run([*cmd, "--workers", "1"], capture_output=True, text=True, timeout=240)
        assert r.returncode == 0, r.stderr
        final = _parts(out)
        assert len(final) == 12
        assert all(final[name] == mtime for name, mtime in kept.items())  # finished runs never rerun
        store = read_store(out)
        assert (store.status.values == "ok").all()
        assert np.isfinite(store.peak_deck_acceleration.values).all()
    finally:
        for p in procs:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait(timeout=30)


def test_workers_keep_dask_thread_limits_without_the_malloc_trim_threshold():
    """The LocalCluster's workers: one BLAS/OpenMP thread each (Dask's default), and glibc's dynamic
    mmap threshold left alone (``sweep.worker_environment``: the per-run overhead halves)."""
    import dask
    import distributed  # noqa: F401 - loads Dask's distributed defaults

    from svbi.runtime.study.sweep import worker_environment

    env = worker_environment()
    assert "MALLOC_TRIM_THRESHOLD_" not in env
    assert "MALLOC_TRIM_THRESHOLD_" in dask.config.get("distributed.nanny.pre-spawn-environ")  # untouched
    for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        assert int(env[name]) == 1
