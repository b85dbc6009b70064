"""`svbi demo --quick`: the paper example end to end, CI-sized, produces every file."""

from __future__ import annotations

from pathlib import Path

import xarray as xr
from typer.testing import CliRunner

from svbi.runtime.cli.app import _register, app
from svbi.runtime.cli.demo import METHODS, example_path
from svbi.runtime.plots.results import FIGURE_NAMES
from svbi.runtime.scenario.schema import load_scenario

_register()


def test_example_scenarios_validate() -> None:
    sc = load_scenario(example_path())
    assert sc.train.cars == 10 and sc.bridge.spans == 10 and sc.train.speed_kmh == 300.0
    assert sc.track.irregularity == "german-low"
    assert sc.earthquake is not None and sc.earthquake.vertical == "synthetic"


def test_quick_demo_writes_results_figures_and_summary(tmp_path: Path) -> None:
    result = CliRunner().invoke(app, ["demo", "--quick", "--out", str(tmp_path), "-q"])
    assert result.exit_code == 0, result.output
    runs = {}
    for method in METHODS:
        path = tmp_path / f"{method}.nc"
        assert path.is_file()
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            assert ds.attrs["method"] == method and ds.attrs["complete"] == 1
            runs[method] = ds.load()
    for name in FIGURE_NAMES:
        png = tmp_path / "figures" / f"{name}.png"
        assert png.is_file() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary = (tmp_path / "summary.txt").read_text()
    assert all(m in summary for m in METHODS) and "wall time" in summary
    # The two dynamic methods are the same discrete problem; classic drifts away from them.
    loc, cpl, cls = (runs[m] for m in METHODS)
    scale = float(abs(loc.midspan_uz).max())
    assert float(abs(loc.midspan_uz - cpl.midspan_uz).max()) < 1e-8 * scale
    assert float(abs(cls.gap_bridge).max()) > 100 * float(abs(loc.gap_bridge).max())
    # the strong-shaking run: unilateral contact under a 2 g vertical record, wheels lift off
    with xr.open_dataset(tmp_path / "strong-shaking.nc", engine="h5netcdf") as ds:
        assert ds.attrs["contact_normal"] == "unilateral" and ds.attrs["liftoffs"] > 0
        assert float(ds.contact_force.min()) >= 0.0
    assert (tmp_path / "strong-shaking-figures" / "wheel_lift_off.png").is_file()
    assert "wheel lift-offs" in summary
    # the 3D run: the 3D example, its lateral running-safety figure and summary lines
    with xr.open_dataset(tmp_path / "three-d.nc", engine="h5netcdf") as ds:
        assert ds.attrs["dimensions"] == 3 and ds.attrs["complete"] == 1
        assert set(ds.side.values) == {"left", "right"} and "derailment_quotient" in ds
    assert (tmp_path / "three-d-figures" / "lateral_running_safety.png").is_file()
    assert "derailment quotient Y/Q" in summary and "flange contacts" in summary
