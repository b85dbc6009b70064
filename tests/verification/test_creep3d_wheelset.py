"""The 3D creep forces (codegen.creep3d) against the linear coned wheelset (codegen.wheelset3d)
and against the saturation law of the 2D creep force (codegen.creep).

Consistency: a wheelset on rigid rails, held on both rails by the normal gaps of codegen.contact3d
(its roll and height follow its lateral displacement through the linearised constraints), its
creep forces linearised in ``y, psi, y', psi'``. To first order in the conicity (the linear model is
written for small contact angles) the creep parts of ``C(v)`` and ``K(v)`` of the linear model are
recovered, up to two terms that the linear model leaves out and the 3D kinematics carry, each
written out here from its cause:

* the **roll rate**: the constrained wheelset rolls at ``phi' = (lam / b) y'``, which moves both
  contact points laterally by ``r0 phi'`` against the rails: an extra lateral creepage
  ``r0 lam y' / (b v)`` on each wheel, so ``C_yy`` gains ``2 f22 r0 lam / (b v)`` and, through the
  spin moment ``f23 xi_y``, ``C_psi,y`` gains ``-2 f23 r0 lam / (b v)``;
* the **spin of a rolled cone**: the linear model turns the contact normals by the roll but not
  the axle, so its spin creepage changes by ``-phi / r0`` per wheel and its lateral creep force by
  ``2 f23 phi / r0`` (the ``K_yy`` term ``-2 f23 lam / (b r0)``); in 3D the axle rolls with the
  wheels, the angle between the axle and a cone's normal stays ``atan(lam)`` and that term is absent.

(The matrices here are of ``M q'' + C q' + K q = 0``; the creep forces are ``-C q' - K q``.)
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
import sympy as sp

from svbi.codegen import beam, creep, creep3d
from svbi.codegen import contact3d as c3
from svbi.codegen import wheelset3d as ws

Y, PSI, YD, PD = ws.y, ws.psi, ws.ydot, ws.psidot


@cache
def linearised_creep() -> tuple[sp.Matrix, sp.Matrix]:
    """``(C, K)`` of the creep forces of the constrained wheelset on rigid rails, in the symbols of
    codegen.wheelset3d."""
    left, right = c3.centred_rows()
    z, phi = sp.symbols("z phi", real=True)
    q = sp.Matrix([Y, z, phi, PSI])
    held = sp.solve([(left.wheelset * q)[0, 0], (right.wheelset * q)[0, 0]], [z, phi], dict=True)[0]
    state = {c3.y_w: Y, c3.z_w: held[z], c3.phi_w: held[phi], c3.psi_w: PSI}
    state.update(dict.fromkeys(c3.UE, 0))
    state.update(dict.fromkeys(creep3d.UE_T, 0))
    state.update(dict.fromkeys(c3.IRREGULARITIES, 0))
    state.update(dict.fromkeys(creep3d.IRREGULARITY_SLOPES, 0))
    ydot_w, zdot_w, phidot_w, psidot_w = creep3d.WHEELSET_RATES
    state.update({ydot_w: YD, zdot_w: held[z].subs(Y, YD), phidot_w: held[phi].subs(Y, YD), psidot_w: PD})
    q_y = sp.Integer(0)
    q_psi = sp.Integer(0)
    for force, contact in zip(creep3d.creep_forces(), c3.contacts(), strict=True):
        f = force.force_vector(saturated=False)
        r = sp.Matrix(contact.position)
        q_y += f[1]
        q_psi += r.cross(f)[2] + force.spin_moment * force.creepages.normal[2]
    q_y, q_psi = q_y.subs(state), q_psi.subs(state)
    zero = dict.fromkeys((Y, PSI, YD, PD), 0)
    assert sp.simplify(q_y.subs(zero)) == 0 and sp.simplify(q_psi.subs(zero)) == 0

    def grad(e: sp.Expr) -> list[sp.Expr]:
        return [sp.diff(e, s).subs(zero) for s in (Y, PSI, YD, PD)]

    gy, gp = grad(q_y), grad(q_psi)
    names = {
        c3.lam: ws.lam,
        c3.r0: ws.r0,
        c3.b: ws.b,
        creep3d.v: ws.v,
        creep3d.f11: ws.f11,
        creep3d.f22: ws.f22,
        creep3d.f23: ws.f23,
    }
    k = -sp.Matrix([[gy[0], gy[1]], [gp[0], gp[1]]]).xreplace(names)
    c = -sp.Matrix([[gy[2], gy[3]], [gp[2], gp[3]]]).xreplace(names)
    return c, k


def first_order(m: sp.Matrix) -> sp.Matrix:
    return m.applyfunc(lambda e: sp.simplify(sp.series(e, ws.lam, 0, 2).removeO()))


def test_linearised_creep_forces_are_the_linear_wheelset_creep_terms() -> None:
    c, k = linearised_creep()
    model = ws.derive_wheelset()
    creep_only = {ws.W: 0, ws.k_y: 0, ws.k_psi: 0, ws.delta0: ws.lam}  # a pure cone: delta0 = lam
    lam, r0, b, v, f22, f23 = ws.lam, ws.r0, ws.b, ws.v, ws.f22, ws.f23
    roll_rate = sp.Matrix([[2 * f22 * r0 * lam / (b * v), 0], [-2 * f23 * r0 * lam / (b * v), 0]])
    rolled_axle = sp.Matrix([[2 * f23 * lam / (b * r0), 0], [0, 0]])
    expected_c = model.damping_matrix.subs(creep_only) + roll_rate
    expected_k = model.stiffness_matrix.subs(creep_only) + rolled_axle
    assert (first_order(c) - expected_c).applyfunc(sp.simplify) == sp.zeros(2, 2)
    assert (first_order(k) - expected_k).applyfunc(sp.simplify) == sp.zeros(2, 2)


def test_creepages_of_the_centred_wheelset_on_a_moving_deck() -> None:
    """Centred wheelset, deck swaying at ``v_dot`` and heaving at ``w_dot`` under the contact: the
    lateral creepage is ``-v_dot cos(delta) / v`` less the vertical part ``w_dot sin(delta)``
    projected on the contact plane, the longitudinal creepage vanishes (written from the frame
    ``t_y = n x e_x``, ``n = (0, -s sin d, cos d)``)."""
    vd, wd = sp.symbols("vdot wdot", real=True)
    idx = {name: k for k, name in enumerate(c3.frame3d.DOF_NAMES)}
    state = dict(c3.centred_state())
    state.update(dict.fromkeys(creep3d.UE_T, 0))
    state.update(dict.fromkeys(creep3d.WHEELSET_RATES, 0))
    state.update(dict.fromkeys(creep3d.IRREGULARITY_SLOPES, 0))
    for name in ("v1", "v2"):
        state[creep3d.UE_T[idx[name]]] = vd
    for name in ("w1", "w2"):
        state[creep3d.UE_T[idx[name]]] = wd
    for cr in creep3d.creepages():
        sign = 1 if cr.side == "left" else -1
        sin_d = c3.lam / sp.sqrt(1 + c3.lam**2)
        cos_d = 1 / sp.sqrt(1 + c3.lam**2)
        # t_y = n x e_x = (0, cos d, s sin d): the rail's velocity (0, vd, wd) counts against the wheel
        assert sp.simplify(cr.xi_x.subs(state)) == 0
        assert sp.simplify(cr.xi_y.subs(state) - (-(vd * cos_d + wd * sign * sin_d) / creep3d.v)) == 0
        # a cone spins about its normal at -s sin(d) v / r0
        assert sp.simplify(cr.xi_sp.subs(state) + sign * sin_d / c3.r0) == 0


@pytest.mark.parametrize("scale", [0.3, 1.0, 2.0, 5.0])
def test_saturated_resultant_follows_shen_hedrick_elkins(scale: float) -> None:
    """Below and beyond saturation the resultant is ``mu N (beta - beta^2/3 + beta^3/27)``
    (``beta < 3``) or ``mu N``, at the direction of the linear force (the law written out here)."""
    force = creep3d.creep_forces()[0]
    xi_x, xi_y = sp.symbols("xi_x xi_y", real=True)
    fx_lin, fy_lin, _ = creep3d.linear_law(xi_x, xi_y, 0)
    eps = creep.she_factor(sp.sqrt(fx_lin**2 + fy_lin**2) / (creep.friction * creep3d.normal_load))
    values = {
        creep3d.f11: 9e6,
        creep3d.f22: 8e6,
        creep3d.f23: 2e3,
        creep.friction: 0.3,
        creep3d.normal_load: 7e4,
    }
    mu_n = 0.3 * 7e4
    # creepages with a linear resultant of scale * mu N
    direction = np.array([0.6, -0.8])
    lin = scale * mu_n
    point = {xi_x: -lin * direction[0] / 9e6, xi_y: -lin * direction[1] / 8e6}
    fx = float((eps * fx_lin).subs(values).subs(point))
    fy = float((eps * fy_lin).subs(values).subs(point))
    beta = scale
    expected = mu_n * (beta - beta**2 / 3 + beta**3 / 27) if beta < 3 else mu_n
    assert np.hypot(fx, fy) == pytest.approx(expected, rel=1e-12)
    assert np.array([fx, fy]) / np.hypot(fx, fy) == pytest.approx(direction, rel=1e-12)
    # out of contact, no creep force
    assert force.fx.subs({creep3d.normal_load: -1.0}) == 0
    assert force.fy.subs({creep3d.normal_load: 0}) == 0


def test_kalker_coefficients_of_the_load() -> None:
    """``f22 / f11 = C22 / C11`` and ``f23 / f11 = sqrt(a b) C23 / C11`` with the 2D Hertz axes."""
    k = creep3d.kalker_coefficients()
    a, bb = creep.hertz_semi_axes()
    assert sp.simplify(k[creep3d.f22] / k[creep3d.f11] - creep3d.kalker_c22 / creep.kalker_c11) == 0
    ratio = k[creep3d.f23] / k[creep3d.f11] - sp.sqrt(a * bb) * creep3d.kalker_c23 / creep.kalker_c11
    assert sp.simplify(ratio) == 0


def test_longitudinal_creepage_in_the_vertical_plane_is_the_2d_creepage() -> None:
    """Wheelset centred and in contact (``z_w = w + r_v``), no lateral, roll or yaw motion, ``lam -> 0``:
    both contacts' longitudinal creepage is the 2D law's (Eq. 16, codegen.creep.creepage) of a wheel
    without longitudinal DOF on the rail head ``h_t`` above the deck's axis:
    ``-(W_T^B u_B' + v W_T^B' u_B) / v``."""
    idx = {name: k for k, name in enumerate(c3.frame3d.DOF_NAMES)}
    restrict: dict[sp.Symbol, sp.Expr] = {
        c3.y_w: 0,
        c3.phi_w: 0,
        c3.psi_w: 0,
        c3.r_a: 0,
        c3.r_c: 0,
        c3.lam: 0,
    }
    lateral = ("v1", "phi1", "psi1", "v2", "phi2", "psi2")
    restrict.update({c3.UE[idx[n]]: 0 for n in lateral})
    restrict.update({creep3d.UE_T[idx[n]]: 0 for n in lateral})
    ydot_w, zdot_w, phidot_w, psidot_w = creep3d.WHEELSET_RATES
    restrict.update({ydot_w: 0, phidot_w: 0, psidot_w: 0})
    restrict.update({s: 0 for s in creep3d.IRREGULARITY_SLOPES[1:]})
    w_deck = (c3.frame3d.shape_functions()["w"] * c3.UE)[0, 0].xreplace(restrict)
    restrict[c3.z_w] = w_deck + c3.r_v
    plane = list(c3.frame3d.VERTICAL_PLANE)
    ue = sp.Matrix([c3.UE[k] for k in plane])
    ue_t = sp.Matrix([creep3d.UE_T[k] for k in plane])
    tangential = {beam.h: c3.h_rail}
    two_d = creep.creepage(
        sp.Matrix([[0]]),
        sp.Matrix([zdot_w]),
        beam.tangential_row(0).xreplace(tangential),
        ue_t,
        beam.tangential_row(1).xreplace(tangential),
        ue,
        0,
        speed=creep3d.v,
    )[0, 0]
    for cr in creep3d.creepages():
        assert sp.simplify(cr.xi_x.xreplace(restrict) - two_d) == 0


@pytest.mark.parametrize("sway", [0.05, 1.5])
def test_module_saturates_the_contact_forces(sway: float) -> None:
    """Centred wheelset, deck swaying at ``sway`` m/s under it: the module's saturated forces are the
    linear ones (creepages of the previous test) scaled by the Shen-Hedrick-Elkins factor of their
    resultant, written out here."""
    idx = {name: k for k, name in enumerate(c3.frame3d.DOF_NAMES)}
    lam, r0, speed, mu, load = 0.1, 0.46, 80.0, 0.3, 7e4
    f = {creep3d.f11: 9e6, creep3d.f22: 8e6, creep3d.f23: 2e3}
    state = dict(c3.centred_state())
    state.update(dict.fromkeys(creep3d.UE_T, 0))
    state.update(dict.fromkeys(creep3d.WHEELSET_RATES, 0))
    state.update(dict.fromkeys(creep3d.IRREGULARITY_SLOPES, 0))
    state.update({creep3d.UE_T[idx["v1"]]: sway, creep3d.UE_T[idx["v2"]]: sway})
    state.update({c3.lam: lam, c3.r0: r0, creep3d.v: speed, creep.friction: mu, creep3d.normal_load: load})
    state.update(f)
    state.update({c3.b: 0.75, c3.ecc: 1.1, c3.h_rail: 1.8, c3.frame3d.le: 2.0, c3.frame3d.xi: 0.4})
    sin_d, cos_d = lam / np.sqrt(1 + lam**2), 1 / np.sqrt(1 + lam**2)
    for force in creep3d.creep_forces():
        sign = 1 if force.side == "left" else -1
        xi_y, xi_sp = -sway * cos_d / speed, -sign * sin_d / r0
        fy_lin = -8e6 * xi_y - 2e3 * xi_sp
        beta = abs(fy_lin) / (mu * load)
        eps = 1 - beta / 3 + beta**2 / 27 if beta < 3 else 1 / beta
        assert float(force.fy.xreplace(state)) == pytest.approx(eps * fy_lin, rel=1e-12)
        assert float(force.fx.xreplace(state)) == pytest.approx(0.0, abs=1e-9)
