"""Engineering metrics (``svbi metrics``) and EN 1990 checks (``svbi check``) against independent truth.

* the deck acceleration the loop records obeys Newmark's average-acceleration identity with the
  recorded displacement, ``(u[n+1] - 2 u[n] + u[n-1]) / dt² = (a[n+1] + 2 a[n] + a[n-1]) / 4``
  exactly (both backends);
* the span frequencies of the filter are the Euler-Bernoulli ones, f_n = n² π/(2 L²) √(EI/m);
* the EN 1990 filter keeps a 5 Hz wave and removes a 200 Hz one (synthetic results);
* the unloading ratio and the minimum filtered force of a synthetic force history;
* ``svbi check``: exit 0 when the limits hold, 3 when the deck acceleration of a span at resonance
  exceeds 3.5 m/s² (and not 5 m/s² for direct fastening when it lies between), 2 on bad input.
"""

from __future__ import annotations

import math
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import svbi
from svbi.runtime.run.results import write_netcdf
from svbi.runtime.scenario.schema import validate_scenario
from svbi.runtime.study.en1990 import en1990_checks
from svbi.runtime.study.metrics import compute_metrics, span_frequencies

BRIDGE = dict(
    spans=1,
    span_length=20.0,
    mass_per_length=15.0e3,
    youngs_modulus=35.0e9,
    area=6.0,
    second_moment=1.5,
    elements_per_span=8,
)


def hslm_scenario(speed_kmh: float, backend: str = "c", dt: float = 1e-3, **bridge: float):
    return validate_scenario(
        {
            "bridge": {**BRIDGE, **bridge},
            "train": {"vehicle": "moving-load", "hslm": "A4", "speed_kmh": speed_kmh},
            "solver": {"time_step": dt, "output_every": 1, "backend": backend},
        }
    )


def run(sc):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return svbi.simulate(sc)


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_deck_acceleration_is_newmarks_acceleration_of_the_midspan(backend):
    ds = run(_short(backend))
    u = ds.midspan_uz.values[:, 0]
    a = ds.deck_acceleration.values[:, 0]
    dt = float(np.diff(ds.time.values).mean())
    lhs = (u[2:] - 2 * u[1:-1] + u[:-2]) / dt**2
    rhs = (a[2:] + 2 * a[1:-1] + a[:-2]) / 4
    assert np.abs(a).max() > 0.1
    np.testing.assert_allclose(lhs, rhs, rtol=0, atol=1e-6 * np.abs(a).max())


def _short(backend: str):
    sc = hslm_scenario(300.0, backend).to_dict()
    sc["solver"]["duration"] = 1.5
    return validate_scenario(sc)


def test_span_frequencies_are_euler_bernoulli():
    b = {**BRIDGE, "elements_per_span": 16}
    f = span_frequencies(b)
    f1 = math.pi / (2 * b["span_length"] ** 2) * math.sqrt(b["youngs_modulus"] * b["second_moment"] / 15.0e3)
    assert f.f1 == pytest.approx(f1, rel=1e-4)
    assert f.f3 == pytest.approx(9 * f1, rel=1e-3)
    assert f.cutoff_hz == pytest.approx(max(30.0, 1.5 * f.f1, f.f3))


def synthetic_results(
    acc: np.ndarray, force: np.ndarray, t: np.ndarray, vehicle: str = "pioneer-2d", earthquake: bool = False
):
    table = {"bridge": BRIDGE, "train": {"vehicle": vehicle, "speed_kmh": 100.0}}
    if earthquake:  # the deck acceleration is then the filtered midspan one (no modal envelope)
        table["earthquake"] = {"vertical": "synthetic"}
    sc = validate_scenario(table)
    f = force[:, None, None] * np.ones((1, 1, 4))
    return xr.Dataset(
        {
            "midspan_uz": (("time", "span"), np.zeros((t.size, 1))),
            "deck_acceleration": (("time", "span"), acc[:, None]),
            "contact_force": (("time", "car", "wheel"), f),
            "contact_force_filtered": (("time", "car", "wheel"), f),
            "carbody_az": (("time", "car"), 0.5 * np.sin(2 * np.pi * t)[:, None]),
        },
        coords={"time": t, "span": [1], "car": [1], "wheel": [1, 2, 3, 4]},
        attrs={"scenario": sc.to_toml(), "complete": 1},
    )


def test_deck_filter_keeps_5_hz_and_removes_200_hz():
    # a 200 Hz burst inside the run (the ends of a zero-phase filter keep their raw values: a run
    # starts at rest and ends in free vibration, within the pass band)
    t = np.arange(0, 4.0, 1e-3)
    burst = np.sin(np.pi * np.clip((t - 1.0) / 2.0, 0.0, 1.0)) ** 2
    acc = np.sin(2 * np.pi * 5 * t) + 5 * burst * np.sin(2 * np.pi * 200 * t)
    m = compute_metrics(synthetic_results(acc, np.full(t.size, 1e5), t, earthquake=True))
    assert m.attrs["deck_acceleration_cutoff_hz"] < 100
    assert float(m.peak_deck_acceleration[0]) == pytest.approx(1.0, abs=2e-3)


def test_deck_filter_is_scipys_and_imports_no_scipy_signal_once_designed(tmp_path: Path):
    """The EN 1990 deck filter runs through the compiled zero-phase filter with SciPy's cached
    design: SciPy's ``sosfiltfilt`` bit for bit (odd padding over ten periods of the cutoff), and a
    fresh process whose filter design is cached does not import ``scipy.signal`` (0.38 s, with
    ``scipy.stats``: a sweep worker's first run paid it)."""
    import scipy.signal as sig

    from svbi.runtime.run import force_filter as zero_phase
    from svbi.runtime.study.metrics import FILTER_ORDER, lowpass

    if not zero_phase.compiled():
        pytest.skip("no working C compiler: the metrics filter is SciPy's own")
    rng = np.random.default_rng(3)
    fs, fc = 1000.0, 37.5
    acc = rng.normal(size=(3001, 3))
    sos = sig.butter(FILTER_ORDER, fc, btype="low", fs=fs, output="sos")
    padlen = min(max(3 * (2 * len(sos) + 1), int(10 * fs / fc)), acc.shape[0] - 1)
    np.testing.assert_array_equal(lowpass(acc, fc, fs), sig.sosfiltfilt(sos, acc, axis=0, padlen=padlen))
    np.testing.assert_array_equal(lowpass(acc[:, 1], fc, fs), sig.sosfiltfilt(sos, acc[:, 1], padlen=padlen))
    probe = (
        "import sys, numpy as np\n"
        "from svbi.runtime.study.metrics import lowpass\n"
        f"lowpass(np.ones((3001, 2)), {fc!r}, {fs!r})\n"
        "print('scipy.signal' in sys.modules)\n"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert done.stdout.strip().splitlines()[-1] == "False", done.stderr


def test_unloading_ratio_and_minimum_force():
    t = np.arange(0, 1.0, 1e-3)
    force = 1e5 - 7e4 * np.exp(-(((t - 0.3) / 0.02) ** 2))  # dips to 30 kN at 0.3 s
    m = compute_metrics(synthetic_results(np.zeros(t.size), force, t))
    assert float(m.max_unloading_ratio[0, 2]) == pytest.approx(0.7, rel=1e-9)
    assert float(m.max_unloading_ratio_time[0, 2]) == pytest.approx(0.3, abs=1e-9)
    assert float(m.min_contact_force_filtered[0, 0]) == pytest.approx(3e4, rel=1e-9)
    assert float(m.peak_carbody_az[0]) == pytest.approx(0.5, rel=1e-5)
    rows = {r.name: r for r in en1990_checks(m)}  # no scenario given: the traffic set
    assert rows["wheel unloading dP/P <= 0.6"].passed is False
    assert "wheel unloading dP/P <= 0.8 (transient)" not in rows
    comfort = rows["comfort, car-body acceleration b_v (acceptable, A2.4.4.3.1, Table A2.9)"]
    assert comfort.passed is True and comfort.note.endswith("very-good")
    seismic = {r.name: r for r in en1990_checks(m, table={"earthquake": {"vertical": "synthetic"}})}
    assert seismic["wheel unloading dP/P <= 0.8 (transient)"].passed is True
    assert "wheel unloading dP/P <= 0.6" not in seismic


def test_unilateral_contact_metrics_when_present():
    t = np.arange(0, 1.0, 0.1)
    ds = synthetic_results(np.zeros(t.size), np.full(t.size, 1e5), t)
    state = np.ones((t.size, 1, 4), dtype=np.int8)
    state[3:5, 0, 1] = 0
    state[7, 0, 1] = 0
    uplift = np.zeros((t.size, 1, 4))
    uplift[4, 0, 1] = 2e-3
    ds["contact_state"] = (("time", "car", "wheel"), state)
    ds["wheel_uplift"] = (("time", "car", "wheel"), uplift)
    m = compute_metrics(ds)
    assert m.lift_offs.values.tolist() == [[0, 2, 0, 0]]
    assert float(m.peak_uplift[0, 1]) == 2e-3 and float(m.peak_uplift_time[0, 1]) == pytest.approx(0.4)
    # lifted over samples 3-4 (back at 0.5 s) and 7: the longest loss is 0.3 ... 0.5 s
    assert float(m.longest_contact_loss[0, 1]) == pytest.approx(0.2)
    assert float(m.longest_contact_loss_time[0, 1]) == pytest.approx(0.3)
    assert float(m.longest_contact_loss[0, 0]) == 0.0
    assert "lift_offs" not in compute_metrics(synthetic_results(np.zeros(t.size), np.full(t.size, 1e5), t))


def _svbi(*args: str) -> subprocess.CompletedProcess:
    """The command line in this process (typer's runner): exit status, stdout and stderr."""
    from typer.testing import CliRunner

    from svbi.runtime.cli.app import _register, app

    if not app.registered_commands:
        _register()
    r = CliRunner().invoke(app, list(args))
    return subprocess.CompletedProcess(args, r.exit_code, r.stdout, r.stderr)


def test_check_exit_status(tmp_path: Path):
    f1 = span_frequencies(BRIDGE).f1
    # HSLM-A4 (D = 21 m) at its second resonance f1 D / 2, then well away from any resonance
    resonant = run(hslm_scenario(3.6 * f1 * 21.0 / 2))
    calm = run(hslm_scenario(120.0))
    peak = float(compute_metrics(resonant).peak_deck_acceleration.max())
    assert 3.5 < peak < 5.0, peak  # the span is chosen so: above ballasted, below direct fastening
    write_netcdf(resonant, tmp_path / "res.nc")
    write_netcdf(calm, tmp_path / "calm.nc")
    r = _svbi("check", str(tmp_path / "res.nc"))
    assert r.returncode == 3, r.stdout + r.stderr
    assert "FAIL" in r.stdout and "deck acceleration" in r.stdout
    assert _svbi("check", str(tmp_path / "res.nc"), "--track-form", "direct").returncode == 0
    r = _svbi("check", str(tmp_path / "calm.nc"))
    assert r.returncode == 0, r.stdout + r.stderr
    assert _svbi("check", str(tmp_path / "calm.nc"), "--track-form", "slab").returncode == 2
    assert _svbi("check", str(tmp_path / "missing.nc")).returncode == 2
    r = _svbi("metrics", str(tmp_path / "calm.nc"))
    assert r.returncode == 0 and "peak_deck_acceleration" in r.stdout


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_end_rotation_of_a_slow_point_load_is_the_static_one(backend):
    """A 100 kN load crossing slowly (quasi-static, v / (2 f1 L) = 0.02): the span's end rotations
    against beam theory, θ_A(a) = -P b (L² - b²) / (6 EI L) with b = L - a the load's distance to
    the right support (θ = dw/dx, z up), and θ_B(a) = P a (L² - a²) / (6 EI L)."""
    L, P, v = BRIDGE["span_length"], 1.0e5, 5.0
    ei = BRIDGE["youngs_modulus"] * BRIDGE["second_moment"]
    sc = validate_scenario(
        {
            "bridge": {**BRIDGE, "spans": 2},
            "train": {
                "vehicle": "moving-load",
                "speed": v,
                "parameters": {"axle_loads": [P], "axle_offsets": [0.0]},
            },
            "solver": {"time_step": 2e-3, "output_every": 5, "backend": backend, "duration": 2 * L / v},
        }
    )
    ds = run(sc)
    a = v * ds.time.values  # load position from the first support
    on1 = (a > 0.1 * L) & (a < 0.9 * L)
    b = L - a[on1]
    theta_a = -P * b * (L**2 - b**2) / (6 * ei * L)
    theta_b = P * a[on1] * (L**2 - a[on1] ** 2) / (6 * ei * L)
    rot = ds.end_rotation.sel(span=1)
    peak = np.abs(theta_a).max()
    np.testing.assert_allclose(rot.sel(end="left").values[on1], theta_a, atol=0.05 * peak)
    np.testing.assert_allclose(rot.sel(end="right").values[on1], theta_b, atol=0.05 * peak)
    m = compute_metrics(ds)
    # at the joint the load on span 2 turns span 2's left end the other way: the joint angle peaks
    # when the load is at L/√3 from either side of it, P L² / (9√3 EI)
    assert float(m.peak_joint_rotation[0]) == pytest.approx(P * L**2 / (9 * math.sqrt(3) * ei), rel=0.05)
    rows = {r.name: r for r in en1990_checks(m, moving_load=True)}
    assert rows["end rotation at abutments (A2.4.4.2.3(2))"].passed is True
    assert rows["rotation between decks (A2.4.4.2.3(2))"].where == "joint 1"


def test_the_metrics_text_gives_no_time_for_a_wheel_that_never_lifted() -> None:
    """``longest_contact_loss`` of a run whose wheels never lifted is 0 s with no time (NaN in the
    dataset): `svbi metrics` prints no "t = nan"; a wheel that lifted gives its time."""
    from svbi.runtime.study.metrics import metrics_text

    dims = ("car", "wheel", "side")
    coords = {"car": [1], "wheel": [1, 2], "side": ["left", "right"]}
    never = xr.Dataset(
        {
            "longest_contact_loss": (dims, np.zeros((1, 2, 2))),
            "longest_contact_loss_time": (dims, np.full((1, 2, 2), np.nan)),
        },
        coords=coords,
    )
    text = metrics_text(never)
    assert "nan" not in text, text
    assert "longest_contact_loss         0 s (car 1, wheel 1, side left)" in text, text
    lifted = never.copy(deep=True)
    lifted["longest_contact_loss"][0, 1, 0] = 0.012
    lifted["longest_contact_loss_time"][0, 1, 0] = 1.5
    assert "0.012 s (car 1, wheel 2, side left at t = 1.5 s)" in metrics_text(lifted)
