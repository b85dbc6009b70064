"""The metrics and ``svbi check`` rows of a 3D run (``study/metrics.py``, ``study/en1990.py``).

Synthetic results: the vertical variables a run writes plus the 3D variables of
``run/results3d.dataset3d``, with forces set by hand so that the peaks and the limits are known:

* the metrics: peak Y/Q, ΣY (and their 2 m means), the static axle load, flange contacts, ΔQ/Q per
  wheel and side, the car-body lateral acceleration, the lateral deck peaks;
* the seismic rows pass or fail at Nadal's limit, Prud'homme's limit of each wheelset (its own
  static load, α given) and a car-body lateral limit the user gives;
* a 2D run has none of the 3D metrics or rows (not NaN rows);
* a sweep's part keeps the 3D metrics with their ``side`` coordinate.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from cases import histories3d as histories

from svbi.runtime.run.results3d import dataset3d
from svbi.runtime.scenario.schema import validate_scenario
from svbi.runtime.study.en1990 import NADAL_LIMIT, CheckOptions, en1990_checks
from svbi.runtime.study.metrics import LATERAL_METRICS, compute_metrics
from svbi.runtime.study.sweep import _read_part, write_part

BRIDGE = dict(
    spans=2,
    span_length=20.0,
    mass_per_length=15.0e3,
    youngs_modulus=35.0e9,
    area=6.0,
    second_moment=1.5,
    elements_per_span=8,
)
SEISMIC = {"earthquake": {"vertical": "synthetic"}}
STEPS, DT = 400, 1e-3
N0, DELTA = 60e3, 0.05
Q0 = N0 * math.cos(DELTA)


def vertical_base(t: np.ndarray, earthquake: bool = True) -> xr.Dataset:
    table = {"bridge": BRIDGE, "train": {"vehicle": "pioneer-2d", "speed_kmh": 180.0}}
    if earthquake:
        table.update(SEISMIC)
    sc = validate_scenario(table)
    return xr.Dataset(
        {
            "midspan_uz": (("time", "span"), np.zeros((t.size, 2))),
            "midspan_ux": (("time", "span"), np.zeros((t.size, 2))),
            "deck_acceleration": (("time", "span"), np.zeros((t.size, 2))),
            "carbody_az": (("time", "car"), np.zeros((t.size, 2))),
        },
        coords={"time": t, "span": [1, 2], "car": [1, 2]},
        attrs={"scenario": sc.to_toml(), "complete": 1},
    )


def results(quotient_peak: float = 1.0, shift_peak: float = 60e3, earthquake: bool = True) -> xr.Dataset:
    """Car 2, wheelset 3: its right wheel flanges at 0.2 s with Y/Q = ``quotient_peak``; car 1,
    wheelset 2 carries a lateral creep on both wheels that gives it ΣY = ``shift_peak`` (left)
    over 0.1 ... 0.3 s (longer than the 2 m window at 50 m/s: its 2 m mean reaches it)."""
    t = np.arange(STEPS) * DT
    wheel = (STEPS, 2, 4, 2)
    pulse = np.exp(-(((t - 0.2) / 0.004) ** 2))  # 0.2 m of travel
    flange = np.zeros(wheel)
    # Y/Q = (N sin δ + F) / (N cos δ) on the flanging wheel
    flange[:, 1, 2, 1] = (quotient_peak * Q0 - N0 * math.sin(DELTA)) * pulse
    creep = np.zeros(wheel)
    plateau = ((t >= 0.1) & (t <= 0.3)).astype(float)
    # T on both wheels to the left: ΣY = Y_l - Y_r = -2 T cos δ (the wheels pull the track right)...
    # so T to the right gives ΣY to the left
    creep[:, 0, 1, :] = -(shift_peak / (2 * math.cos(DELTA))) * plateau[:, None]
    ay = np.zeros((STEPS, 2))
    ay[150, 1] = 1.2
    uy = np.zeros((STEPS, 2))
    uy[100, 1] = 3e-3
    h = histories(
        normal=N0,
        angle=DELTA,
        flange_force=flange,
        flange_contact=flange > 1.0,
        creep_lateral=creep,
        carbody_ay=ay,
        midspan_uy=uy,
        midspan_uy_rel=uy,
    )
    return dataset3d(h, force_filter_hz=1e6, base=vertical_base(t, earthquake))


def test_metrics_of_a_3d_run():
    m = compute_metrics(results(1.1, 60e3))
    assert m.peak_derailment_quotient.dims == ("car", "wheel", "side")
    assert float(m.peak_derailment_quotient.sel(car=2, wheel=3, side="right")) == pytest.approx(1.1, rel=1e-6)
    assert float(m.peak_derailment_quotient_time.sel(car=2, wheel=3, side="right")) == pytest.approx(0.2)
    untouched = float(m.peak_derailment_quotient.sel(car=1, wheel=1, side="left"))
    assert untouched == pytest.approx(math.tan(DELTA), rel=1e-12)
    assert float(m.peak_axle_lateral_force.sel(car=1, wheel=2)) == pytest.approx(60e3, rel=1e-12)
    assert float(m.peak_axle_lateral_force_2m.sel(car=1, wheel=2)) == pytest.approx(60e3, rel=1e-12)
    np.testing.assert_allclose(m.static_axle_load.values, 2 * Q0, rtol=1e-15)
    assert m.flange_contacts.sel(car=2, wheel=3, side="right").item() == 1
    assert int(m.flange_contacts.sum()) == 1
    assert m.max_unloading_ratio.dims == ("car", "wheel", "side")
    # the normal forces never change: only the lateral creep to the right on car 1, wheelset 2 turns
    # into a vertical component, -T sin δ on the left wheel (unloaded), +T sin δ on the right
    creep = 60e3 / (2 * math.cos(DELTA))
    ratio = m.max_unloading_ratio.values.copy()
    assert ratio[0, 1, 0] == pytest.approx(creep * math.sin(DELTA) / Q0, rel=1e-12)
    ratio[0, 1, 0] = 0.0
    assert np.abs(ratio).max() < 1e-12
    assert float(m.peak_carbody_ay.sel(car=2)) == 1.2 and float(m.peak_carbody_ay_time.sel(car=2)) == 0.15
    assert float(m.peak_midspan_uy.sel(span=2)) == 3e-3 and float(m.peak_midspan_uy_rel.sel(span=2)) == 3e-3


def rows_of(ds: xr.Dataset, **options) -> dict[str, object]:
    m = compute_metrics(ds)
    rows = en1990_checks(
        m, table={**SEISMIC, "contact": {"normal": "bilateral"}}, options=CheckOptions(**options)
    )
    return {r.name.split(" <=")[0].split(" (")[0]: r for r in rows}


@pytest.mark.parametrize(("quotient", "passed"), [(NADAL_LIMIT - 0.01, True), (NADAL_LIMIT + 0.01, False)])
def test_nadal_row_passes_and_fails_at_the_limit(quotient, passed):
    rows = rows_of(results(quotient_peak=quotient, shift_peak=1e3))
    row = rows["derailment quotient Y/Q"]
    assert row.value == pytest.approx(quotient, rel=1e-6) and row.limit == 1.34
    assert row.passed is passed and row.where == "car 2, wheel 3, side right"
    assert row.when == pytest.approx(0.2)
    # the 2 m mean of the short flange pulse stays below 0.8
    assert rows["derailment quotient"].passed is True


@pytest.mark.parametrize("alpha", [1.0, 0.85])
@pytest.mark.parametrize(("factor", "passed"), [(0.999, True), (1.001, False)])
def test_prudhomme_row_at_the_limit_of_the_wheelset(alpha, factor, passed):
    limit = alpha * (10e3 + 2 * Q0 / 3)  # α (10 + P0/3) kN, P0 = 2 Q0
    rows = rows_of(results(quotient_peak=0.3, shift_peak=factor * limit), prudhomme_alpha=alpha)
    row = rows["track-shift force"]
    assert row.name.startswith("track-shift force (sum Y)_2m <= alpha (10 + P0/3) kN")
    assert row.limit == pytest.approx(limit, rel=1e-12)
    assert row.value == pytest.approx(factor * limit, rel=1e-9)
    assert row.passed is passed and row.where == "car 1, wheel 2"


def test_carbody_lateral_acceleration_row():
    info = rows_of(results())["car-body lateral acceleration"]
    assert info.passed is None and info.value == 1.2 and info.limit is None
    assert rows_of(results(), carbody_ay_limit=1.0)["car-body lateral acceleration"].passed is False
    assert rows_of(results(), carbody_ay_limit=1.5)["car-body lateral acceleration"].passed is True
    flange = rows_of(results())["flange contacts"]
    assert flange.value == 1.0 and flange.where == "car 2, wheel 3, side right"


def test_unloading_row_reads_every_wheel_of_a_3d_run():
    ds = results()
    unloaded = ds["unloading_ratio"].copy()
    ds = ds.copy()
    ds["contact_force_filtered"] = ds["contact_force_filtered"].where(
        ~((ds.time == 0.25) & (ds.car == 1) & (ds.wheel == 4) & (ds.side == "left")), 0.1 * Q0
    )
    assert unloaded.dims == ("time", "car", "wheel", "side")
    row = rows_of(ds)["wheel unloading dP/P"]
    assert row.value == pytest.approx(0.9, rel=1e-12) and row.passed is False
    assert row.where == "car 1, wheel 4, side left"


def test_a_2d_run_has_no_lateral_metrics_or_rows():
    t = np.arange(STEPS) * DT
    base = vertical_base(t)
    f = np.full((STEPS, 2, 4), Q0)
    base["contact_force"] = (("time", "car", "wheel"), f)
    base["contact_force_filtered"] = (("time", "car", "wheel"), f)
    base = base.assign_coords(wheel=[1, 2, 3, 4])
    m = compute_metrics(base)
    assert not set(LATERAL_METRICS) & set(m.data_vars) and "side" not in m.dims
    rows = en1990_checks(m, table={**SEISMIC, "contact": {"normal": "bilateral"}})
    names = " ".join(r.name for r in rows)
    for word in ("derailment", "track-shift", "lateral", "flange contacts"):
        assert word not in names


def test_a_sweep_part_keeps_the_3d_metrics(tmp_path: Path):
    m = compute_metrics(results())
    path = write_part(m, tmp_path / "part.nc")
    back = _read_part(path)
    assert back is not None
    for name in LATERAL_METRICS:
        if name in ("peak_pier_top_uy", "peak_pier_top_uy_rel", "peak_track_twist"):
            continue  # no piers and no deck_twist in these hand-made results
        assert name in back, name
    assert back["side"].values.astype(str).tolist() == ["left", "right"]
    np.testing.assert_allclose(back.peak_derailment_quotient.values, m.peak_derailment_quotient.values)


def test_svbi_metrics_and_check_of_a_3d_results_file(tmp_path: Path):
    from typer.testing import CliRunner

    from svbi.runtime.cli.app import _register, app
    from svbi.runtime.run.results import write_netcdf

    if not app.registered_commands:
        _register()
    path = write_netcdf(results(quotient_peak=1.4, shift_peak=1e3), tmp_path / "r3d.nc")
    done = CliRunner().invoke(app, ["metrics", str(path)])
    assert done.exit_code == 0, done.output
    assert "peak_derailment_quotient" in done.output and "car 2, wheel 3, side right" in done.output
    done = CliRunner().invoke(app, ["check", str(path), "--prudhomme-alpha", "0.85"])
    assert done.exit_code == 3, done.output  # Y/Q 1.4 > 1.34
    assert "seismic set" in done.output and "Prud'homme, alpha = 0.85" in done.output
    line = next(x for x in done.output.splitlines() if x.startswith("derailment quotient Y/Q <= 1.34"))
    assert "1.4 " in line and "FAIL" in line
    done = CliRunner().invoke(app, ["check", str(path), "--prudhomme-alpha", "0"])
    assert done.exit_code == 2 and "--prudhomme-alpha must be greater than 0" in done.output


def test_metrics_peak_sum_y_is_the_summary_s_filtered_one():
    """A single-step 2 MN flange closing (a rigid contact's, impulse / dt) and a 40 kN flanging of
    another wheelset: the metric reads the filtered forces' ΣY, as the run's summary does."""
    steps, dt, every = 4000, 1e-4, 10
    t = np.arange(steps) * dt
    flange = np.zeros((steps, 2, 4, 2))
    flange[2000, 0, 1, 1] = 2e6
    flange[:, 1, 0, 0] = 40e3 * np.exp(-(((t - 0.2) / 0.025) ** 2))
    h = histories(steps=steps, dt=dt, flange_force=flange, flange_contact=flange > 1e3)
    ds = dataset3d(h, output_every=every, base=vertical_base(t[::every]))
    m = compute_metrics(ds)
    assert float(np.abs(ds.axle_lateral_force).max()) == pytest.approx(2e6, rel=1e-12)
    peak = m.peak_axle_lateral_force
    assert float(peak.sel(car=2, wheel=1)) == pytest.approx(ds.attrs["peak_axle_lateral_force"], rel=1e-12)
    assert float(np.abs(peak).max()) == pytest.approx(ds.attrs["peak_axle_lateral_force"], rel=1e-12)
