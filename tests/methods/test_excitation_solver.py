"""Excitations in the solver: ground motion at the supports, rail irregularity, HSLM trains.

Independent truths:

* a simply supported span (and its fixed-free axial bar) under a uniform base motion: the
  relative response is the modal solution of the base-excited beam, ``Y_n'' + 2 zeta_n w_n Y_n' +
  w_n^2 Y_n = -Gamma_n q''(t)``, integrated exactly for the piecewise-linear record acceleration
  (``scipy.signal.lsim``, first-order hold);
* a wave of apparent velocity c reaches the support at x after x / c, and identical spans then
  respond identically, delayed;
* a sprung mass on rigid (infinitely stiff) track follows the rail profile: its contact force is
  the closed form of a base-excited oscillator, integrated with ``solve_ivp``;
* an HSLM train on one span is the superposition of its single axles, each Fryba's series while on
  the span and free modal vibration after it.

"No train" is a moving-load train that never reaches the bridge (``start_position`` far behind):
it puts no load on the bridge and needs no ground under its axles.
"""

from __future__ import annotations

import warnings
from functools import cache
from pathlib import Path

import numpy as np
import pytest
import scipy.signal as sig
from conftest import c_compiler_works
from scipy.integrate import solve_ivp

import svbi
from svbi.examples import paper_section
from svbi.runtime.excitation import make_irregularity, process_record, read_record, synthetic_record
from svbi.runtime.excitation.synthetic import synthetic_motion
from svbi.runtime.model.hslm import hslm_train
from svbi.runtime.model.system import FunctionGround
from svbi.runtime.run.simulate import build_model
from svbi.runtime.scenario.schema import ScenarioError, validate_scenario

L, MU, E, A, IY = paper_section()
ZETA = 0.02


def bridge(spans: int = 1, elements: int = 8, **kw: float) -> dict:
    data = dict(
        spans=spans,
        span_length=L,
        mass_per_length=MU,
        youngs_modulus=E,
        area=A,
        second_moment=IY,
        damping_ratio=ZETA,
        elements_per_span=elements,
    )
    data.update(kw)
    return data


def quake_only(
    earthquake: dict, spans: int = 1, dt: float = 1e-3, duration: float = 3.0, every: int = 1, **bk
):
    """A scenario whose train never reaches the bridge: only the ground moves it."""
    return validate_scenario(
        {
            "bridge": bridge(spans, **bk),
            "train": dict(vehicle="moving-load", speed=10.0, start_position=-1000.0),
            "earthquake": earthquake,
            "solver": dict(backend="numpy", time_step=dt, duration=duration, output_every=every),
        }
    )


def run(scenario):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # records longer than the run
        return svbi.simulate(scenario)


# --------------------------------------------------------------------------------------------------
# uniform ground motion


def newmark_gap_bound(dt: float, motions) -> float:
    """Support gap allowed by Newmark's truncation of a piecewise-cubic q(t): 0.5 dt^3 max|q'''|.

    Newmark's average acceleration is exact for q quadratic in t; for a cubic its acceleration
    lags by q''' dt / 3 per step, which the stabilised constraint turns into a gap of order
    q''' dt^3 / 10 (kappa = zeta = 1).
    """
    return 0.5 * dt**3 * max(np.abs(np.diff(h.accel)).max() / h.dt for h in motions)


def modal_relative(
    t: np.ndarray, qdd, omegas: np.ndarray, gammas: np.ndarray, shapes: np.ndarray, alpha, beta
):
    """Sum of modal responses ``shape_n Y_n(t)`` of a base-excited structure (Rayleigh damping)."""
    u = qdd(t)
    out = np.zeros_like(t)
    for w, gam, phi in zip(omegas, gammas, shapes, strict=True):
        c = alpha + beta * w * w
        system = sig.lti([[0.0, 1.0], [-w * w, -c]], [[0.0], [-gam]], [[1.0, 0.0]], [[0.0]])
        _, y, _ = sig.lsim(system, u, t)
        out += phi * y
    return out


def rayleigh(w1: float, w2: float, zeta: float) -> tuple[float, float]:
    return 2 * zeta * w1 * w2 / (w1 + w2), 2 * zeta / (w1 + w2)


@cache
def uniform_run(spans: int = 2, youngs: float = E):
    eq = dict(vertical="synthetic", longitudinal="synthetic", arrival=0.1, seed=2)
    return run(quake_only(eq, spans=spans, dt=5e-4, duration=3.0, every=2, youngs_modulus=youngs))


def test_uniform_ground_supports_follow_q_and_spans_respond_as_base_excited_beams():
    ds = uniform_run()
    t = ds.time.values
    qz, qx = ds.ground_uz.values, ds.ground_ux.values
    assert ds.ground_uz.dims == ("time",)
    assert np.abs(qz).max() > 0.01 and np.abs(qx).max() > 0.01
    # the recorded ground is the processed record (independent evaluation)
    vert = synthetic_motion("vertical", 2, arrival=0.1)
    lon = synthetic_motion("longitudinal", 2, arrival=0.1)
    # every support follows its target up to Newmark's truncation of the cubic q(t), O(dt^3 q''')
    # (measured 0.17 dt^3 max|q'''|, 4.7e-9 m); a quadratic q is followed to round-off (next test)
    assert float(np.abs(ds.gap_support).max()) < newmark_gap_bound(5e-4, [vert, lon])
    np.testing.assert_allclose(qz, vert.evaluate(t)[0], rtol=0, atol=1e-14)
    np.testing.assert_allclose(qx, lon.evaluate(t)[0], rtol=0, atol=1e-14)

    # vertical: midspan minus ground against the modal solution of a simply supported beam
    n = np.arange(1, 8)
    wb = (n * np.pi / L) ** 2 * np.sqrt(E * IY / MU)
    alpha, beta = rayleigh(wb[0], wb[1], ZETA)
    odd = n % 2 == 1
    gam = 4.0 / (n[odd] * np.pi)
    shape = np.sin(n[odd] * np.pi / 2)
    tt = np.arange(0.0, 3.0 + 1e-9, 5e-4)
    ref_z = np.interp(
        t, tt, modal_relative(tt, lambda s: vert.evaluate(s)[2], wb[odd], gam, shape, alpha, beta)
    )
    rel_z = ds.midspan_uz.values - qz[:, None]
    for span in range(2):
        err = np.abs(rel_z[:, span] - ref_z).max() / np.abs(ref_z).max()
        assert err < 5e-4, err  # measured 7.1e-5 (8 elements, dt = 5e-4 s)
    # the same record moves both spans identically
    assert np.abs(rel_z[:, 0] - rel_z[:, 1]).max() < 1e-10 * np.abs(ref_z).max()

    # longitudinal: the fixed-free bar (fixed bearing at the left end) under its base motion
    m = np.arange(1, 8)
    wa = (2 * m - 1) * np.pi / (2 * L) * np.sqrt(E * A / MU)
    gam_a = 4.0 / ((2 * m - 1) * np.pi)
    shape_a = np.sin((2 * m - 1) * np.pi / 4)
    ref_x = np.interp(
        t, tt, modal_relative(tt, lambda s: lon.evaluate(s)[2], wa, gam_a, shape_a, alpha, beta)
    )
    rel_x = ds.midspan_ux.values[:, 0] - qx
    err = np.abs(rel_x - ref_x).max() / np.abs(ref_x).max()
    assert err < 2e-2, err  # measured 1.2 %: Newmark's period error on the 29 Hz axial mode


def test_supports_follow_a_quadratic_ground_motion_to_round_off():
    """Newmark's kinematics are exact for q quadratic in t, so the support gap is round-off."""
    sc = quake_only(dict(vertical="synthetic"), spans=2, dt=1e-3, duration=0.5)
    model = build_model(sc)

    def parabola(t, x, c=0.3):
        return c * t * t + 0 * x, 2 * c * t + 0 * x, 2 * c + 0 * x

    model.ground = FunctionGround(vertical=parabola, longitudinal=lambda t, x: parabola(t, x, -0.2))
    ds = svbi.simulate(sc, model=model)
    q = float(np.abs(ds.ground_uz).max())
    assert q > 0.07
    assert float(np.abs(ds.gap_support).max()) < 1e-13 * q


def newmark_target(history, t: np.ndarray, dt: float) -> np.ndarray:
    """The support target displacement (docs/method.md "Support targets"), computed here from the
    record's own evaluation: h = q - dt^2/4 q'' at t - dt, t, t + dt, then (h0 + 2 h1 + h2) / 4."""
    h = [(lambda q: q[0] - 0.25 * dt * dt * q[2])(history.evaluate(t + k * dt)) for k in (-1, 0, 1)]
    return 0.25 * (h[0] + 2.0 * h[1] + h[2])


def test_infinitely_stiff_span_moves_with_its_supports():
    """A rigid span (E x 1e10) is carried by its bearings: midspan = mean of the two vertical
    supports, axial = the fixed bearing; the supports are their Newmark targets less their gaps."""
    ds = uniform_run(spans=1, youngs=E * 1e10)
    qz, qx = ds.ground_uz.values, ds.ground_ux.values
    t = ds.time.values
    gap = ds.gap_support.values
    vertical = ds.support_component.values == "vertical"
    tz = newmark_target(synthetic_motion("vertical", 2, arrival=0.1), t, 5e-4)
    tx = newmark_target(synthetic_motion("longitudinal", 2, arrival=0.1), t, 5e-4)
    uz = tz - gap[:, vertical].mean(axis=1)
    ux = tx - gap[:, ~vertical][:, 0]
    assert np.abs(ds.midspan_uz.values[:, 0] - uz).max() < 1e-9 * np.abs(qz).max()
    assert np.abs(ds.midspan_ux.values[:, 0] - ux).max() < 1e-9 * np.abs(qx).max()
    assert np.abs(ds.midspan_uz.values[:, 0] - qz).max() < 1e-6 * np.abs(qz).max()


# --------------------------------------------------------------------------------------------------
# asynchronous ground motion


@cache
def wave_run(velocity: float | None):
    eq = dict(vertical="synthetic", longitudinal="synthetic", arrival=0.05, seed=3)
    if velocity is not None:
        eq["apparent_velocity"] = velocity
    return run(quake_only(eq, spans=3, dt=1e-3, duration=2.5, every=10))


def test_infinite_apparent_velocity_equals_synchronous():
    """1e12 m/s delays the last support by 1e-10 s: the difference is that delay times q', no more."""
    c = 1e12
    sync, fast = wave_run(None), wave_run(c)
    assert fast.ground_uz.dims == ("time", "support") and sync.ground_uz.dims == ("time",)
    delay = float(fast.support_x.max()) / c
    for comp, name in (("vertical", "uz"), ("longitudinal", "ux")):
        speed = np.abs(synthetic_motion(comp, 3, arrival=0.05).vel).max()
        bound = 2 * speed * delay + 1e-15
        assert float(np.abs(fast[f"ground_{name}"] - sync[f"ground_{name}"]).max()) < bound
        assert float(np.abs(fast[f"midspan_{name}"] - sync[f"midspan_{name}"]).max()) < bound


def test_wave_passage_delays_each_support_by_x_over_c():
    c = 320.0  # one span in 0.1 s = 10 stored rows
    sync, wave = wave_run(None), wave_run(c)
    rows = 10
    x = wave.support_x.values
    for comp in ("ground_uz", "ground_ux"):
        q0 = sync[comp].values
        for j, xj in enumerate(x):
            k = int(round(xj / L)) * rows
            got = wave[comp].values[k:, j]
            assert np.abs(got - q0[: q0.size - k]).max() < 1e-12 * np.abs(q0).max()
            assert np.all(wave[comp].values[:k, j] == 0.0) or k == 0
    motions = [synthetic_motion(comp, 3, arrival=0.05) for comp in ("vertical", "longitudinal")]
    assert float(np.abs(wave.gap_support).max()) < newmark_gap_bound(1e-3, motions)
    # identical spans, each excited like the first one, later by its distance over c
    mid = wave.midspan_uz.values
    for span in (1, 2):
        k = span * rows
        assert np.abs(mid[k:, span] - mid[: mid.shape[0] - k, 0]).max() < 1e-9 * np.abs(mid).max()


def write_record(path: Path, seed: int, scale: float = 1.0) -> Path:
    """A two-column record file (t in s, acceleration in g) made from a seeded synthetic record."""
    rec = synthetic_record("vertical", seed)
    t = np.arange(rec.accel.size) * rec.dt
    np.savetxt(path, np.column_stack([t, scale * rec.accel / 9.81]), fmt="%.10e")
    return path


def test_one_record_per_support(tmp_path: Path):
    files = [str(write_record(tmp_path / f"r{k}.txt", seed=k + 1)) for k in range(3)]
    eq = dict(vertical=files, arrival=0.05)
    sc = quake_only(eq, spans=2, dt=1e-3, duration=2.0, every=10)
    ds = run(sc)
    assert ds.ground_uz.dims == ("time", "support")
    t = ds.time.values
    line = np.rint(ds.support_x.values / L).astype(int)  # abutment or pier of each support
    own = [process_record(read_record(f), arrival=0.05).evaluate(t)[0] for f in files]
    for j, k in enumerate(line):
        np.testing.assert_allclose(ds.ground_uz.values[:, j], own[k], rtol=0, atol=1e-14)
    motions = [process_record(read_record(f), arrival=0.05) for f in files]
    assert float(np.abs(ds.gap_support).max()) < newmark_gap_bound(1e-3, motions)
    # the approach tracks follow the abutments: the first record before the bridge, the last after
    ground = build_model(sc).ground
    for x, k in ((-30.0, 0), (0.0, 0), (2 * L, 2), (2 * L + 40.0, 2)):
        q = ground.under(1.3, np.array([x]), 10.0)
        ref = process_record(read_record(files[k]), arrival=0.05).evaluate(1.3)
        np.testing.assert_allclose([v[0] for v in q], ref, rtol=0, atol=1e-15)
    # the same record everywhere is the synchronous motion
    same = run(
        quake_only(dict(vertical=[files[0]] * 3, arrival=0.05), spans=2, dt=1e-3, duration=2.0, every=10)
    )
    sync = run(quake_only(dict(vertical=files[0], arrival=0.05), spans=2, dt=1e-3, duration=2.0, every=10))
    assert float(np.abs(same.midspan_uz - sync.midspan_uz).max()) < 1e-12 * float(
        np.abs(sync.midspan_uz).max()
    )


# --------------------------------------------------------------------------------------------------
# rail irregularity


def sprung_on_rigid_track(dt: float = 2e-4):
    return validate_scenario(
        {
            "bridge": bridge(1, youngs_modulus=E * 1e5),
            "train": dict(vehicle="sprung-mass", speed_kmh=100.0),
            "track": dict(irregularity="german-high", seed=5, wavelength_min=2.0, wavelength_max=60.0),
            "contact": dict(creep=False),
            # the C loop: the same irregularity table and steps as NumPy (tests/backends)
            "solver": dict(backend="c", time_step=dt, output_every=5),
        }
    )


def test_irregularity_under_the_wheel_and_rigid_track_response():
    sc = sprung_on_rigid_track()
    ds = svbi.simulate(sc)
    assert ds.attrs["backend"] == ("c" if c_compiler_works() else "numpy")
    t = ds.time.values
    v = 100.0 / 3.6
    exact = make_irregularity("german-high", seed=5, length=L, wavelength_min=2.0, wavelength_max=60.0)
    r, _, r2 = exact.evaluate(v * t)
    sigma = np.sqrt(exact.variance)
    # the output is the profile at the wheel (the solver's table is within 1e-12 sigma of it)
    assert np.abs(ds.irregularity.values[:, 0, 0] - r).max() < 1e-10 * sigma
    assert np.abs(r).max() > sigma  # past the onset ramp, the profile is fully there
    # rigid track: the wheel rides the profile; like the supports, the gap is Newmark's truncation
    # of the non-polynomial path r(v t), O(dt^3 v^3 r''') (see newmark_gap_bound)
    x = np.linspace(0.0, v * t[-1], 200_001)
    r3 = np.gradient(exact.evaluate(x)[2], x)
    assert float(np.abs(ds.gap_bridge).max()) < 0.5 * 2e-4**3 * v**3 * np.abs(r3).max()
    # contact force of a base-excited sprung mass: P = (M + m) g + m w'' + M z'', M z'' = -k (z - w)
    M, m, k = 5750.0, 500.0, 1.595e6  # the sprung-mass topology's defaults
    static = (M + m) * 9.81 * L**3 / (48 * E * 1e5 * IY)  # the bridge barely moves (1.7e-9 m)
    assert float(np.abs(ds.midspan_uz).max()) < 2 * static

    def rhs(time, y):
        w = exact.evaluate(np.array([v * time]))[0][0]
        return [y[1], -k / M * (y[0] - w)]

    sol = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0], method="DOP853", rtol=1e-10, atol=1e-13, dense_output=True)
    z = sol.sol(t)[0]
    ref = (M + m) * 9.81 + m * v * v * r2 - k * (z - r)
    force = ds.contact_force.values[:, 0, 0]
    dynamic = np.abs(ref - (M + m) * 9.81).max()
    assert dynamic > 0.05 * (M + m) * 9.81  # the track really shakes the vehicle
    err = np.abs(force - ref).max() / dynamic
    assert err < 1e-4, err  # measured 8.4e-6 (dt = 2e-4 s)


# --------------------------------------------------------------------------------------------------
# HSLM


def fryba_superposition(t: np.ndarray, loads: np.ndarray, offsets: np.ndarray, v: float, modes: int = 60):
    """Midspan deflection (up positive) of an undamped simply supported span under moving axles."""
    n = np.arange(1, modes + 1)[:, None]
    wn = (n * np.pi / L) ** 2 * np.sqrt(E * IY / MU)
    om = n * np.pi * v / L
    T = L / v
    out = np.zeros_like(t)
    for P, off in zip(loads, offsets, strict=True):
        s = t - off / v
        amp = 2 * P / (MU * L) / (wn**2 - om**2)
        on = (s > 0) & (s <= T)
        y = -amp * (np.sin(om * s) - om / wn * np.sin(wn * s))
        yT = -amp * (np.sin(om * T) - om / wn * np.sin(wn * T))
        dyT = -amp * (om * np.cos(om * T) - om * np.cos(wn * T))
        after = s > T
        y_free = yT * np.cos(wn * (s - T)) + dyT / wn * np.sin(wn * (s - T))
        y = np.where(on, y, np.where(after, y_free, 0.0))
        out += np.sum(y * np.sin(n * np.pi / 2), axis=0)
    return out


def test_hslm_a1_is_the_superposition_of_single_axles():
    v = 200.0 / 3.6
    sc = validate_scenario(
        {
            "bridge": bridge(1, elements=16, damping_ratio=0.0),
            "train": dict(vehicle="moving-load", hslm="A1", speed=v),
            # the C loop: HSLM trains in C = NumPy (tests/backends/test_c_backend.py)
            "solver": dict(backend="c", time_step=5e-4, output_every=4),
        }
    )
    ds = svbi.simulate(sc)
    assert ds.attrs["backend"] == ("c" if c_compiler_works() else "numpy")
    loads, offsets = hslm_train("A1")
    assert ds.sizes["wheel"] == 50  # the whole train, until its last axle has left the span:
    assert ds.attrs["steps"] * 5e-4 >= (L + offsets[-1]) / v
    ref = fryba_superposition(ds.time.values, loads, offsets, v)
    w = ds.midspan_uz.values[:, 0]
    err = np.abs(w - ref).max() / np.abs(ref).max()
    assert err < 5e-3, err  # measured 1.1e-3 (16 elements, dt = 5e-4 s)


# --------------------------------------------------------------------------------------------------
# bad input


def test_bad_irregularity_band_names_the_key():
    with pytest.raises(ScenarioError, match=r"track\.wavelength_min"):
        validate_scenario(
            {
                "bridge": bridge(),
                "train": dict(vehicle="moving-load", speed=10.0),
                "track": dict(irregularity="german-low", wavelength_min=80.0, wavelength_max=80.0),
            }
        )


def test_record_timing_errors_and_warnings_name_the_file(tmp_path: Path):
    short = tmp_path / "short.txt"
    rec = synthetic_record("vertical", 1)
    np.savetxt(short, rec.accel[:601] / 9.81)  # one column, 3 s at 0.005 s
    # the record would start only after the run ends: an error naming the file
    with pytest.raises(ScenarioError, match="short.txt") as err:
        quake_only(dict(vertical=str(short), record_dt=0.005, arrival=2.5), duration=2.0)
    assert "earthquake.arrival" in str(err.value)
    sc = validate_scenario(
        {
            "bridge": bridge(),
            "train": dict(vehicle="moving-load", speed=1.0, start_position=-10.0),
            "earthquake": dict(vertical=str(short), record_dt=0.005, arrival=60.0),
            "solver": dict(backend="numpy", time_step=1e-3),
        }
    )
    with pytest.raises(ValueError, match="short.txt"):
        build_model(sc)  # default duration: until the axle leaves, 42 s
    # a one-column record needs its time step
    with pytest.raises(ValueError, match="short.txt"):
        build_model(quake_only(dict(vertical=str(short)), duration=2.0))
    # the record ends before the run: a warning naming the file
    with pytest.warns(UserWarning, match="short.txt"):
        build_model(quake_only(dict(vertical=str(short), record_dt=0.005, arrival=0.5), duration=4.0))


def test_a_wave_must_not_reach_the_standing_train_before_t0():
    data = {
        "bridge": bridge(),
        "train": dict(vehicle="sprung-mass", cars=3, speed_kmh=100.0),  # axles back to x = -50 m
        "earthquake": dict(vertical="synthetic", apparent_velocity=200.0, arrival=0.1),
        "solver": dict(backend="numpy", time_step=1e-3, duration=1.0),
    }
    with pytest.raises(ValueError, match=r"earthquake\.arrival to at least 0\.25 s"):
        build_model(validate_scenario(data))
    data["earthquake"]["arrival"] = 0.25
    assert not build_model(validate_scenario(data)).ground.uniform


def test_earthquake_and_contact_keys_are_validated(tmp_path: Path):
    def problems(earthquake: dict, spans: int = 2, **extra) -> str:
        data = {
            "bridge": bridge(spans),
            "train": dict(vehicle="moving-load", speed=10.0),
            "earthquake": earthquake,
        }
        data.update(extra)
        with pytest.raises(ScenarioError) as err:
            validate_scenario(data)
        return str(err.value)

    record = str(write_record(tmp_path / "a.txt", seed=1))
    msg = problems(dict(vertical=[record, record]))
    assert "earthquake.vertical: one record per support needs bridge.spans + 1 = 3 entries" in msg
    msg = problems(dict(vertical=[record, "missing.AT2", record], apparent_velocity=500.0))
    assert "earthquake.vertical[1]" in msg and "missing.AT2" in msg
    assert "earthquake.apparent_velocity: cannot be combined with one record per support" in msg
    assert "earthquake.arrival" in problems(dict(vertical="synthetic", arrival=-1.0))
    assert "earthquake.target_pga" in problems(dict(vertical="synthetic", target_pga=0.0))
    assert "earthquake.vertical_scale" in problems(dict(vertical="synthetic", vertical_scale=-1.0))
    assert "contact.friction" in problems(dict(vertical="synthetic"), contact=dict(friction=0.0))
    assert "contact.colour" in problems(dict(vertical="synthetic"), contact=dict(colour="red"))
    ok = validate_scenario(
        {
            "bridge": bridge(2),
            "train": dict(vehicle="moving-load", speed=10.0),
            "earthquake": dict(vertical=[record, "none", "synthetic"], seed=7, target_pga=2.0),
        }
    )
    assert ok.earthquake.sources("vertical") == [record, "none", "synthetic"]
    assert ok.contact.creep and ok.contact.friction == 0.3


def test_target_pga_and_component_scales(tmp_path: Path):
    record = str(write_record(tmp_path / "a.txt", seed=1))
    eq = dict(
        vertical=record, longitudinal="synthetic", target_pga=2.0, scale=1.5, vertical_scale=0.5, seed=9
    )
    source = build_model(quake_only(eq, duration=1.0)).ground.source
    assert source.vertical.histories[0].pga == pytest.approx(2.0 * 1.5 * 0.5, rel=1e-12)
    assert source.longitudinal.histories[0].pga == pytest.approx(2.0 * 1.5, rel=1e-12)
    # the synthetic record of that seed, independently
    ref = process_record(synthetic_record("longitudinal", 9), target_pga=3.0)
    np.testing.assert_allclose(source.longitudinal.histories[0].accel, ref.accel, rtol=0, atol=1e-12)
