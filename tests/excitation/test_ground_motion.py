"""Record processing, the synthetic record and support motion (paper Eqs. 22-24)."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate
from scipy.optimize import brentq

from svbi.runtime.excitation import (
    HORIZONTAL,
    VERTICAL,
    Record,
    ground_motion,
    process_record,
    read_record,
    synthetic_motion,
    synthetic_record,
)
from svbi.runtime.excitation.processing import integrate as integrate_record

RECORDS = Path(__file__).resolve().parents[3] / "shared" / "data" / "ground-motions"


def burst_record(offset: float = 0.05, dt: float = 0.01, duration: float = 30.0) -> Record:
    """A decaying 2 Hz burst on a constant baseline error (m/s²): raw integration drifts."""
    t = np.arange(0.0, duration + dt / 2, dt)
    a = 3.0 * np.sin(2 * math.pi * 2.0 * t) * np.exp(-(((t - 8.0) / 4.0) ** 2)) + offset
    return Record("burst", dt, a, "test")


def test_raw_integration_drifts_but_corrected_does_not() -> None:
    rec = burst_record()
    v_raw, d_raw = integrate_record(rec.accel, rec.dt)
    assert abs(v_raw[-1]) > 1.0  # 0.05 m/s² over 30 s: the drift the correction must remove
    motion = process_record(rec)
    assert abs(motion.vel[-1]) < 1e-12 * np.abs(motion.vel).max()
    assert abs(motion.accel[-1]) < 1e-12 * np.abs(motion.accel).max()
    # No linear drift at the end: over the last 10 % the displacement is flat.
    tail = slice(int(0.9 * motion.disp.size), None)
    slope = np.polyfit(np.arange(motion.disp.size)[tail] * rec.dt, motion.disp[tail], 1)[0]
    assert abs(slope) < 2e-3 * np.abs(motion.vel).max()
    # After the record the ground stays at rest at its final displacement.
    q, qd, qdd = motion.evaluate(np.array([motion.end_time, motion.end_time + 5.0, 1e3]))
    np.testing.assert_array_equal(q, motion.disp[-1])
    assert np.all(qd == 0.0) and np.all(qdd == 0.0)


def test_real_record_ends_at_rest() -> None:
    path = RECORDS / "RSN6_IMPVALL.I_I-ELC180.AT2"
    if not path.is_file():
        pytest.skip(f"El Centro record not found at {path} (../shared is absent)")
    motion = process_record(read_record(path), arrival=1.0)
    assert abs(motion.vel[-1]) < 1e-12 * np.abs(motion.vel).max()
    # No drift: over the last 10 % the mean velocity is small (measured 0.5 % of the peak).
    tail = motion.vel[int(0.9 * motion.vel.size) :]
    assert abs(tail.mean()) < 0.02 * np.abs(motion.vel).max()
    assert motion.pga / 9.81 == pytest.approx(0.281, abs=0.005)  # the processing keeps the PGA


def test_q_qd_qdd_are_consistent() -> None:
    motion = process_record(burst_record(), arrival=0.7)
    # Points inside sample intervals (the jerk jumps at the samples, where a central difference
    # of q' would straddle the kink), before the arrival and after the end of the record.
    rng = np.random.default_rng(1)
    k = rng.integers(0, motion.accel.size - 1, 400)
    inside = 0.7 + (k + rng.uniform(0.1, 0.9, k.size)) * motion.dt
    t = np.concatenate([inside, [0.3, motion.end_time + 0.5]])
    h = 1e-5
    q, qd, qdd = motion.evaluate(t)
    q_p, qd_p, _ = motion.evaluate(t + h)
    q_m, qd_m, _ = motion.evaluate(t - h)
    np.testing.assert_allclose((q_p - q_m) / (2 * h), qd, atol=1e-7 * np.abs(motion.vel).max())
    np.testing.assert_allclose((qd_p - qd_m) / (2 * h), qdd, atol=1e-6 * np.abs(motion.accel).max())
    # q'' is the processed acceleration itself at the samples ...
    k = np.arange(0, motion.accel.size, 37)
    np.testing.assert_allclose(motion.evaluate(0.7 + k * motion.dt)[2], motion.accel[k], atol=1e-12)
    # ... and q is the double integral of q'' (quadrature on a fine grid, independent of the code).
    tt = np.linspace(0.7, 0.7 + 12.0, 120001)
    _, qd_f, qdd_f = motion.evaluate(tt)
    vel = integrate.cumulative_trapezoid(qdd_f, tt, initial=0.0)
    disp = integrate.cumulative_trapezoid(qd_f, tt, initial=0.0)
    np.testing.assert_allclose(vel, qd_f, atol=1e-6 * np.abs(qd_f).max())
    np.testing.assert_allclose(disp, motion.evaluate(tt)[0], atol=1e-6 * np.abs(disp).max())


def test_smooth_onset_at_arrival() -> None:
    motion = process_record(burst_record(), arrival=2.0)
    for v in motion.evaluate(np.array([0.0, 1.0, 2.0])):
        assert np.all(v == 0.0)
    # Just after the arrival q'', q' and q grow like s, s² and s³ (a C2 onset, no jump).
    q, qd, qdd = motion.evaluate(2.0 + np.array([1e-5, 1e-6]))
    assert qdd[0] != 0.0
    np.testing.assert_allclose([qdd[1] / qdd[0], qd[1] / qd[0], q[1] / q[0]], [1e-1, 1e-2, 1e-3], rtol=1e-3)


def test_scaling() -> None:
    rec = burst_record()
    base = process_record(rec)
    np.testing.assert_allclose(process_record(rec, scale=2.0).accel, 2.0 * base.accel, rtol=1e-12)
    assert process_record(rec, target_pga=4.0).pga == pytest.approx(4.0, rel=1e-12)
    with pytest.raises(ValueError, match="arrival"):
        process_record(rec, arrival=-1.0)


def test_synthetic_reproducible_from_seed() -> None:
    a = synthetic_record("vertical", seed=4)
    b = synthetic_record("vertical", seed=4)
    c = synthetic_record("vertical", seed=5)
    h = synthetic_record("horizontal", seed=4)
    np.testing.assert_array_equal(a.accel, b.accel)
    assert np.abs(a.accel - c.accel).max() > 0.1
    assert np.abs(a.accel[: h.accel.size] - h.accel).max() > 0.1
    assert a.dt == 0.005 and a.duration == pytest.approx(20.0)


def test_synthetic_pga_documented() -> None:
    g = 9.81
    assert synthetic_motion("horizontal").pga == pytest.approx(0.35 * g, rel=1e-12)
    assert synthetic_motion("longitudinal").pga == pytest.approx(0.35 * g, rel=1e-12)
    assert synthetic_motion("vertical").pga == pytest.approx(2 / 3 * 0.35 * g, rel=1e-12)
    assert synthetic_motion("vertical", scale=0.5).pga == pytest.approx(1 / 3 * 0.35 * g, rel=1e-12)


def clough_penzien(f: np.ndarray, wg: float, zg: float, wf: float, zf: float) -> np.ndarray:
    """Clough-Penzien acceleration PSD shape, written out independently of the code."""
    w = 2 * np.pi * f
    kt = (1 + 4 * zg**2 * (w / wg) ** 2) / ((1 - (w / wg) ** 2) ** 2 + 4 * zg**2 * (w / wg) ** 2)
    hp = (w / wf) ** 4 / ((1 - (w / wf) ** 2) ** 2 + 4 * zf**2 * (w / wf) ** 2)
    return kt * hp


@pytest.mark.parametrize(
    ("component", "params"),
    [("horizontal", (15.0, 0.6, 1.5, 0.6)), ("vertical", (25.0, 0.6, 2.5, 0.6))],
)
def test_synthetic_frequency_content(component: str, params: tuple[float, ...]) -> None:
    """Median and centroid frequency of the energy spectrum match the Clough-Penzien target.

    Over ten seeds the sample median scatters by about ±20 % and the centroid by ±12 % around the
    target; the mean of four seeds is held to 10 %.
    """
    nyquist = 0.5 / 0.005
    total = integrate.quad(clough_penzien, 0, nyquist, args=params, limit=400)[0]
    centroid = integrate.quad(lambda f: f * clough_penzien(f, *params), 0, nyquist, limit=400)[0] / total

    def below(f: float) -> float:
        return integrate.quad(clough_penzien, 0, f, args=params, limit=400)[0] - 0.5 * total

    median = brentq(below, 0.01, nyquist)
    medians, centroids = [], []
    for seed in range(1, 5):
        a = synthetic_motion(component, seed).accel
        energy = np.abs(np.fft.rfft(a)) ** 2
        f = np.fft.rfftfreq(a.size, 0.005)
        cum = np.cumsum(energy)
        medians.append(f[np.searchsorted(cum, 0.5 * cum[-1])])
        centroids.append((f * energy).sum() / energy.sum())
    assert np.mean(medians) == pytest.approx(median, rel=0.10)
    assert np.mean(centroids) == pytest.approx(centroid, rel=0.10)


def test_vertical_is_richer_in_high_frequencies() -> None:
    assert VERTICAL.omega_g > HORIZONTAL.omega_g
    v, h = synthetic_motion("vertical").accel, synthetic_motion("horizontal").accel
    f = np.fft.rfftfreq(v.size, 0.005)
    centroid = [(f * np.abs(np.fft.rfft(a)) ** 2).sum() / (np.abs(np.fft.rfft(a)) ** 2).sum() for a in (v, h)]
    assert centroid[0] > 1.2 * centroid[1]


def test_infinite_apparent_velocity_equals_synchronous() -> None:
    t = np.linspace(0.0, 22.0, 2001)[:, None]
    x = np.array([0.0, 32.0, 64.0, 320.0, -40.0])
    sync = ground_motion(vertical="synthetic", longitudinal="synthetic", arrival=0.5)
    wave = ground_motion(
        vertical="synthetic", longitudinal="synthetic", arrival=0.5, apparent_velocity=math.inf
    )
    for comp in ("vertical", "longitudinal"):
        for a, b in zip(sync.motion(comp, t, x), wave.motion(comp, t, x), strict=True):
            assert a.shape == (2001, 5)
            np.testing.assert_array_equal(a, b)
        assert np.all(sync.motion(comp, t, x)[0][:, 0] == sync.motion(comp, t, x)[0][:, 3])


def test_wave_passage_delays_by_x_over_c() -> None:
    c = 800.0
    t = np.linspace(0.0, 22.0, 1501)[:, None]
    x = np.array([0.0, 32.0, 160.0, 320.0])
    sync = ground_motion(vertical="synthetic", arrival=0.5)
    wave = ground_motion(vertical="synthetic", arrival=0.5, apparent_velocity=c)
    got = wave.motion("vertical", t, x)
    ref = sync.motion("vertical", t - x / c, 0.0)
    for a, b in zip(got, ref, strict=True):
        np.testing.assert_array_equal(a, b)
    # The last support starts x/c later: still at rest just before then.
    q = wave.motion("vertical", np.array([0.5 + 320.0 / c]), np.array([320.0]))
    assert all(np.all(v == 0.0) for v in q)
    with pytest.raises(ValueError, match="before t = 0"):
        wave.motion("vertical", 1.0, np.array([-1000.0]))


def test_none_component_and_per_support_records() -> None:
    rec_a, rec_b = burst_record(0.0), burst_record(0.02)
    motion = ground_motion(vertical=[rec_a, rec_b], support_positions=[0.0, 32.0], arrival=0.3)
    t = np.linspace(0.0, 31.0, 301)[:, None]
    q = motion.motion("vertical", t, np.array([0.0, 32.0]))
    np.testing.assert_array_equal(q[0][:, 0], process_record(rec_a, arrival=0.3).evaluate(t[:, 0])[0])
    np.testing.assert_array_equal(q[0][:, 1], process_record(rec_b, arrival=0.3).evaluate(t[:, 0])[0])
    assert not motion.is_active("longitudinal")
    assert all(np.all(v == 0.0) for v in motion.motion("longitudinal", t, np.array([0.0, 32.0])))
    with pytest.raises(ValueError, match="asked at x"):
        motion.motion("vertical", 1.0, np.array([16.0]))
    with pytest.raises(ValueError, match="support positions"):
        ground_motion(vertical=[rec_a, rec_b], support_positions=[0.0])


def test_duration_checks() -> None:
    with pytest.warns(UserWarning, match="before the run ends"):
        ground_motion(vertical="synthetic", arrival=1.0, duration=30.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ground_motion(vertical="synthetic", arrival=1.0, duration=15.0)
    with pytest.raises(ValueError, match="never act"):
        ground_motion(vertical="synthetic", arrival=10.0, duration=8.0)
    with pytest.raises(ValueError, match="arrival"):
        ground_motion(vertical="synthetic", arrival=-0.5)
    with pytest.raises(ValueError, match="synthetic"):
        ground_motion(vertical="no-such-file.AT2")
