"""Unilateral contact: wheels that lift off and land again (docs/method.md section 12, issue 12).

The reference is written here, independently of the code under test: a sprung mass (body M on a
spring k and dashpot c above a wheel m_w, the ``sprung-mass`` vehicle) standing still on the rigid
approach track, whose ground moves vertically as ``q(t) = A sin^3(w t)`` (smooth, at rest at t = 0,
peak downward acceleration above g). It is integrated event by event with ``solve_ivp`` (DOP853,
tight tolerances): in contact the wheel rides the ground and the contact force is
``N = m_w (q'' + g) + M g - k (z_b - q) - c (z_b' - q')``; an event ``N = 0`` starts a flight, in
which both masses move freely under gravity and the suspension; an event ``z_w = q`` ends it with a
perfectly plastic impact (the wheel takes the ground's velocity).
"""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import svbi
from svbi.runtime.methods.unilateral import ContactWarning, Impact
from svbi.runtime.model.system import FunctionGround
from svbi.runtime.run.simulate import BackendFallback, build_model
from svbi.runtime.scenario.schema import ScenarioError, validate_scenario

M_S, M_W, K_S, C_S, G = 5750.0, 500.0, 1.595e6, 2.0e4, 9.81
SPLIT = 0.5
BRIDGE = dict(
    spans=1,
    span_length=25.0,
    elements_per_span=4,
    mass_per_length=2303.0,
    youngs_modulus=2.87e9,
    area=1.0,
    second_moment=2.9,
)


def sine_cubed(amplitude: float, frequency: float):
    """``q = A sin^3(w t)`` with its exact first and second derivatives (any x)."""
    w = 2 * np.pi * frequency

    def q(t, x):
        s, c = np.sin(w * t), np.cos(w * t)
        z = 0 * np.asarray(x, dtype=float)
        return (
            amplitude * s**3 + z,
            3 * amplitude * w * s * s * c + z,
            3 * amplitude * w * w * (2 * s * c * c - s**3) + z,
        )

    return q


STRONG = sine_cubed(0.05, 2.0)  # peak downward acceleration 1.4 g: three flights in 1.5 s
WEAK = sine_cubed(0.005, 2.0)  # 0.14 g: the wheel never leaves the rail


def sprung_mass_scenario(
    method="localized-dynamic", dt=1e-4, duration=1.5, normal="unilateral", backend="numpy"
):
    return validate_scenario(
        {
            "bridge": BRIDGE,
            "train": dict(
                vehicle="sprung-mass",
                speed=0.0,
                start_position=-10.0,  # on the approach track, which moves with the ground
                parameters=dict(sprung_mass=M_S, wheel_mass=M_W, stiffness=K_S, damping=C_S),
            ),
            "contact": dict(normal=normal, creep=False),  # no wheel spin: nothing to creep
            "solver": dict(
                method=method,
                backend=backend,
                time_step=dt,
                output_every=1,
                duration=duration,
                contact_split=SPLIT,
            ),
        }
    )


def run(ground=STRONG, **kw):
    sc = sprung_mass_scenario(**kw)
    model = build_model(sc)
    model.ground = FunctionGround(vertical=ground)
    return svbi.simulate(sc, model=model)


def event_driven_reference(ground, t_end: float):
    """Flights ``(lift-off time, landing time, peak uplift)`` of the sprung mass (module docstring)."""

    def g3(t):
        return (float(a) for a in ground(t, 0.0))

    def force(t, y):
        q, q1, q2 = g3(t)
        return M_W * (q2 + G) + M_S * G - K_S * (y[0] - q) - C_S * (y[1] - q1)

    def in_contact(t, y):
        q, q1, _ = g3(t)
        return [y[1], (-K_S * (y[0] - q) - C_S * (y[1] - q1)) / M_S]

    def flying(t, y):
        f = K_S * (y[0] - y[2]) + C_S * (y[1] - y[3])
        return [y[1], -f / M_S, y[3], (f - (M_W + M_S) * G) / M_W]

    def lift(t, y):
        return force(t, y)

    def land(t, y):
        return y[2] - next(g3(t))

    lift.terminal, lift.direction = True, -1
    land.terminal, land.direction = True, -1
    opts = dict(method="DOP853", rtol=1e-11, atol=1e-13, dense_output=True, max_step=1e-3)
    t, y, flights = 0.0, np.zeros(2), []
    while True:
        sol = solve_ivp(in_contact, (t, t_end), y, events=lift, **opts)
        if sol.status != 1:
            return flights
        t0 = sol.t_events[0][0]
        zb, vb = sol.y_events[0][0]
        q, q1, _ = g3(t0)
        sol = solve_ivp(flying, (t0 + 1e-12, t_end), [zb, vb, q, q1], events=land, **opts)
        tt = np.linspace(t0, sol.t[-1], 4000)
        uplift = sol.sol(tt)[2] - np.array([next(g3(s)) for s in tt])
        if sol.status != 1:
            flights.append((t0, np.inf, float(uplift.max())))
            return flights
        t1 = sol.t_events[0][0]
        flights.append((t0, t1, float(uplift.max())))
        zb, vb, _, _ = sol.y_events[0][0]
        t, y = t1 + 1e-12, np.array([zb, vb])  # plastic: the wheel rides the ground again


def flights_of(ds) -> list[tuple[float, float, float]]:
    """Flights of wheel 1 of car 1: (first airborne time, first time back on the rail, peak uplift)."""
    t = ds.time.values
    off = ds.contact_state.values[:, 0, 0] == 0
    up = ds.wheel_uplift.values[:, 0, 0]
    edges = np.flatnonzero(np.diff(np.concatenate([[0], off.astype(int), [0]])))
    out = []
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        out.append((float(t[a]), float(t[b]) if b < len(t) else np.inf, float(up[a:b].max())))
    return out


@pytest.fixture(scope="module")
def reference():
    return event_driven_reference(STRONG, 1.5)


@pytest.fixture(scope="module")
def localized():
    """The localized method's run against the reference, on the C loop: it keeps lift-offs, flights
    and landings in C and gives the NumPy backend's results to 1e-9 of the peaks
    (``test_c_localized_keeps_lift_offs_and_landings_in_c``), in a fraction of the time. The NumPy
    backend's own steps through these impacts are checked by ``test_energy_never_increases_at_an_impact``."""
    ds = run(backend="c")
    assert ds.attrs["backend"] == "c" and ds.attrs["numpy_steps"] == 0
    return ds


# --------------------------------------------------------------------------------------------------
# scenario


def test_scenario_normal_key_default_and_values():
    sc = sprung_mass_scenario()
    assert sc.contact.normal == "unilateral"
    d = sc.to_dict()
    del d["contact"]["normal"]
    assert validate_scenario(d).contact.normal == "unilateral"  # the default
    d["contact"]["normal"] = "sticky"
    with pytest.raises(ScenarioError, match="contact.normal"):
        validate_scenario(d)


def test_speed_zero_needs_a_duration():
    d = sprung_mass_scenario().to_dict()
    del d["solver"]["duration"]
    with pytest.raises(ScenarioError, match=r"train.speed: 0 .* needs solver.duration"):
        validate_scenario(d)


def test_paper_examples_are_bilateral():
    """The paper's examples keep its rigid contact. Read as TOML: the Tabas example's records are
    the user's to download, so the file is not validated here (that would need them)."""
    import tomllib

    from conftest import REPO

    from svbi.runtime.scenario.schema import load_scenario

    assert load_scenario(REPO / "examples" / "paper-2020.toml").contact.normal == "bilateral"
    tabas = tomllib.loads((REPO / "examples" / "paper-2020-tabas.toml").read_text(encoding="utf-8"))
    assert tabas["contact"]["normal"] == "bilateral"
    assert not any(".." in str(tabas["earthquake"][k]) for k in ("vertical", "longitudinal"))


# --------------------------------------------------------------------------------------------------
# against the event-driven reference


def test_reference_has_flights(reference):
    assert len(reference) == 3
    assert all(np.isfinite(f[1]) for f in reference)


def compare_flights(ds, reference, time_tol=3e-3, rel_tol=0.03):
    got = flights_of(ds)
    assert len(got) == len(reference), (got, reference)
    worst = [0.0, 0.0, 0.0]
    for (a, b, up), (ra, rb, rup) in zip(got, reference, strict=True):
        assert abs(a - ra) < time_tol, ("lift-off", a, ra)
        assert abs(b - rb) < time_tol, ("landing", b, rb)
        assert abs((b - a) - (rb - ra)) < rel_tol * (rb - ra), ("flight time", b - a, rb - ra)
        assert abs(up - rup) < rel_tol * rup, ("peak uplift", up, rup)
        worst = [
            max(worst[0], abs(a - ra), abs(b - rb)),
            max(worst[1], abs((b - a) / (rb - ra) - 1)),
            max(worst[2], abs(up / rup - 1)),
        ]
    return worst


def test_localized_flights_match_event_driven_reference(localized, reference):
    worst = compare_flights(localized, reference)
    # measured at dt = 1e-4 s: event times within 0.1 ms, flight time 0.1 %, peak uplift 0.01 %
    assert worst[0] < 2e-4 and worst[1] < 2e-3 and worst[2] < 1e-3, worst


@pytest.mark.parametrize("method", ["coupled-dynamic", "coupled-classic"])
def test_coupled_flights_match_event_driven_reference(method, reference):
    # the C loop runs the steps in contact; the steps around each event are the NumPy stepper's, as
    # in a NumPy run (test_c_coupled_methods_hand_lift_offs_to_numpy_steps_and_back)
    ds = run(method=method, dt=2e-4, duration=1.0, backend="c")
    assert ds.attrs["backend"] == "c" and ds.attrs["numpy_steps"] > 0
    compare_flights(ds, [f for f in reference if f[1] < 1.0])


def test_invariants_at_every_step(localized):
    P = localized.contact_force.values
    s = localized.wheel_uplift.values
    state = localized.contact_state.values
    assert (P >= 0).all()
    assert (s >= 0).all()
    assert (P * s == 0).all()
    assert (P[state == 0] == 0).all()  # airborne: no normal force
    assert (s[state == 1] == 0).all()
    assert (s[state == 0] > 0).any()


def test_energy_never_increases_at_an_impact(monkeypatch):
    """Energy in the frame of the moving ground, just before and just after each impact: the
    impact changes only velocities, so the kinetic energy relative to the ground may only drop."""
    records: list[tuple[float, float, float]] = []
    relative: list[float] = []
    original = Impact.apply

    def energy(st, q1):
        body = 0.5 * M_S * (st.vV[0, 0] - q1) ** 2
        wheel = 0.5 * (1 - SPLIT) * M_W * (st.vV[0, 1] - q1) ** 2
        aux = 0.5 * SPLIT * M_W * (st.vg[0] - q1) ** 2
        return body + wheel + aux

    def spy(self, st, c, active, landing, aux_is_wheel, P_start):
        q1 = float(c.q1[0])
        before = energy(st, q1)
        out = original(self, st, c, active, landing, aux_is_wheel, P_start)
        records.append((st.t, before, energy(st, q1)))
        relative.append(abs(st.vg[0] - q1) / abs(q1))
        return out

    monkeypatch.setattr(Impact, "apply", spy)
    sc = sprung_mass_scenario(dt=2e-4)
    model = build_model(sc)
    wheel_dof = int(np.argmax(model.train.W[:, 0]))
    assert model.train.W[:, 0].tolist() == [0.0, 1.0] and wheel_dof == 1  # [body, wheel]
    model.ground = FunctionGround(vertical=STRONG)
    svbi.simulate(sc, model=model)
    assert len(records) == 3
    for t, before, after in records:
        assert after <= before, (t, before, after)
    assert max(relative) < 1e-12  # plastic: the wheel leaves the impact with the ground's velocity


def test_flight_time_converges_with_the_time_step(reference, localized):
    """Lift-off and landing are resolved to the step: each is seen at the first step at or after
    the event (error in [0, dt)), so the flight time errs by less than dt; the peak uplift converges
    at second order (measured, first flight: 1.6e-4, 4.2e-5, 1.1e-5, 3.6e-6 at dt = 8e-4 ... 1e-4)."""
    ref = reference[:2]
    peak_errors = []
    for dt in (8e-4, 4e-4, 2e-4, 1e-4):
        ds = localized if dt == 1e-4 else run(dt=dt, duration=1.0, backend="c")  # as `localized`
        got = flights_of(ds)[:2]
        for (a, b, _), (ra, rb, _) in zip(got, ref, strict=True):
            assert -1e-6 <= a - ra < dt and -1e-6 <= b - rb < dt, (dt, a - ra, b - rb)
            assert abs((b - a) - (rb - ra)) < dt
        peak_errors.append([abs(up / r[2] - 1) for (_, _, up), r in zip(got, ref, strict=True)])
    e = np.array(peak_errors)
    assert (np.diff(e, axis=0) < 0).all(), e
    assert (e[0] / e[-1] > 16).all(), e  # at least first order over a factor 8, measured second


# --------------------------------------------------------------------------------------------------
# nothing separates: unilateral = bilateral


@pytest.mark.parametrize("method", ["localized-dynamic", "coupled-dynamic", "coupled-classic"])
def test_nothing_separates_equals_bilateral(method):
    a = run(ground=WEAK, method=method, dt=5e-4, duration=0.8)
    b = run(ground=WEAK, method=method, dt=5e-4, duration=0.8, normal="bilateral")
    assert a.attrs["liftoffs"] == 0 and (a.contact_state == 1).all()
    for name in ("contact_force", "carbody_uz", "carbody_az", "midspan_uz", "gap_bridge"):
        peak = float(np.abs(b[name]).max())
        assert float(np.abs(a[name] - b[name]).max()) <= 1e-12 * peak, name


# --------------------------------------------------------------------------------------------------
# a Pioneer car on a two-span bridge: localized = coupled-dynamic through separations


PIONEER_GROUND = sine_cubed(0.06, 2.5)


@functools.cache
def pioneer(method: str, speed_kmh: float, start: float, backend: str = "numpy", normal: str = "unilateral"):
    """A Pioneer car on two spans under a strong vertical ground motion, for 0.44 s: the ground's
    first two downward peaks, 6 to 9 lift-offs (per method, speed and backend, measured), every wheel
    back on its rail at the end (asserted where the runs are compared; runs of 0.6 s added lift-offs
    and landings of the same kind, at a third more steps). One run per set of arguments: the NumPy
    runs are the references of several tests below (the datasets are only read)."""
    sc = validate_scenario(
        {
            "bridge": dict(
                spans=2,
                span_length=20.0,
                elements_per_span=4,
                mass_per_length=1.2e4,
                youngs_modulus=3.5e10,
                area=5.0,
                second_moment=3.0,
            ),
            "train": dict(vehicle="pioneer-2d", speed_kmh=speed_kmh, start_position=start),
            "track": dict(irregularity="german-low"),
            "contact": dict(normal=normal),
            "solver": dict(method=method, backend=backend, time_step=2e-4, output_every=1, duration=0.44),
        }
    )
    model = build_model(sc)
    model.ground = FunctionGround(vertical=PIONEER_GROUND)
    return svbi.simulate(sc, model=model)


@pytest.mark.parametrize(("speed", "start"), [(0.0, 30.0), (200.0, 5.0)], ids=["standing", "running"])
def test_localized_equals_coupled_dynamic_through_separations(speed, start):
    a = pioneer("localized-dynamic", speed, start)
    b = pioneer("coupled-dynamic", speed, start)
    assert a.attrs["liftoffs"] >= 5  # measured 9 standing, 6 running
    assert (a.contact_state == b.contact_state).all()
    assert (a.contact_state.values[-1] == 1).all()  # every wheel landed again
    for name in ("contact_force", "wheel_uplift", "carbody_uz", "carbody_az", "midspan_uz", "creep_force"):
        peak = float(np.abs(a[name]).max())
        assert float(np.abs(a[name] - b[name]).max()) <= 1e-8 * max(peak, 1e-300), name
    for ds in (a, b):
        P, s = ds.contact_force.values, ds.wheel_uplift.values
        assert (P >= 0).all() and (s >= -1e-15).all() and (np.abs(P * s) == 0).all()
        assert (ds.creep_force.values[ds.contact_state.values == 0] == 0).all()


# --------------------------------------------------------------------------------------------------
# C backend, results, warnings


def test_c_backend_runs_non_separating_unilateral_runs_as_the_bilateral_c_loop():
    a = run(ground=WEAK, backend="c", dt=5e-4, duration=0.4)
    b = run(ground=WEAK, backend="c", dt=5e-4, duration=0.4, normal="bilateral")
    assert a.attrs["backend"] == "c" and a.attrs["liftoffs"] == 0
    for name in ("contact_force", "carbody_az", "midspan_uz"):
        assert float(np.abs(a[name] - b[name]).max()) == 0.0


@pytest.mark.parametrize(("speed", "start"), [(0.0, 30.0), (200.0, 5.0)], ids=["standing", "running"])
def test_c_localized_keeps_lift_offs_and_landings_in_c(speed, start):
    """The C loop keeps the active set: wheels lift off, fly and land (the landing row and the
    plastic impact, impact.c) in C, with no NumPy step, and the NumPy backend's results."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", BackendFallback)
        c = pioneer("localized-dynamic", speed, start, backend="c")
    d = pioneer("localized-dynamic", speed, start)
    assert c.attrs["backend"] == "c" and c.attrs["liftoffs"] == d.attrs["liftoffs"] >= 5
    assert (c.contact_state == d.contact_state).all()
    assert (d.contact_state.values[-1] == 1).all()  # every wheel landed again
    assert c.attrs["numpy_steps"] == 0
    # measured 1.4e-10 (force), 1e-11 (uplift), 3e-12 (car body, midspan)
    for name in ("contact_force", "wheel_uplift", "carbody_uz", "carbody_az", "midspan_uz"):
        peak = float(np.abs(d[name]).max())
        assert float(np.abs(c[name] - d[name]).max()) <= 1e-9 * peak, name


@pytest.mark.parametrize("method", ["coupled-dynamic", "coupled-classic"])
def test_c_coupled_methods_hand_lift_offs_to_numpy_steps_and_back(method):
    """As for localized-dynamic: C runs while every wheel is on its rail, NumPy (with the C loop's
    dynamic multipliers) takes the steps around each event, and the C loop goes on. The backends'
    own round-off difference is the scale: the same run with bilateral contact (measured 1.5e-11 of
    the force peak for coupled-dynamic; 5.9e-10 for coupled-classic, whose index-1 rows are ill
    conditioned), and the events may amplify it by a few (measured 1.9e-10 and 5.9e-10 over the
    0.44 s run; 3.4e-10 and 1.8e-9 over 0.6 s)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", BackendFallback)
        c = pioneer(method, 200.0, 5.0, backend="c")
        cb = pioneer(method, 200.0, 5.0, backend="c", normal="bilateral")
    d = pioneer(method, 200.0, 5.0)
    db = pioneer(method, 200.0, 5.0, normal="bilateral")
    assert c.attrs["backend"] == "c" and c.attrs["liftoffs"] == d.attrs["liftoffs"] >= 5
    assert (c.contact_state == d.contact_state).all()
    assert (d.contact_state.values[-1] == 1).all()  # every wheel landed again
    for name in ("contact_force", "wheel_uplift", "carbody_uz", "carbody_az", "midspan_uz"):
        peak = float(np.abs(d[name]).max())
        scale = float(np.abs(db[name]).max())  # zero for wheel_uplift: no wheel lifts off there
        base = max(float(np.abs(cb[name] - db[name]).max()) / scale if scale > 0 else 0.0, 1e-10)
        assert float(np.abs(c[name] - d[name]).max()) <= 10 * base * peak, name


def test_results_summary(localized, reference):
    at = localized.attrs
    assert at["contact_normal"] == "unilateral"
    assert at["liftoffs"] == 3
    longest = max(reference, key=lambda f: f[1] - f[0])
    assert abs(at["longest_flight_s"] - (longest[1] - longest[0])) < 3e-3
    assert abs(at["longest_flight_time"] - longest[0]) < 3e-3
    assert (at["longest_flight_car"], at["longest_flight_wheel"]) == (1, 1)
    assert abs(at["peak_uplift_m"] / max(f[2] for f in reference) - 1) < 0.03
    assert at["peak_uplift_m"] == float(localized.wheel_uplift.max())
    static = (M_S + M_W) * G
    ratio = 1 - localized.contact_force_filtered.values / static
    assert np.allclose(localized.unloading_ratio.values, ratio, rtol=0, atol=1e-12)
    assert at["peak_unloading_ratio"] == pytest.approx(float(ratio.max()), abs=1e-12)
    assert at["peak_unloading_ratio"] >= 1.0  # the filtered force of a wheel in flight is ~0


def test_bilateral_run_with_tension_warns_with_time_car_wheel():
    with pytest.warns(ContactWarning, match=r"first at t = 0\.1[67]\d* s, car 1, wheel 1"):
        ds = run(dt=2e-4, duration=0.4, normal="bilateral")
    assert float(ds.contact_force.min()) < 0  # the rail pulls: reported, and warned about
    with warnings.catch_warnings():
        warnings.simplefilter("error", ContactWarning)
        run(ground=WEAK, dt=5e-4, duration=0.4, normal="bilateral")


def test_plot_draws_lift_off_panels_and_summary_rows(tmp_path):
    from svbi.runtime.plots import results as plots
    from svbi.runtime.run.results import write_netcdf

    path = write_netcdf(run(dt=4e-4, duration=0.4, backend="c"), tmp_path / "lift.nc")  # any backend
    ds = plots.read_results(path)
    assert ds.contact_state.dtype.kind in "iu" and ds.attrs["liftoffs"] == 1
    written = plots.plot_results({"lift": ds}, tmp_path / "fig")
    assert tmp_path / "fig" / f"{plots.CONTACT}.png" in written
    text = plots.summary_text({"lift": ds})
    assert "wheel lift-offs" in text and "peak uplift (mm)" in text
    calm = run(ground=WEAK, dt=5e-4, duration=0.2, backend="c")
    assert plots.CONTACT not in plots.make_figures({"calm": calm})
