"""The contact state of every step as one complementarity problem over all wheels (docs/method.md
section 12): the pivoting against brute-force enumeration, the invariants of strong-shaking runs of
the paper's train (no wheel in contact ever carries tension, raw or filtered), convergence of the
quantities that converge, the divergence guard's reading of flights, and the static start of a train
standing on the bridge."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from conftest import REPO, c_compiler_works
from test_unilateral import BRIDGE, M_S, M_W

from svbi.runtime.cli.demo import STRONG
from svbi.runtime.methods.unilateral import complementary_solve
from svbi.runtime.run.simulate import Diverged, DivergenceGuard, build_model, simulate
from svbi.runtime.scenario.schema import load_scenario, validate_scenario

PAPER = str(REPO / "examples" / "paper-2020.toml")


def needs_c() -> None:
    if not c_compiler_works():
        pytest.skip("no C compiler: the strong-shaking runs need the C loop to be quick")


# --------------------------------------------------------------------------------------------------
# the complementarity solve against enumeration


def enumerate_lcp(G, want, x0, cand):
    """Every complementary set tried: the unique solution of the P-matrix problem."""
    n = len(want)
    found = []
    idx = np.flatnonzero(cand)
    for k in range(len(idx) + 1):
        for B in itertools.combinations(idx, k):
            basic = np.zeros(n, dtype=bool)
            basic[list(B)] = True
            y = np.where(basic, 0.0, -x0)
            b, f = np.flatnonzero(basic), np.flatnonzero(~basic)
            if b.size:
                y[b] = np.linalg.solve(G[np.ix_(b, b)], want[b] - G[np.ix_(b, f)] @ y[f])
            w = G @ y - want
            if (x0[basic] + y[basic] >= -1e-9).all() and (w[cand & ~basic] >= -1e-9).all():
                found.append(y)
    return found


@pytest.mark.parametrize("seed", range(12))
def test_complementary_solve_finds_the_unique_solution(seed):
    rng = np.random.default_rng(seed)
    n = 8
    A = rng.normal(size=(n, n))
    G = A @ A.T + 0.5 * np.eye(n)  # a flexibility: symmetric positive definite
    want = rng.normal(size=n)
    x0 = np.abs(rng.normal(size=n)) * rng.integers(0, 2, size=n)
    cand = rng.random(n) < 0.8
    x0[~cand] = 0.0
    y, basic = complementary_solve(G, want, x0, cand, 0.0, "test")
    truth = enumerate_lcp(G, want, x0, cand)
    assert len(truth) == 1  # a P-matrix: one solution
    assert np.allclose(y, truth[0], rtol=0, atol=1e-10 * max(1.0, np.abs(truth[0]).max()))
    z = x0 + y
    w = G @ y - want
    assert (z[cand] >= -1e-12).all() and (w[cand & ~basic] >= 0).all()
    assert (np.abs(w[basic]) < 1e-9).all() and (z[cand & ~basic] == 0).all()


# --------------------------------------------------------------------------------------------------
# strong shaking: the paper's train, unilateral


def strong_run(scale_g: float, dt: float = 1e-4, method: str = "localized-dynamic", **extra):
    overrides = [*STRONG, f"earthquake.target_pga={9.81 * scale_g}", f"solver.time_step={dt}"]
    overrides += [f"solver.method={method}", "solver.output_every=1"]
    overrides += [f"{k}={v}" for k, v in extra.items()]
    return simulate(load_scenario(PAPER, overrides=overrides), progress=False)


def assert_contact_invariants(ds):
    P = ds.contact_force.values
    Pf = ds.contact_force_filtered.values
    state = ds.contact_state.values == 1
    assert (P[state] >= 0).all(), float(P[state].min())
    assert (P[~state] == 0).all()
    assert (Pf >= 0).all() and (Pf[~state] == 0).all()
    unloading = ds.unloading_ratio.values
    assert (unloading <= 1).all() and (unloading[~state] == 1).all()


@pytest.mark.parametrize("scale_g", [2.0, 5.0])
def test_strong_shaking_never_pulls_a_wheel_in_contact(scale_g):
    """The demo's strong-shaking run (2 g) and the same at 5 g: before the contact state was one
    problem over all wheels, wheels in contact carried down to -637 kN (2 g) and -3.2 MN (5 g)."""
    needs_c()
    ds = strong_run(scale_g)
    assert ds.attrs["liftoffs"] > 100
    assert_contact_invariants(ds)


def test_strong_shaking_coupled_dynamic_never_pulls_a_wheel_in_contact():
    """coupled-dynamic on C hands the steps around each event to NumPy: the first strong phase
    (1.6 s, measured 19 lift-offs; the whole 7 s run, 3,418 lift-offs with localized-dynamic's peak
    uplift 14.73 mm, takes two minutes and is not repeated here)."""
    needs_c()
    ds = strong_run(2.0, method="coupled-dynamic", **{"solver.duration": 1.6})
    assert ds.attrs["liftoffs"] >= 10 and ds.attrs["numpy_steps"] > 0
    assert_contact_invariants(ds)


def test_the_viaduct_example_never_pulls_a_wheel_in_contact():
    """examples/viaduct.toml as shipped (unilateral, C loop): before, 45 samples of wheels in
    contact with tensile forces, down to -1.36 MN over the deck joints."""
    needs_c()
    ds = simulate(load_scenario(str(REPO / "examples" / "viaduct.toml")), progress=False)
    assert ds.attrs["liftoffs"] > 100
    assert_contact_invariants(ds)


def test_peak_uplift_and_longest_flight_converge_the_lift_off_count_does_not():
    """What converges as dt halves (measured: peak uplift 14.73 / 14.72 mm, longest flight 95.4 /
    95.45 ms at dt = 1e-4 / 5e-5 s) and what does not (the number of lift-offs: 3425 / 1747, short
    chatters at the joints that a smaller step resolves into fewer, longer contacts)."""
    needs_c()
    a = strong_run(2.0, dt=1e-4)
    b = strong_run(2.0, dt=5e-5)
    for key in ("peak_uplift_m", "longest_flight_s"):
        assert abs(a.attrs[key] / b.attrs[key] - 1) < 0.05, key
    assert a.attrs["liftoffs"] > 1.5 * b.attrs["liftoffs"]  # documented as not converged
    assert abs(a.attrs["airborne_time_s"] / b.attrs["airborne_time_s"] - 1) < 0.15


# --------------------------------------------------------------------------------------------------
# the divergence guard


def test_a_flight_is_not_a_divergence_but_a_flight_beyond_the_limit_is_derailment():
    """A healthy run whose wheels fly higher than the gap limit (the limit set below the flights'
    height, far above the violations of wheels in contact) stops as a likely derailment, not as a
    time-step problem; with the limit above the flights it runs to its end."""
    needs_c()
    with pytest.warns(Warning, match="derailment is likely") as caught:
        ds = strong_run(5.0, **{"solver.max_gap": 1e-3, "solver.duration": 4.0})
    assert not any("time step" in str(w.message) for w in caught)
    assert ds.attrs["complete"] == 0
    ok = strong_run(5.0, **{"solver.duration": 4.0})  # the default limit, 1 m
    assert ok.attrs.get("complete", 1) == 1 and ok.attrs["peak_uplift_m"] > 0.01


def test_a_bridge_that_is_nearly_a_mechanism_is_named_as_the_cause():
    soft = validate_scenario(
        {
            "bridge": dict(BRIDGE, youngs_modulus=1e-3),
            "train": dict(vehicle="sprung-mass", speed=0.0, start_position=-10.0),
            "solver": dict(duration=0.1),
        }
    )
    guard = DivergenceGuard(build_model(soft))
    assert "nearly a mechanism" in guard._cause()
    stiff = validate_scenario(dict(soft.to_dict(), bridge=BRIDGE))
    assert "time step" in DivergenceGuard(build_model(stiff))._cause()


def test_divergence_of_a_wheel_in_contact_is_still_caught():
    guard = DivergenceGuard(build_model(load_scenario(PAPER)))

    class St:
        t = 1.0
        contact_state = np.ones(40, dtype=bool)

    gaps = {"bridge": np.full(40, 2.0)}
    with pytest.raises(Diverged, match=r"\|gap_bridge\| = 2 m exceeds"):
        guard.check_gaps(St(), gaps)
    St.contact_state = np.zeros(40, dtype=bool)
    with pytest.raises(Diverged, match="derailment is likely"):
        guard.check_gaps(St(), gaps)


# --------------------------------------------------------------------------------------------------
# a train standing on the bridge starts on the deflected bridge


def standing(initial: str | None):
    train = dict(vehicle="sprung-mass", cars=2, speed=0.0, start_position=20.0)
    train["parameters"] = dict(sprung_mass=M_S, wheel_mass=M_W, car_length=10.0)
    if initial is not None:
        train["initial"] = initial
    sc = validate_scenario(
        {
            "bridge": dict(BRIDGE, damping_ratio=0.0),
            "train": train,
            "contact": dict(creep=False),
            "solver": dict(backend="numpy", time_step=1e-3, duration=1.0, output_every=1),
        }
    )
    return simulate(sc, progress=False)


def test_a_train_standing_on_the_bridge_starts_in_static_equilibrium_by_default():
    """Undamped bridge, no earthquake: from the static start nothing moves; dropped onto the
    unloaded bridge (``train.initial = "rigid-track"``) the midspan swings about the static
    deflection up to nearly twice it, for ever."""
    still = standing(None)
    u = still.midspan_uz.values[:, 0]
    static = u[0]
    assert static < 0
    assert np.abs(u - static).max() < 1e-9 * abs(static)
    dropped = standing("rigid-track").midspan_uz.values[:, 0]
    assert dropped[0] == 0.0
    assert dropped.min() < 1.5 * static  # overshoots the static deflection by half of it or more
