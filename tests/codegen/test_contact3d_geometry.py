"""The 3D wheel-rail contact geometry (codegen.contact3d) against the 2D constraints, rigid-body
motions, the flange clearance and the virtual work of a deck loaded by the contact force."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from svbi.codegen import beam, constraints, frame3d
from svbi.codegen import contact3d as c3

N = frame3d.shape_functions()
IDX = {name: k for k, name in enumerate(frame3d.DOF_NAMES)}


def _vertical_plane_state() -> dict[sp.Symbol, sp.Expr]:
    """No lateral, roll or yaw motion of the wheelset, no lateral or twist motion of the deck,
    no alignment or cross-level."""
    state: dict[sp.Symbol, sp.Expr] = {c3.y_w: 0, c3.phi_w: 0, c3.psi_w: 0, c3.r_a: 0, c3.r_c: 0}
    for name in ("v1", "phi1", "psi1", "v2", "phi2", "psi2"):
        state[c3.UE[IDX[name]]] = 0
    return state


def _two_d_gap() -> sp.Expr:
    """Wheel-aux plus aux-bridge gap of the 2D constraints, on the 3D element's vertical-plane DOFs."""
    aux = sp.Symbol("u_aux", real=True)
    g_v = constraints.gap_vehicle(sp.Matrix([1]), sp.Matrix([c3.z_w]), aux)
    gap = constraints.gap_bridge()
    ug = gap.u_aux[0]
    ue2d = gap.u_elem[0]
    subs = {ug: aux, constraints.r: c3.r_v}
    subs.update({ue2d[i]: c3.UE[k] for i, k in enumerate(frame3d.VERTICAL_PLANE)})
    return g_v + gap.g.xreplace(subs)


def test_centred_contacts_touch_with_normals_leaning_inwards() -> None:
    state = c3.centred_state()
    for c in c3.contacts():
        assert sp.simplify(c.gap.subs(state)) == 0
        assert sp.simplify(c.radius.subs(state) - c3.r0) == 0
        n = c.normal.subs(state)
        # inclined inwards by the contact angle atan(lam): the lateral part points to the centreline
        assert sp.simplify(n[1] + c.sign * c3.lam / sp.sqrt(1 + c3.lam**2)) == 0
        assert sp.simplify(n[2] - 1 / sp.sqrt(1 + c3.lam**2)) == 0


def test_vertical_plane_rows_sum_to_the_2d_row() -> None:
    """Restricted to the vertical plane, each normal gap is the 2D gap times cos(atan(lam)); with
    lam -> 0 the two gaps sum to twice the 2D gap, and on the track axis (e = 0) half the sum of the
    rows is the 2D row, and the constraint masses are the 2D ones."""
    restrict = _vertical_plane_state()
    left, right = (c.gap.xreplace(restrict) for c in c3.contacts())
    two_d = _two_d_gap()
    assert sp.simplify(left - two_d / sp.sqrt(1 + c3.lam**2)) == 0
    assert sp.simplify(right - two_d / sp.sqrt(1 + c3.lam**2)) == 0
    assert sp.simplify((left + right).subs(c3.lam, 0) - 2 * two_d) == 0
    rl, rr = c3.centred_rows()
    flat = {c3.lam: 0, c3.ecc: 0}
    wheel = ((rl.wheelset + rr.wheelset) / 2).subs(flat)
    deck = ((rl.deck + rr.deck) / 2).subs(flat).applyfunc(sp.expand)
    assert wheel == sp.Matrix([[0, 1, 0, 0]])
    expected = sp.zeros(1, frame3d.NDOF)
    for i, k in enumerate(frame3d.VERTICAL_PLANE):
        expected[0, k] = beam.normal_row(0)[0, i]
    assert (deck - expected).applyfunc(sp.expand) == sp.zeros(1, frame3d.NDOF)
    m_g = c3.m_g
    two_d_mass = constraints.mass_bridge_constraint(m_g)
    assert sp.simplify(c3.mass_deck_constraint(deck) - two_d_mass) == 0
    two_d_vehicle = constraints.mass_vehicle_constraint(
        constraints.b_vehicle(sp.Matrix([1]), sp.Matrix([1])), sp.Matrix([c3.m_w]), sp.Matrix([m_g])
    )
    assert sp.simplify(c3.mass_wheelset_constraint(wheel) - two_d_vehicle) == 0


def _random_state(rng: np.random.Generator) -> dict[sp.Symbol, float]:
    state: dict[sp.Symbol, float] = {
        c3.y_w: rng.normal(0, 3e-3),
        c3.z_w: rng.normal(0, 1e-3),
        c3.phi_w: rng.normal(0, 2e-3),
        c3.psi_w: rng.normal(0, 2e-3),
        c3.r_v: rng.normal(0, 1e-3),
        c3.r_a: rng.normal(0, 1e-3),
        c3.r_c: rng.normal(0, 1e-3),
    }
    state.update({u: rng.normal(0, 1e-3) for u in c3.UE})
    return state


PARAMS = {
    c3.r0: 0.46,
    c3.b: 0.7465,
    c3.lam: 0.15,
    c3.ecc: 1.2,
    c3.h_rail: 1.9,
    frame3d.le: 2.0,
    frame3d.xi: 0.3,
    c3.clearance: 8e-3,
}


def test_rigid_translations_leave_the_gaps_unchanged() -> None:
    """Wheelset and deck translated together (laterally, vertically) in any state: the same gaps."""
    rng = np.random.default_rng(4)
    for _ in range(3):
        state = {**_random_state(rng), **PARAMS}
        for wheel, deck in ((c3.y_w, ("v1", "v2")), (c3.z_w, ("w1", "w2"))):
            shift = 2.5e-3
            moved = dict(state)
            moved[wheel] = state[wheel] + shift
            for name in deck:
                moved[c3.UE[IDX[name]]] = state[c3.UE[IDX[name]]] + shift
            for c in c3.contacts():
                g0, g1 = float(c.gap.subs(state)), float(c.gap.subs(moved))
                assert g1 == pytest.approx(g0, abs=1e-15)
                f0, f1 = float(c.flange_gap.subs(state)), float(c.flange_gap.subs(moved))
                assert f1 == pytest.approx(f0, abs=1e-15)


def test_rigid_twist_about_the_shear_centre_leaves_the_gaps_unchanged_to_first_order() -> None:
    """A small rotation alpha of wheelset and deck about the deck's shear centre (the axle centre is
    ``e`` beside and ``h + r0`` above it): the rows annihilate the rigid motion."""
    rl, rr = c3.centred_rows()
    alpha = sp.Symbol("alpha")
    dq = sp.Matrix([-alpha * (c3.h_rail + c3.r0), alpha * c3.ecc, alpha, 0])
    due = sp.zeros(frame3d.NDOF, 1)
    due[IDX["phi1"]] = due[IDX["phi2"]] = alpha
    for rows in (rl, rr):
        change = (rows.wheelset * dq)[0, 0] - (rows.deck * due)[0, 0]
        assert sp.simplify(change) == 0


def test_flange_gap_closes_exactly_at_the_clearance() -> None:
    rng = np.random.default_rng(11)
    left, right = c3.contacts()
    for _ in range(4):
        state = {**_random_state(rng), **PARAMS}
        v = float((N["v"] * c3.UE)[0, 0].subs(state))
        phi_d = float((N["phi"] * c3.UE)[0, 0].subs(state))
        y_r = v - PARAMS[c3.h_rail] * phi_d + state[c3.r_a]
        clearance = PARAMS[c3.clearance]
        for side, target in ((left, y_r + clearance), (right, y_r - clearance)):
            at = {**state, c3.y_w: target}
            assert float(side.flange_gap.subs(at)) == pytest.approx(0.0, abs=1e-16)
            other = right if side is left else left
            assert float(other.flange_gap.subs(at)) == pytest.approx(2 * clearance, rel=1e-13)
    fl, fr = c3.flange_rows()
    assert fl.wheelset == sp.Matrix([[-1, 0, 0, 0]]) and fr.wheelset == sp.Matrix([[1, 0, 0, 0]])


def test_contact_force_sways_and_twists_the_deck() -> None:
    """The constraint force of the normal gap on the deck DOFs, ``dg/du_e^T Lambda``, is the virtual
    work of the reaction ``-Lambda n`` at the rail: lateral force ``F_y`` at the rail top ``h`` above
    the shear centre and vertical ``F_z`` at ``e + s b`` beside it twist the deck by
    ``-h F_y + (e + s b) F_z`` (written out here from the shape functions)."""
    lam_n = sp.Symbol("Lambda")
    state = c3.centred_state()
    for c, rows in zip(c3.contacts(), c3.centred_rows(), strict=True):
        n = c.normal.subs(state)
        f_y, f_z = -lam_n * n[1], -lam_n * n[2]
        virtual = f_y * (N["v"] - c3.h_rail * N["phi"]) + f_z * (N["w"] + (c3.ecc + c.sign * c3.b) * N["phi"])
        generalized = -rows.deck * lam_n  # dg/du_e = -J_e
        assert (generalized - virtual).applyfunc(sp.simplify) == sp.zeros(1, frame3d.NDOF)
        # the force on the wheelset: Lambda n on the contact point, moment about the axle centre
        r = sp.Matrix(c.position).subs(state)
        force = lam_n * n
        moment_x = r[1] * force[2] - r[2] * force[1]
        expected = sp.Matrix([[force[1], force[2], moment_x, 0]])
        assert (rows.wheelset * lam_n - expected).applyfunc(sp.simplify) == sp.zeros(1, 4)


def test_gap_rates_are_the_time_derivatives_along_the_moving_contact() -> None:
    """``g_t`` and ``g_tt`` against central differences of ``g`` along a trajectory: wheelset and deck
    DOFs quadratic in time, the contact moving through the element at ``v``, irregularities
    quadratic in ``x``."""
    rng = np.random.default_rng(2)
    speed, le_value, xi0 = 70.0, 2.0, 0.2
    coef = {s: rng.normal(0, 1e-3, 3) for s in (*c3.WHEELSET_DOFS, *c3.UE)}
    irr = {s: rng.normal(0, 1e-3, 3) for s in c3.IRREGULARITIES}
    fixed = {
        c3.r0: 0.46,
        c3.b: 0.75,
        c3.lam: 0.2,
        c3.ecc: 0.9,
        c3.h_rail: 1.7,
        frame3d.le: le_value,
        c3.v: speed,
    }

    rate = dict(zip((*c3.WHEELSET_DOFS, *c3.UE), (*c3.WHEELSET_RATES, *c3.UE_T), strict=True))
    acc = dict(zip((*c3.WHEELSET_DOFS, *c3.UE), (*c3.WHEELSET_ACCELERATIONS, *c3.UE_TT), strict=True))
    slopes = zip(c3.IRREGULARITIES, c3.IRREGULARITY_SLOPES, c3.IRREGULARITY_CURVATURES, strict=True)
    families = list(slopes)

    def at(t: float) -> dict[sp.Symbol, float]:
        values = dict(fixed)
        for s, (a0, a1, a2) in coef.items():
            values[s] = a0 + a1 * t + a2 * t * t
            values[rate[s]] = a1 + 2 * a2 * t
            values[acc[s]] = 2 * a2
        x = speed * t  # distance travelled from xi0
        values[frame3d.xi] = xi0 + x / le_value
        for s, sx, sxx in families:
            a0, a1, a2 = irr[s]
            values[s] = a0 + a1 * x + a2 * x * x
            values[sx] = a1 + 2 * a2 * x
            values[sxx] = 2 * a2
        return values

    symbols = sorted(at(0.0), key=str)
    step, t0 = 1e-5, 3e-3
    for contact, (g_t, g_tt) in zip(c3.contacts(), c3.gap_rates(), strict=True):
        funcs = [sp.lambdify(symbols, e) for e in (contact.gap, g_t, g_tt)]

        def ev(f, t: float) -> float:  # noqa: ANN001
            values = at(t)
            return float(f(*[values[s] for s in symbols]))

        g = [ev(funcs[0], t0 + k * step) for k in (-1, 0, 1)]
        # central differences: truncation step^2 g'''/6 and step^2 g''''/12. The cubic shape
        # functions swept at v / le = 35 /s give g''' ~ 6 (35)^3 1e-3 ~ 260 /s^3: 4e-9 against
        # g' ~ 0.16 (2.5e-8 relative); round-off eps g / step^2 ~ 2e-9 in g''.
        assert (g[2] - g[0]) / (2 * step) == pytest.approx(ev(funcs[1], t0), rel=1e-6)
        assert (g[2] - 2 * g[1] + g[0]) / step**2 == pytest.approx(ev(funcs[2], t0), rel=1e-4)
