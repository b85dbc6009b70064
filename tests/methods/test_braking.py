"""A train that brakes or accelerates (``[train] acceleration``, issue 13 item 5).

The reference is written here, independently of the code under test: a sprung mass on a wheel
crosses one simply supported span while its speed changes, ``x = v0 t + a t^2 / 2``, over a smooth
ramp in the rail (a measured profile file). The beam is expanded in its exact modes
``sin(n pi x / L)``; the wheel rides rigidly on the rail, so its acceleration is the total second
derivative of ``w(x(t), t) + r(x(t))``:
``w_tt + 2 v w_xt + v^2 w_xx + a w_x + v^2 r_xx + a r_x`` (the terms in ``a`` are what a changing
speed adds). Integrated by DOP853 at tight tolerances, with the mode-acceleration correction of
``test_verification_sprung_mass.py`` for the truncated modes.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import c_compiler_works
from scipy.integrate import solve_ivp

import svbi
from svbi.examples import paper_section_keys
from svbi.runtime.run.simulate import build_model
from svbi.runtime.scenario.schema import validate_scenario

L, E, Iy, MU = 25.0, 2.87e9, 2.9, 2303.0
M_S, K_S, M_W = 5750.0, 1.595e6, 500.0
G = 9.81
MODES = 20
TOL = 2e-4
GENTLE = (6.0, 8.0, 0.004)
"""A ramp of the rail: start (m), length (m), height (m)."""
STEEP = (6.0, 4.0, 0.02)


def ramp(
    x: np.ndarray, shape: tuple[float, float, float] = GENTLE
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A quintic smooth step of the rail (C2), and its first two x-derivatives."""
    start, length, height = shape
    s = np.clip((x - start) / length, 0.0, 1.0)
    inside = (x > start) & (x < start + length)
    r = height * s**3 * (10 - 15 * s + 6 * s * s)
    r1 = np.where(inside, height * 30 * s * s * (1 - s) ** 2 / length, 0.0)
    r2 = np.where(inside, height * 60 * s * (1 - s) * (1 - 2 * s) / length**2, 0.0)
    return r, r1, r2


def ramp_at(x: float, shape: tuple[float, float, float]) -> tuple[float, float, float]:
    """:func:`ramp` at one point, in scalar arithmetic (the reference's right-hand side calls it at
    every stage of every step: NumPy's per-call overhead on a scalar was a third of its time)."""
    start, length, height = shape
    s = min(max((x - start) / length, 0.0), 1.0)
    r = height * s**3 * (10 - 15 * s + 6 * s * s)
    if not start < x < start + length:
        return r, 0.0, 0.0
    return r, height * 30 * s * s * (1 - s) ** 2 / length, height * 60 * s * (1 - s) * (1 - 2 * s) / length**2


def modal_reference(
    v0: float, a: float, t_end: float, acceleration_terms: bool = True, shape: tuple = GENTLE
):
    n = np.arange(1, MODES + 1)
    k_n = n * np.pi / L
    k_n2 = k_n**2
    w2 = k_n**4 * E * Iy / MU
    m0 = MU * L / 2
    stiffness = m0 * w2
    mid = np.sin(n * np.pi / 2)

    def motion(t: float, y: np.ndarray) -> tuple[np.ndarray, float, float]:
        """The modal accelerations, the contact force and the spring force. With the mode shapes
        ``phi = sin(k x)``, ``phi' = k cos(k x)``, ``phi'' = -k^2 sin(k x)``; the products with
        ``phi'`` and ``phi''`` are taken as ``cos(k x) @ (k q)`` and ``sin(k x) @ (k^2 q)`` (the
        same sums, fewer array operations per call)."""
        q, qd, z = y[:MODES], y[MODES : 2 * MODES], y[-2]
        x, v = v0 * t + 0.5 * a * t * t, v0 + a * t
        kx = k_n * x
        phi, cos = np.sin(kx), np.cos(kx)
        r, r1, r2 = ramp_at(x, shape)
        w_x = cos @ (k_n * q)
        spring = K_S * (phi @ q + r - z)
        conv = 2 * v * (cos @ (k_n * qd)) - v * v * (phi @ (k_n2 * q)) + v * v * r2
        if acceleration_terms:
            conv += a * w_x + a * r1
        f = -stiffness * q - phi * (M_W * (conv + G) + M_S * G + spring)
        qdd = f / m0 - phi * ((M_W * (phi @ f) / m0**2) / (1 + M_W * (phi @ phi) / m0))
        force = M_W * (phi @ qdd + conv + G) + M_S * G + spring
        return qdd, force, spring

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        qdd, _, spring = motion(t, y)
        out = np.empty_like(y)
        out[:MODES] = y[MODES : 2 * MODES]
        out[MODES : 2 * MODES] = qdd
        out[-2] = y[-1]
        out[-1] = spring / M_S
        return out

    sol = solve_ivp(
        rhs, (0.0, t_end), np.zeros(2 * MODES + 2), method="DOP853", rtol=1e-10, atol=1e-13, dense_output=True
    )
    assert sol.success

    def outputs(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        y = sol.sol(t)
        w = mid @ y[:MODES]
        force = np.zeros(len(t))
        for i, ti in enumerate(t):
            x = v0 * ti + 0.5 * a * ti * ti
            aa = min(x, L - x)
            green = -aa * (3 * L * L - 4 * aa * aa) / (48 * E * Iy)
            force[i] = motion(ti, y[:, i])[1]
            w[i] += force[i] * (green + np.sum(np.sin(k_n * x) * mid / (m0 * w2)))
        return w, y[-2]

    return outputs


def scenario(tmp_path, v0: float, a: float, dt: float = 1e-4, shape: tuple = GENTLE, **solver):
    xs = np.arange(-5.0, 60.0, 0.02)
    np.savetxt(tmp_path / "ramp.txt", np.column_stack([xs, ramp(xs, shape)[0]]))
    return validate_scenario(
        {
            "bridge": dict(
                spans=1,
                span_length=L,
                mass_per_length=MU,
                youngs_modulus=E,
                area=1.0,
                second_moment=Iy,
                damping_ratio=0.0,
                elements_per_span=16,
            ),
            "train": dict(
                vehicle="sprung-mass",
                speed=v0,
                acceleration=a,
                parameters=dict(sprung_mass=M_S, stiffness=K_S, wheel_mass=M_W, damping=0.0),
            ),
            "track": dict(irregularity=str(tmp_path / "ramp.txt")),
            "contact": dict(creep=False),
            "solver": dict(backend="numpy", time_step=dt, output_every=1) | solver,
        }
    )


# accelerating from 25 m/s, the crossing ends 0.054 s before a constant speed's (checked to 1e-4 s)
# and the wheel runs 1.3 m further than at v0 (measured: 1.2e-5 and 7e-6 of the peaks; from 15 m/s,
# 1.0e-5 and 1.2e-5 over a crossing half as long again)
@pytest.mark.parametrize(("v0", "a"), [(25.0, 3.0), (35.0, -4.0)])
def test_sprung_mass_changing_speed_over_a_ramp_matches_the_modal_solution(tmp_path, v0, a):
    # on the C loop, which brakes as NumPy does (test_c_loop_brakes_to_a_stop_as_numpy_does)
    ds = svbi.simulate(scenario(tmp_path, v0, a, backend="c"))
    assert ds.attrs["backend"] == "c"
    t = ds.time.values
    t_cross = (np.sqrt(v0 * v0 + 2 * a * L) - v0) / a
    assert t[-1] == pytest.approx(t_cross, abs=1e-4)  # the run ends as the wheel leaves the span
    keep = t <= t_cross
    w_ref, z_ref = modal_reference(v0, a, t[keep][-1])(t[keep])
    peak = np.abs(w_ref).max()
    # measured about 1e-5 of the peaks at dt = 1e-4 s (Newmark and 16 elements per span)
    assert np.abs(ds.midspan_uz.values[keep, 0] - w_ref).max() < TOL * peak
    z = ds.carbody_uz.values[keep, 0]
    assert np.abs(z - z_ref).max() < TOL * np.abs(z_ref).max()
    np.testing.assert_allclose(ds.train_speed.values, v0 + a * t, rtol=1e-12)


@pytest.mark.parametrize(("v0", "a"), [(20.0, 12.0), (40.0, -12.0)])
def test_the_response_has_the_terms_of_the_acceleration(tmp_path, v0, a):
    """On a gentle ramp at a train's accelerations the terms in ``a`` (``a w_x``, ``a r_x``) change
    the response by less than the discretisation error. Exaggerated here (1.2 g, a steep ramp), they
    change the midspan deflection by 9e-4 (accelerating from 20 m/s) and 7e-4 (braking from 40 m/s)
    of its peak: svbi follows the reference with them to 1e-4 (measured 8e-6 and 1.2e-5), and misses
    the reference without them. (Accelerating from 10 m/s: 8.5e-4 and 6e-6, the same check over a
    crossing twice as long, twice the reference's cost.)"""
    ds = svbi.simulate(scenario(tmp_path, v0, a, shape=STEEP, backend="c"))  # C brakes as NumPy does
    assert ds.attrs["backend"] == "c"
    t = ds.time.values
    keep = t <= (np.sqrt(v0 * v0 + 2 * a * L) - v0) / a
    w, _ = modal_reference(v0, a, t[keep][-1], shape=STEEP)(t[keep])
    w0, _ = modal_reference(v0, a, t[keep][-1], acceleration_terms=False, shape=STEEP)(t[keep])
    peak = np.abs(w).max()
    got = ds.midspan_uz.values[keep, 0]
    assert np.abs(got - w).max() < 1e-4 * peak
    assert np.abs(got - w0).max() > 5e-4 * peak


def test_the_rows_terms_of_the_acceleration_keep_the_contact_gap_closed(tmp_path, monkeypatch):
    """The generated row's ``a_x`` terms (``bridge_row_acceleration_coefficients``): the contact is
    held at position level, so without them the wheel still follows the rail, but the gap on the span
    opens to about 1e-9 m instead of staying at the constant-speed run's level (2e-10 m, left by
    the entry kink's transient)."""
    from svbi.runtime.model import contact_rows

    v0, a = 40.0, -12.0

    def interior_gap() -> float:
        ds = svbi.simulate(scenario(tmp_path, v0, a, shape=STEEP))
        t = ds.time.values
        x = v0 * t + 0.5 * a * t * t
        inside = (x > 3.0) & (x < L - 3.0)
        return float(np.abs(ds.gap_bridge.values[inside]).max())

    with_terms = interior_gap()
    call = contact_rows.ContactRowKernel.__call__
    monkeypatch.setattr(
        contact_rows.ContactRowKernel,
        "__call__",
        lambda self, xi, span=None, v=None, a=0.0: call(self, xi, span, v),
    )
    without = interior_gap()
    assert with_terms < 4e-10
    assert without > 3 * with_terms


def test_a_braking_train_stops_and_stands(tmp_path):
    v0, a = 20.0, -5.0  # stops after 4 s and 40 m
    sc = scenario(tmp_path, v0, a, dt=5e-4, duration=6.0, backend="c")  # C brakes as NumPy does
    model = build_model(sc)
    assert model.train.positions(4.0)[0] == pytest.approx(40.0)
    assert model.train.positions(6.0)[0] == pytest.approx(40.0)
    ds = svbi.simulate(sc, model=model)
    assert ds.attrs["backend"] == "c"
    speed = ds.train_speed.values
    assert speed[0] == v0 and np.all(speed[ds.time.values >= 4.0] == 0.0)
    assert np.all(np.isfinite(ds.contact_force.values))
    # standing on the rigid approach beyond the span, at rest on the raised rail: the wheel load is
    # the static one and the car body has settled by the spring's undamped ringing only
    assert abs(float(ds.contact_force.values[-1, 0, 0]) - (M_S + M_W) * G) < 0.05 * (M_S + M_W) * G


def test_a_braking_train_that_stops_on_the_bridge_needs_a_duration():
    from svbi.runtime.scenario.schema import ScenarioError

    with pytest.raises(
        ScenarioError, match="train.acceleration: braking at 5 m/s\\^2 the train stops after 40 m"
    ):
        validate_scenario(
            {
                "bridge": dict(
                    spans=2,
                    span_length=32.0,
                    mass_per_length=1e4,
                    youngs_modulus=3e10,
                    area=5.0,
                    second_moment=3.0,
                ),
                "train": dict(vehicle="sprung-mass", speed=20.0, acceleration=-5.0),
            }
        )


@pytest.mark.skipif(not c_compiler_works(), reason="no working C compiler")
def test_c_loop_brakes_to_a_stop_as_numpy_does():
    """The C loop with a changing speed (positions, the rows of each step's v and a, the off-bridge
    targets, a travelling earthquake seen from the braking wheels, creep at the actual speed and
    none below its stable speed): a Pioneer car braking to a stop on the bridge under a quake."""
    import warnings

    from svbi.runtime.run.simulate import BackendFallback

    def run(backend: str):
        sc = validate_scenario(
            {
                "bridge": dict(
                    spans=3,
                    span_length=32.0,
                    **paper_section_keys(),
                    rail_height=2.0,
                ),
                "train": dict(
                    vehicle="pioneer-2d", cars=1, speed_kmh=60.0, acceleration=-4.0, start_position=-5.0
                ),
                "track": dict(irregularity="german-low"),
                "earthquake": dict(
                    vertical="synthetic", longitudinal="synthetic", arrival=0.2, apparent_velocity=500.0
                ),
                "contact": dict(normal="bilateral"),
                "solver": dict(backend=backend, time_step=5e-4, duration=5.0),
            }
        )
        with warnings.catch_warnings():
            warnings.simplefilter("error", BackendFallback)
            warnings.simplefilter("ignore", UserWarning)
            return svbi.simulate(sc)

    c, d = run("c"), run("numpy")
    assert c.attrs["backend"] == "c"
    speed = c.train_speed.values
    assert speed[0] > 16.0 and speed[-1] == 0.0  # stopped at 4.17 s, then standing
    np.testing.assert_array_equal(speed, d.train_speed.values)
    for name in ("midspan_uz", "contact_force", "carbody_az", "creep_force", "creepage"):
        peak = float(np.abs(d[name]).max())
        assert peak > 0.0, name
        assert float(np.abs(c[name] - d[name]).max()) <= 1e-9 * peak, name
    assert np.all(c.creep_force.values[c.time.values > 4.2] == 0.0)  # no creep force standing
