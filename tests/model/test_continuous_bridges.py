"""Continuous girders, unequal spans and piers (issue 13 items 2 and 6), against independent truth.

* The natural frequencies of a two-span continuous beam against its exact modes: the spans' own
  simply supported modes ``sin(n pi x / L)`` (no moment over the middle support) and the
  symmetric family with ``tan(beta L) = tanh(beta L)`` (each span pinned-clamped), and the
  girder's axial modes (a fixed-free bar of length 2L).
* A force crossing that beam against a modal solution written here with those exact modes.
* Two unequal simply supported spans against Frýba's series for each span.
* A span whose fixed bearing sits on a flexible pier: the longitudinal frequency against the exact
  cantilever with a tip mass (the deck, axially rigid), from the modes and from a free vibration
  computed by the time loop.
"""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pytest
from cases import A_P, AREA, E_P, I_P, MU, MU_P, VIADUCT, E, H, Iy, L, bridge_dict
from conftest import c_compiler_works
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import svbi
from svbi.runtime.model.bridge import Bridge, Girder, Section
from svbi.runtime.model.system import FunctionGround
from svbi.runtime.run.simulate import build_model
from svbi.runtime.scenario.schema import validate_scenario

P = 170.0e3
C_BEND = np.sqrt(E * Iy / MU)
DECK = Section(MU, E, AREA, Iy, 0.0)


def exact_two_span_modes(count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The vertical modes of two equal continuous spans, by increasing frequency: circular
    frequencies ``w`` and the parameters of :func:`two_span_shapes`, ``(w, b, c, symmetric)``."""
    modes = []
    for n in range(1, count + 1):
        k = n * np.pi / L
        modes.append((k * k * C_BEND, k, 0.0, False))
        z = brentq(lambda z: np.tan(z) - np.tanh(z), n * np.pi + 1e-9, n * np.pi + np.pi / 2 - 1e-9)
        b = z / L
        modes.append((b * b * C_BEND, b, np.sin(z) / np.sinh(z), True))
    w, b, c, symmetric = (np.array(column) for column in zip(*sorted(modes, key=lambda m: m[0]), strict=True))
    return w, b, c, symmetric


def two_span_shapes(x: float | np.ndarray, b: np.ndarray, c: np.ndarray, symmetric: np.ndarray) -> np.ndarray:
    """The shapes of :func:`exact_two_span_modes` at ``x`` (modes along the last axis): the spans'
    own modes ``sin(b x)`` and the symmetric ones ``sin(b y) - c sinh(b y)``, ``y`` the distance from
    the nearer end. Every mode at once: the modal reference evaluates them at each stage."""
    x = np.asarray(x, dtype=float)[..., None]
    y = np.where(symmetric & (x > L), 2 * L - x, x)
    return np.sin(b * y) - c * np.sinh(b * y)


def moving_force(bridge: dict, speed_kmh: float, dt: float = 1e-4):
    """A force crossing ``bridge``, on the C loop: these tests verify the bridge (its modes, joints,
    piers) against closed forms, and the C loop gives the NumPy backend's results to round-off on
    continuous girders, unequal spans and piers under moving loads
    (tests/backends/test_c_general_bridges.py), in a fraction of the time."""
    ds = svbi.simulate(
        validate_scenario(
            {
                "bridge": bridge,
                "train": dict(
                    vehicle="moving-load",
                    speed_kmh=speed_kmh,
                    parameters=dict(axle_loads=[P], axle_offsets=[0.0]),
                ),
                "solver": dict(backend="c", time_step=dt, output_every=1),
            }
        )
    )
    assert ds.attrs["backend"] == ("c" if c_compiler_works() else "numpy")
    return ds


def test_two_span_continuous_beam_has_the_exact_frequencies():
    b = Bridge(0, 0.0, 1, 1, 1, 1, 0.0, 16, 0.0, [Girder((L, L), DECK)], [])
    vertical = exact_two_span_modes(4)[0] / (2 * np.pi)
    c_axial = np.sqrt(E * AREA / MU)
    axial = np.array([(2 * m - 1) * c_axial / (4 * 2 * L) for m in range(1, 4)])
    vertical = vertical[vertical < 60.0]  # six modes; Hermite cubics: within 2e-4 up to here
    got = b.natural_frequencies(12)
    assert len(got[got < 60.0]) == len(vertical) + len(axial[axial < 60.0])
    for f in vertical:
        assert np.abs(got - f).min() < 2e-4 * f, f
    le = L / 16
    for f in axial:  # linear axial elements, consistent mass: omega_h / omega = 1 + (k le)^2 / 24
        k = 2 * np.pi * f / c_axial
        err = (k * le) ** 2 / 24
        nearest = got[np.argmin(np.abs(got - f))]
        assert nearest / f - 1 == pytest.approx(err, rel=0.05), f


@pytest.mark.parametrize("speed_kmh", [150.0, 300.0])
def test_force_crossing_a_two_span_continuous_beam_matches_the_modal_solution(speed_kmh):
    v = speed_kmh / 3.6
    ds = moving_force(bridge_dict(girders=[dict(spans=[L, L])]), speed_kmh)
    t = ds.time.values
    on = t <= 2 * L / v
    # modal solution: q'' + w^2 q = -P phi(v t) / M_n, M_n = mu * integral of phi^2
    omega, *shape = exact_two_span_modes(10)
    x = np.linspace(0.0, 2 * L, 40001)
    norms = MU * np.trapezoid(two_span_shapes(x, *shape) ** 2, x, axis=0)
    w2 = omega * omega
    n = len(omega)

    def rhs(time, y):
        q, dq = y[:n], y[n:]
        f = -P * two_span_shapes(v * time, *shape) / norms
        return np.concatenate([dq, f - w2 * q])

    sol = solve_ivp(
        rhs, (0.0, t[on][-1]), np.zeros(2 * n), t_eval=t[on], rtol=1e-10, atol=1e-14, method="DOP853"
    )
    for span, xm in ((0, 0.5 * L), (1, 1.5 * L)):
        ref = two_span_shapes(xm, *shape) @ sol.y[:n]
        w = ds.midspan_uz.values[on, span]
        peak = np.abs(ref).max()
        assert np.abs(w - ref).max() < 5e-3 * peak, span
    # the middle support carries the force: reactions at the three lines sum to P + dead load
    total = ds.support_reaction.where(ds.support_component == "vertical").sum("support").values
    assert np.allclose(total[0], P + MU * 2 * L * 9.81, rtol=1e-9)


def fryba_midspan(t: np.ndarray, v: float, span: float, terms: int = 200) -> np.ndarray:
    n = np.arange(1, terms + 1)[:, None]
    w1 = (np.pi / span) ** 2 * C_BEND
    omega = np.pi * v / span
    alpha = omega / w1
    series = (np.sin(n * omega * t) - (alpha / n) * np.sin(n**2 * w1 * t)) / (n**2 * (n**2 - alpha**2))
    return -(2 * P * span**3 / (np.pi**4 * E * Iy)) * np.sum(series * np.sin(n * np.pi / 2), axis=0)


def test_unequal_simply_supported_spans_match_frybas_series_span_by_span():
    speed_kmh = 200.0
    v = speed_kmh / 3.6
    spans = (24.0, 40.0)
    ds = moving_force(bridge_dict(girders=[dict(spans=[spans[0]]), dict(spans=[spans[1]])]), speed_kmh)
    t = ds.time.values
    start = 0.0
    for k, length in enumerate(spans):
        on = (t >= start) & (t <= start + length / v)
        ref = fryba_midspan(t[on] - start, v, length)
        w = ds.midspan_uz.values[on, k]
        peak = np.abs(ref).max()
        assert np.abs(w - ref).max() < 5e-3 * peak, k
        start += length / v
    # the second span is at rest until the force arrives
    assert np.all(ds.midspan_uz.values[t < spans[0] / v - 1e-9, 1] == 0.0)


# --------------------------------------------------------------------------------------------------
# a span whose fixed bearing is on a flexible pier


def cantilever_with_tip_mass(tip_mass: float) -> float:
    """Fundamental circular frequency of a cantilever carrying a point mass at its free end."""
    r = tip_mass / (MU_P * H)
    f = lambda z: 1 + np.cos(z) * np.cosh(z) + z * r * (np.cos(z) * np.sinh(z) - np.sin(z) * np.cosh(z))  # noqa: E731
    z = brentq(f, 0.1, 1.875104)
    return z * z * np.sqrt(E_P * I_P / (MU_P * H**4))


STIFF_DECK = 1.0e4  # m^2: an axially rigid deck, as the closed form assumes


def pier_bridge_dict() -> dict:
    return bridge_dict(
        girders=[dict(spans=[L], fixed_support=1, area=STIFF_DECK)],
        piers=[
            dict(support=1, height=H, mass_per_length=MU_P, youngs_modulus=E_P, area=A_P, second_moment=I_P)
        ],
    )


def test_span_on_a_flexible_pier_has_the_cantilever_with_tip_mass_frequency():
    sc = validate_scenario(
        {"bridge": pier_bridge_dict(), "train": dict(vehicle="moving-load", speed_kmh=100.0)}
    )
    b = build_model(sc).bridge
    exact = cantilever_with_tip_mass(MU * L) / (2 * np.pi)
    assert b.natural_frequencies(1)[0] == pytest.approx(exact, rel=1e-4)


def test_free_longitudinal_vibration_of_the_pier_in_the_time_loop():
    """A longitudinal ground pulse, then free vibration: the pier top swings at the exact
    frequency, and the deck follows it (fixed bearing) while the sliding end does not hold it."""
    sc = validate_scenario(
        {
            "bridge": pier_bridge_dict(),
            "train": dict(vehicle="moving-load", speed=0.0, start_position=-50.0),
            "solver": dict(backend="numpy", time_step=1e-3, duration=3.0),
        }
    )
    model = build_model(sc)
    T0 = 0.2

    def pulse(t, x):  # a smooth displacement pulse of the ground, over by T0
        s = np.clip(t / T0, 0.0, 1.0)
        q = 0.01 * np.sin(np.pi * s) ** 4
        q1 = 0.01 * 4 * np.sin(np.pi * s) ** 3 * np.cos(np.pi * s) * np.pi / T0 * (t < T0)
        q2 = (
            0.01
            * (np.pi / T0) ** 2
            * (12 * np.sin(np.pi * s) ** 2 * np.cos(np.pi * s) ** 2 - 4 * np.sin(np.pi * s) ** 4)
            * (t < T0)
        )
        return q + 0 * x, q1 + 0 * x, q2 + 0 * x

    model.ground = FunctionGround(longitudinal=pulse)
    ds = svbi.simulate(sc, model=model)
    t = ds.time.values
    top = ds.pier_top_ux.values[:, 0]
    free = t > 0.5
    crossings = t[free][np.flatnonzero(np.diff(np.sign(top[free])) != 0)]
    period = 2 * np.mean(np.diff(crossings))
    exact = cantilever_with_tip_mass(MU * L)
    assert 2 * np.pi / period == pytest.approx(exact, rel=3e-3)
    assert np.abs(top[free]).max() > 1e-3  # it does swing
    # drift: the top relative to the ground at its base, and its peak among the metrics
    np.testing.assert_array_equal(ds.pier_drift.values[:, 0], top - ds.ground_ux.values)
    from svbi.runtime.study.metrics import compute_metrics

    m = compute_metrics(ds)
    assert float(m.peak_pier_drift.sel(pier=1)) == float(np.abs(ds.pier_drift).max())
    # the deck moves with the pier top (fixed bearing): midspan u equals the top's u, less the
    # deck's axial strain under its own inertia (about 1e-5 of it with this stiff deck)
    np.testing.assert_allclose(ds.midspan_ux.values[free, 0], top[free], atol=1e-4 * np.abs(top).max())
    assert float(np.abs(ds.gap_support).max()) < 1e-12


# --------------------------------------------------------------------------------------------------
# the three methods on a small viaduct: a simple span, then a continuous two-span girder, on piers


def viaduct(method: str, **sections):
    data = {k: dict(v) for k, v in VIADUCT.items()}
    for section, keys in sections.items():
        data[section] = data.get(section, {}) | keys
    data["solver"]["method"] = method
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # synthetic record shorter than the run
        return svbi.simulate(validate_scenario(data))


BILATERAL_STEP = {"time_step": 1e-3}
"""The viaduct's runs with bilateral contact take 1e-3 s steps, half the steps of the viaduct's
5e-4 s: the methods solve the same discrete problem at either step. Measured at 1e-3 s (5e-4 s):
localized = coupled-dynamic to 1.4e-10 (2e-11) of the peaks, classic's pier top within 2.0e-7
(3.2e-8) of localized's, classic's contact gaps 7200 (3900) times localized's, the bearing springs
change the pier top by 11 % (11 %)."""


@functools.cache
def bilateral_viaduct(method: str):
    """The viaduct under its earthquake with bilateral contact: one run per method for the tests
    that compare with it (the datasets are only read)."""
    return viaduct(method, contact={"normal": "bilateral"}, solver=BILATERAL_STEP)


def assert_same(a, b, names, rtol):
    for name in names:
        peak = float(np.abs(a[name]).max())
        assert peak > 0.0, name
        assert float(np.abs(a[name] - b[name]).max()) < rtol * peak, name


def test_localized_equals_coupled_dynamic_on_a_viaduct_under_an_earthquake():
    a, b = bilateral_viaduct("localized-dynamic"), bilateral_viaduct("coupled-dynamic")
    assert_same(a, b, ("midspan_uz", "contact_force", "pier_top_ux", "carbody_az", "support_reaction"), 1e-8)
    # supports follow the ground, the continuous girder stays continuous over its pier
    assert float(np.abs(a.gap_support).max()) < 1e-12
    rot = a.end_rotation.values
    assert np.abs(rot[:, 1, 1] - rot[:, 2, 0]).max() < 1e-12 * np.abs(rot).max()
    assert np.abs(rot[:, 0, 1] - rot[:, 1, 0]).max() > 1e-3 * np.abs(rot).max()  # a joint, not continuous
    # classic multipliers drift in the contact gaps, not in the bridge's own constraints
    c = bilateral_viaduct("coupled-classic")
    assert float(np.abs(c.gap_bridge).max()) > 100 * float(np.abs(a.gap_bridge).max())
    assert float(np.abs(c.pier_top_ux - a.pier_top_ux).max()) < 1e-6 * float(np.abs(a.pier_top_ux).max())


def test_localized_equals_coupled_dynamic_through_lift_offs_on_a_viaduct():
    keys = {
        "train": {"speed_kmh": 100.0},
        "solver": {"duration": 3.0},
        "earthquake": {"longitudinal": "none", "target_pga": 19.62},
        "contact": {"normal": "unilateral"},
    }
    a, b = viaduct("localized-dynamic", **keys), viaduct("coupled-dynamic", **keys)
    assert a.attrs["liftoffs"] >= 1
    assert a.attrs["liftoffs"] == b.attrs["liftoffs"]
    assert_same(a, b, ("midspan_uz", "contact_force", "pier_top_ux", "wheel_uplift"), 1e-8)


def test_two_spans_on_a_very_stiff_pier_behave_as_on_a_rigid_support():
    """The bearings' links to a pier top: with the pier made 1000 times stiffer than a real one,
    a force crossing the joint sees the rigid support of the paper's bridge."""
    span = dict(spans=[L])
    base = bridge_dict(girders=[span, span]) | {"damping_ratio": 0.02}
    stiff = dict(
        support=1, height=H, mass_per_length=MU_P, youngs_modulus=E_P, area=1e3 * A_P, second_moment=1e3 * I_P
    )
    rigid = moving_force(base, 300.0)
    on_pier = moving_force(base | {"piers": [stiff]}, 300.0)
    peak = float(np.abs(rigid.midspan_uz).max())
    assert float(np.abs(rigid.midspan_uz - on_pier.midspan_uz).max()) < 1e-4 * peak
    assert "pier_top_ux" in on_pier and "pier_top_ux" not in rigid
    # the pier base carries what the rigid support carried (three components at its base)
    assert sorted(on_pier.support_component.values[on_pier.support_pier.values == 1]) == [
        "longitudinal",
        "rotation",
        "vertical",
    ]


K_BEARING = 2.0e8  # N/m: an elastomeric bearing, softer than the pier (3 E I / H^3 = 3.3e8 N/m)


def cantilever_with_spring_mass(tip_mass: float, k: float) -> float:
    """Fundamental circular frequency of a cantilever whose tip carries a mass through a spring:
    the tip sees the mass ``M k / (k - M w^2)`` (exact for a massless spring)."""
    c = np.sqrt(E_P * I_P / (MU_P * H**4))

    def f(z: float) -> float:
        w = z * z * c
        r = tip_mass * k / (k - tip_mass * w * w) / (MU_P * H)
        return 1 + np.cos(z) * np.cosh(z) + z * r * (np.cos(z) * np.sinh(z) - np.sin(z) * np.cosh(z))

    upper = min(1.875104, np.sqrt(np.sqrt(k / tip_mass) / c) * (1 - 1e-9))  # below the spring-mass pole
    z = brentq(f, 0.1, upper)
    return z * z * c


def test_flexible_longitudinal_bearing_on_a_pier_has_the_exact_frequency():
    data = pier_bridge_dict()
    data["piers"][0]["bearing_stiffness_longitudinal"] = K_BEARING
    sc = validate_scenario({"bridge": data, "train": dict(vehicle="moving-load", speed_kmh=100.0)})
    b = build_model(sc).bridge
    exact = cantilever_with_spring_mass(MU * L, K_BEARING) / (2 * np.pi)
    rigid = cantilever_with_tip_mass(MU * L) / (2 * np.pi)
    assert exact < 0.8 * rigid  # the spring matters
    assert b.natural_frequencies(1)[0] == pytest.approx(exact, rel=1e-4)


def test_localized_equals_coupled_dynamic_with_bearing_springs():
    contact = {"normal": "bilateral"}
    springs = {"bearing_stiffness_vertical": 5.0e9, "bearing_stiffness_longitudinal": 3.0e8}
    data = {k: dict(v) for k, v in VIADUCT.items()}
    data["bridge"] = dict(data["bridge"], piers=[dict(p, **springs) for p in data["bridge"]["piers"]])
    runs = {}
    for method in ("localized-dynamic", "coupled-dynamic", "coupled-classic"):
        data["solver"] = dict(VIADUCT["solver"], method=method) | BILATERAL_STEP
        data["contact"] = contact
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            runs[method] = svbi.simulate(validate_scenario(data))
    a, b = runs["localized-dynamic"], runs["coupled-dynamic"]
    assert_same(a, b, ("midspan_uz", "contact_force", "pier_top_ux", "support_reaction"), 1e-8)
    rigid = bilateral_viaduct("localized-dynamic")
    # the springs change the piers' response (softer: more sway relative to the deck)
    assert float(np.abs(a.pier_top_ux - rigid.pier_top_ux).max()) > 1e-3 * float(
        np.abs(rigid.pier_top_ux).max()
    )
    c = runs["coupled-classic"]
    assert float(np.abs(c.pier_top_ux - a.pier_top_ux).max()) < 1e-6 * float(np.abs(a.pier_top_ux).max())


def test_the_viaduct_example_loads_prints_its_modes_and_runs(tmp_path):
    """examples/viaduct.toml (shipped with the package): valid, `svbi modes` prints the whole
    bridge's frequencies, and a short run writes piers' results."""
    from typer.testing import CliRunner

    from svbi.runtime.cli.app import _register, app
    from svbi.runtime.cli.demo import example_path
    from svbi.runtime.scenario.schema import load_scenario

    path = example_path("viaduct.toml")
    sc = load_scenario(path)
    b = build_model(sc).bridge
    assert (b.spans, len(b.piers)) == (8, 7) and not b.uniform
    _register()
    result = CliRunner().invoke(app, ["modes", str(path)])
    assert result.exit_code == 0, result.output
    assert "bridge (8 spans, 7 piers" in result.output
    first = float(result.output.split("bridge (8 spans")[1].splitlines()[1].split()[-1])
    assert first == pytest.approx(b.natural_frequencies(1)[0], abs=1e-4)  # printed to 4 decimals
    sc = load_scenario(path, overrides=["solver.duration=0.5", "train.cars=2"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        ds = svbi.simulate(sc)
    assert ds.attrs["backend"] == ("c" if c_compiler_works() else "numpy") and ds.sizes["pier"] == 7
    assert np.isfinite(ds.pier_drift.values).all()


def test_svbi_run_reports_the_peak_pier_drift(tmp_path):
    import tomli_w
    from typer.testing import CliRunner

    from svbi.runtime.cli.app import _register, app

    data = {
        "bridge": pier_bridge_dict(),
        "train": dict(vehicle="moving-load", speed_kmh=200.0),
        "earthquake": dict(longitudinal="synthetic", arrival=0.0),
        "solver": dict(backend="numpy", time_step=1e-3),
    }
    path = tmp_path / "pier.toml"
    path.write_text(tomli_w.dumps(data), encoding="utf-8")
    _register()
    result = CliRunner().invoke(app, ["run", str(path), "-o", str(tmp_path / "r.nc"), "-q"])
    assert result.exit_code == 0, result.output
    result = CliRunner().invoke(app, ["run", str(path), "-o", str(tmp_path / "r.nc")])
    line = next(x for x in result.output.splitlines() if x.startswith("pier drift: peak"))
    import xarray as xr

    with xr.open_dataset(tmp_path / "r.nc") as ds:
        peak = float(np.abs(ds.pier_drift).max())
    assert f"{1e3 * peak:.3g} mm (pier 1 = bridge.piers[0], on support line 1" in line
