"""`svbi sweep --dry-run`: runs, time, disk and memory estimated from a probe run; a study that
would fill the disk is refused with the estimate, before the cluster starts."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from svbi.runtime.cli import app as cli
from svbi.runtime.study import sweep as sweep_module

HSLM = """[bridge]
spans = 1
span_length = 20.0
mass_per_length = 15.0e3
youngs_modulus = 35.0e9
area = 6.0
second_moment = 1.5
elements_per_span = 8
[train]
vehicle = "moving-load"
hslm = "A4"
speed_kmh = 200.0
[solver]
time_step = 1.0e-3
duration = 1.0
"""


def study(tmp_path: Path, histories: bool) -> Path:
    (tmp_path / "base.toml").write_text(HSLM, encoding="utf-8")
    path = tmp_path / "s.toml"
    path.write_text(
        'scenario = "base.toml"\n[axes]\n"train.speed_kmh" = [150.0, 200.0, 250.0]\n'
        '"bridge.damping_ratio" = [0.01, 0.02]\n'
        f"[output]\nhistories = {'true' if histories else 'false'}\n",
        encoding="utf-8",
    )
    return path


def invoke(*args: str):
    cli._register()
    return CliRunner().invoke(cli.app, ["sweep", *args])


def test_dry_run_prints_runs_time_disk_and_memory_and_writes_nothing(tmp_path):
    out = tmp_path / "out.nc"
    r = invoke(str(study(tmp_path, histories=True)), "-o", str(out), "--dry-run", "--workers", "2")
    assert r.exit_code == 0, r.output
    text = r.output
    assert "6 runs (6 to run" in text, text
    assert "time:" in text and "on 2 workers" in text, text
    assert "disk:" in text and "histories" in text and "parts" in text, text
    assert "memory:" in text and "per worker" in text, text
    assert not out.exists() and not Path(str(out) + ".parts").exists()
    assert not Path(str(out) + ".histories").exists()


def test_a_study_that_would_fill_the_disk_is_refused_with_the_estimate(tmp_path, monkeypatch):
    monkeypatch.setattr(sweep_module, "free_disk_bytes", lambda path: 10_000)
    out = tmp_path / "out.nc"
    r = invoke(str(study(tmp_path, histories=True)), "-o", str(out), "-q", "--workers", "1")
    assert r.exit_code == 2, r.output
    assert "would need about" in r.output and "free" in r.output, r.output
    assert "Traceback" not in r.output
    assert not out.exists()
    assert len(list(Path(str(out) + ".parts").glob("*.nc"))) <= 1  # at most the probe run
