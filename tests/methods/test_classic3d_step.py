"""The 3D coupled-classic step (runtime/methods/classic3d.py) against independent truth.

* **The vertical plane is svbi's 2D coupled-classic run**: the symmetric sprung wheelset crossing
  from the approach track over a chain of two spans and off it again, with and without an
  earthquake at the supports, against ``svbi.simulate`` of the same case with
  ``method = "coupled-classic"``: midspan deflections, contact forces and the gaps (the 2D gap times
  ``cos(atan lam)``) to round-off, the drift at the joint and the span ends included.
* **Classic drifts, coupled-dynamic does not**: once the wheelset has left the deck for the rigid
  approach track, classic's gaps grow exactly linearly in time (``g'' = 0`` is imposed and Newmark
  integrates a linear motion exactly): the gap rate the slope kink at the span end left is never
  pulled back; coupled-dynamic's stabilised rows bring the same gaps back to round-off. A car
  standing on the span and rolling on its cones under a lateral load: the rolled cones' gap is
  nonlinear in the roll, so ``g'' = 0`` at every step does not keep ``g = 0`` under Newmark, and
  classic's normal gaps grow step after step where coupled-dynamic's stay at round-off.
* **Classic = coupled-dynamic to the drift**, with bounds derived, not tuned: off the deck, the
  wheelsets' vertical difference is the gaps' difference over ``cos(atan lam)`` (the ground is
  rigid and at rest); the car bodies' difference follows it on the suspension, off it by no more
  than the amplitude of the relative motion when both wheelsets move linearly (the discrete
  energy of Newmark's average acceleration is conserved for ``x'' + omega^2 x = 0``); the decks
  vibrate freely and their difference keeps its energy, which bounds its midspan deflection
  (``(e.u)^2 <= (u^T K u)(e^T K^-1 e)``).
* **Contact features**: a flange strike held at the clearance (above, on rolled cones); lift-off,
  free flight and landing in ``test_unilateral3d_step.py`` (both methods); a ``svbi.simulate`` run
  of a 3D scenario with ``coupled-classic`` (three ground components, unilateral contact).
"""

from __future__ import annotations

import numpy as np
import pytest
from cases import SW_CONICITY, SW_SPEED, ground_bump, sprung_mass_run2d, sprung_wheelset3d, sw_chain3d

import svbi
from svbi.codegen.topology3d import parse_topology3d
from svbi.runtime.methods.classic3d import CoupledClassic3D
from svbi.runtime.methods.coupled3d import CoupledDynamic3D, static_state
from svbi.runtime.model.ground import FunctionGround
from svbi.runtime.model.system3d import GROUND, System3D, Track3D, vehicle3d
from tests.methods.test_unilateral3d_step import (
    CLEARANCE,
    E_T,
    H_T,
    LATERAL,
    LB,
    SECTION,
    TOPOLOGY,
    body_load,
)

V = SW_SPEED
DT, ELEMENTS = 2e-3, 8
LAM = SW_CONICITY
R0 = 0.46  # the wheel radius of SPRUNG_WHEELSET_3D
COS = 1.0 / np.sqrt(1.0 + LAM**2)
SPANS, START, STEPS = 2, -5.0, 600  # 1.2 s: from x = -5 m to 28.3 m; off the deck after 0.9 s
SYNCHRONOUS = dict(
    vertical=ground_bump(0.005, 2 * np.pi * 2.0, t0=0.05),
    longitudinal=ground_bump(-0.03, 2 * np.pi * 2.0, t0=0.05),
)


def crossing3d(method, ground=None):
    """The car from the approach track over two undamped 10 m spans and off again: per step the
    midspan deflections, the normal forces, the normal gaps, the wheelset's and the body's vertical
    displacement, the wheelset's location, and the deck's full state."""
    b = sw_chain3d(SPANS, ELEMENTS)
    vehicle = sprung_wheelset3d()
    system = System3D(vehicle, b, Track3D(conicity=LAM), speed=V, start=START, ground=ground)
    stepper = method(system, static_state(system), DT)
    mids = [b.midspan_node(s) for s in range(SPANS)]
    out = {k: [] for k in ("w", "P", "gap", "z_ws", "z_body", "zd_ws", "zd_body", "where", "u", "ud")}
    for n in range(STEPS):
        st = stepper.step(n)
        out["w"].append([st.u[b.dof(m, "w")] for m in mids])
        out["P"].append(st.P.copy())
        out["gap"].append(stepper.gaps())
        out["z_ws"].append(st.q[vehicle.index("z_ws")])
        out["z_body"].append(st.q[vehicle.index("z_body")])
        out["zd_ws"].append(st.qd[vehicle.index("z_ws")])
        out["zd_body"].append(st.qd[vehicle.index("z_body")])
        out["where"].append(system.contact_location(st.t)[0][0])
        out["u"].append(st.u.copy())
        out["ud"].append(st.ud.copy())
    run = {k: np.array(v) for k, v in out.items()}
    run["bridge"], run["vehicle"], run["mid"] = b, vehicle, b.dof(mids[0], "w")
    run["q_max"] = max(np.abs(stepper.state.q).max(), np.abs(run["u"]).max())
    return run


def crossing2d(ground=None):
    return sprung_mass_run2d(
        SPANS, STEPS, method="coupled-classic", start=START, elements=ELEMENTS, dt=DT, ground=ground
    )


@pytest.fixture(scope="module")
def classic():
    return crossing3d(CoupledClassic3D)


@pytest.fixture(scope="module")
def dynamic():
    return crossing3d(CoupledDynamic3D)


def exit_step(run) -> int:
    """The first step with the wheelset off the deck, after the crossing."""
    on = np.flatnonzero(run["where"] != GROUND)
    return int(on[-1] + 1)


@pytest.mark.parametrize("quake", [False, True], ids=["no-earthquake", "synchronous"])
def test_vertical_plane_is_the_2d_classic_run(quake, classic) -> None:
    r3 = crossing3d(CoupledClassic3D, FunctionGround(**SYNCHRONOUS)) if quake else classic
    r2 = crossing2d(FunctionGround(**SYNCHRONOUS) if quake else None)
    w2 = np.asarray(r2.midspan_uz.values)[1:].reshape(STEPS, SPANS)
    P2 = np.asarray(r2.contact_force.values).reshape(STEPS + 1, -1)[1:, 0]
    g2 = np.asarray(r2.gap_bridge.values + r2.gap_vehicle.values).reshape(STEPS + 1, -1)[1:, 0]
    where = r3["where"]
    assert where[0] == GROUND and where[-1] == GROUND and (where != GROUND).sum() > 100
    peak = np.abs(w2).max()
    assert peak > 1e-4
    # measured 2.3e-12 (no earthquake) and 2.5e-11 (synchronous: the displacements carry the
    # ground's 0.12 m); the forces 8.8e-14 and 6.4e-12
    assert np.abs(r3["w"] - w2).max() < 1e-10 * peak
    P3 = r3["P"]
    assert np.abs(P3[:, 0] - P3[:, 1]).max() < 1e-10 * P2.max()
    assert np.abs(COS * (P3[:, 0] + P3[:, 1]) - P2).max() < 1e-10 * P2.max()
    # the gaps, drift included: the 2D gap (wheel to rail: classic has no auxiliary point) times
    # cos(atan lam) on both wheels. Nothing pulls a classic gap back, so the round-off of each step's
    # row, eps a0 |q| in g'' (|q| the largest displacement, the body's static 3.5 cm), is integrated
    # twice over the run: at most (n dt)^2 / 2 times it, 2 eps n^2 |q| (5.7e-12 m and 1.9e-11 m;
    # measured 2.3e-14 m and 8.9e-13 m, on drifts of 2.5e-5 m and 6.0e-4 m)
    assert np.abs(g2).max() > 1e-6  # the drift
    bound = 2 * np.finfo(float).eps * STEPS**2 * r3["q_max"]
    for side in (0, 1):
        assert np.abs(r3["gap"][:, side] - COS * g2).max() < bound


def test_classic_drifts_after_the_span_end(classic, dynamic) -> None:
    m = exit_step(classic)
    assert m == exit_step(dynamic) and STEPS - m > 100
    g = classic["gap"][:, 0]
    # off the deck, on rigid track at rest: g'' = 0 keeps the gap rate, Newmark integrates the
    # linear motion exactly, so the gap's second differences vanish to round-off (the gap is a
    # difference of lengths of the wheel's size: eps r0 each, 4 eps r0 for a second difference)
    second = g[m + 1 :] - 2 * g[m:-1] + g[m - 1 : -2]
    assert np.abs(second[1:]).max() < 4 * np.finfo(float).eps * R0  # measured 5.5e-17 m
    rate = (g[-1] - g[m + 1]) / ((STEPS - 2 - m) * DT)
    # the drift: 5.4e-5 m/s measured (the slope kinks at the joint and at the end), 9.0e-6 m at
    # the exit, 2.5e-5 m at the end
    assert abs(rate) > 1e-5
    assert abs(g[-1]) > 2 * abs(g[m]) > 1e-6
    # coupled-dynamic's stabilised rows pull the same gap back to round-off
    gd = dynamic["gap"][:, 0]
    assert np.abs(gd[-50:]).max() < 1e-15
    assert np.abs(g[-50:]).min() > 1e9 * np.abs(gd[-50:]).max()


def test_classic_drifts_on_rolled_cones() -> None:
    """The car standing on a span, a lateral load on its body drives the wheelset against its flange
    and rolls the car on its cones: the normal gaps are nonlinear in the roll."""
    vehicle = vehicle3d(parse_topology3d(TOPOLOGY))
    from svbi.runtime.model.span3d import simply_supported_span

    span = simply_supported_span(SECTION, LB, 4)
    track = Track3D(conicity=LAM, eccentricity=E_T, rail_height=H_T, flange_clearance=CLEARANCE)
    gaps = {}
    for cls in (CoupledClassic3D, CoupledDynamic3D):
        system = System3D(vehicle, span, track, speed=0.0, start=LB / 2)
        st = static_state(system)
        system.load = body_load(vehicle, LATERAL)
        stepper = cls(system, st, 1e-3)
        g, fg, flange = [], [], []
        for n in range(800):
            stepper.step(n)
            g.append(np.abs(stepper.gaps()).max())
            fg.append(stepper.flange_gaps()[0])
            flange.append(stepper.state.flange[0])
        g, fg, flange = np.array(g), np.array(fg), np.array(flange)
        # both: the flange struck (position-level row) and held at its clearance to round-off
        closed = flange > 0
        assert closed.any() and fg.min() > -1e-15 and np.abs(fg[closed]).max() < 1e-15
        gaps[cls.name] = g
    c, d = gaps["coupled-classic-3d"], gaps["coupled-dynamic-3d"]
    # classic: once the car rolls on its cones (the strike, about 0.18 s) the gaps grow, every
    # 0.1 s more (measured 2.5e-9 m at 0.2 s, 3.5e-8 m at 0.75 s)
    samples = c[199::100]
    assert (np.diff(samples) > 0).all() and samples[-1] > 1e-8
    # coupled-dynamic: held at the level of the deck's chatter after the strike (measured 7e-13 m)
    assert d[400:].max() < 1e-11 and samples[-1] > 1e3 * d[400:].max()


def test_classic_is_coupled_dynamic_to_the_drift(classic, dynamic) -> None:
    """Off the deck, the difference between the two runs is the drift and what it drives."""
    m = exit_step(classic)
    veh = classic["vehicle"]
    zb, zw = veh.index("z_body"), veh.index("z_ws")
    # the wheelsets: on rigid track at rest the gap is (z_ws - 0) cos(atan lam)
    dz_w = classic["z_ws"] - dynamic["z_ws"]
    dg = classic["gap"][:, 0] - dynamic["gap"][:, 0]
    scale = np.abs(dz_w[m:]).max()
    assert np.abs(dz_w[m:] - dg[m:] / COS).max() < 4 * np.finfo(float).eps * R0  # measured 5e-17 m
    assert scale > 1e-5
    assert abs(dz_w[-1]) > 2 * abs(dz_w[m])  # the difference grows with the drift
    # the car bodies: on the spring k over the wheelset (no damper, the body's only vertical tie)
    M, K, C = veh.M, veh.K, veh.C
    k, mass = K[zb, zb], M[zb, zb]
    assert K[zb, zw] == -k and np.abs(C[zb]).max() == 0.0 and np.count_nonzero(M[zb]) == 1
    omega = np.sqrt(k / mass)
    # from the step where coupled-dynamic's gap has come back to round-off, both wheelsets move
    # linearly: x = dz_body - dz_ws obeys x'' + omega^2 x = 0 and keeps its discrete energy
    s = m + np.flatnonzero(np.abs(dynamic["gap"][m:, 0]) < 1e-15)[0]
    assert STEPS - s > 50
    dz_b = classic["z_body"] - dynamic["z_body"]
    x = dz_b - dz_w
    xd = (classic["zd_body"] - dynamic["zd_body"]) - (classic["zd_ws"] - dynamic["zd_ws"])
    amplitude = np.sqrt(x[s] ** 2 + (xd[s] / omega) ** 2)
    assert np.abs(x[s:]).max() <= amplitude * (1 + 1e-9)
    # so the bodies' difference is the drift plus that bounded swing (measured 3.3e-6 m against
    # 2.9e-5 m at the end)
    # the decks: free and undamped after the exit, the difference keeps its energy
    b = classic["bridge"]
    f = b.free
    du = (classic["u"] - dynamic["u"])[:, f]
    dud = (classic["ud"] - dynamic["ud"])[:, f]
    Kf, Mf = b.K[np.ix_(f, f)], b.M[np.ix_(f, f)]
    energy = 0.5 * np.einsum("ij,jk,ik->i", dud, Mf, dud) + 0.5 * np.einsum("ij,jk,ik->i", du, Kf, du)
    assert np.abs(energy[m:] - energy[m]).max() < 1e-9 * energy[m]  # measured 3.3e-11
    e = np.zeros(len(f))
    e[list(f).index(classic["mid"])] = 1.0
    flex = e @ np.linalg.solve(Kf, e)
    dw = classic["w"][:, 0] - dynamic["w"][:, 0]
    # measured 1.2e-9 m against 4.1e-9 m
    assert np.abs(dw[m:]).max() <= np.sqrt(2 * energy[m] * flex) * (1 + 1e-9)


def test_a_3d_scenario_runs_with_coupled_classic(tmp_path) -> None:
    """``svbi.simulate`` of a 3D scenario with ``solver.method = "coupled-classic"`` (the short span
    under three ground components, unilateral contact and flange): the run completes on the classic
    step and says so."""
    from svbi.runtime.scenario.schema import load_scenario
    from tests.cases import write_short_span_3d

    sc = load_scenario(write_short_span_3d(tmp_path), overrides={"solver.method": "coupled-classic"})
    ds = svbi.simulate(sc)
    assert ds.attrs["method"] == "coupled-classic" and ds.attrs["complete"] == 1
    assert ds.attrs["steps"] == 10
    for name in ("contact_force", "normal_gap", "derailment_quotient", "midspan_uy"):
        assert np.isfinite(ds[name].values).all(), name
    assert float(ds["contact_force"].min()) > 0.0
