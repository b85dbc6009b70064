"""The generalised creep loads of codegen/creep3d.py (``creep_loads``) and the flange gap rates of
codegen/contact3d.py (``flange_gap_rates``).

* Equal and opposite: a rigid motion of the wheelset and the deck together (lateral and vertical
  translations, a rotation about the deck's shear centre) moves the wheel's contact point with the
  rail point, so the creep forces and the spin moment do no virtual work on it: the wheelset's and
  the deck's generalised loads cancel (first order, in the centred state, any forces).
* The loads on the wheelset are the force's components and its moment about the axle centre,
  written here from the contact point and the contact frame.
* The flange gap's rates against central differences of the gap along a trajectory of the contact
  moving through the element.
"""

from __future__ import annotations

import pytest
import sympy as sp

from svbi.codegen import contact3d as c3
from svbi.codegen import creep3d, frame3d

E_T, H_T = sp.Rational(3, 10), sp.Rational(6, 5)


def _deck(**dofs: float) -> sp.Matrix:
    return sp.Matrix([dofs.get(name, 0) for name in frame3d.DOF_NAMES])


@pytest.mark.parametrize("motion", ["lateral", "vertical", "roll"])
def test_rigid_motions_do_no_work(motion: str) -> None:
    centred = c3.centred_state()
    centred.update(dict.fromkeys(creep3d.UE_T, 0))
    centred.update(dict.fromkeys(c3.WHEELSET_RATES, 0))
    centred.update(dict.fromkeys(c3.IRREGULARITY_SLOPES, 0))
    centred.update({c3.ecc: E_T, c3.h_rail: H_T})
    if motion == "lateral":
        wheelset, deck = [1, 0, 0, 0], _deck(v1=1, v2=1)
    elif motion == "vertical":
        wheelset, deck = [0, 1, 0, 0], _deck(w1=1, w2=1)
    else:  # a rotation about the shear centre: the axle centre sits at (e, h + r0) from it
        wheelset, deck = [-(H_T + c3.r0), E_T, 1, 0], _deck(phi1=1, phi2=1)
    for loads in creep3d.creep_loads():
        work = (loads.wheelset.T * sp.Matrix(wheelset))[0, 0] + (loads.deck.T * deck)[0, 0]
        assert sp.simplify(work.subs(centred)) == 0


def test_wheelset_loads_are_the_force_and_its_moment() -> None:
    for loads, cr, contact in zip(creep3d.creep_loads(), creep3d.creepages(), c3.contacts(), strict=True):
        f = creep3d.creep_fx * cr.t_x + creep3d.creep_fy * cr.t_y
        moment = sp.Matrix(contact.position).cross(f) + creep3d.creep_spin * cr.normal
        expected = sp.Matrix([f[1], f[2], moment[0], moment[2]])
        assert sp.simplify(loads.wheelset - expected) == sp.zeros(4, 1)


def test_flange_gap_rates_against_central_differences() -> None:
    t = sp.Symbol("t", real=True)
    speed, le = 30.0, 2.5
    traj = {q: 1e-3 * sp.sin((k + 1) * 3.0 * t + k) for k, q in enumerate(c3.WHEELSET_DOFS)}
    traj.update({u: 1e-3 * sp.cos((k + 2) * 2.0 * t + 0.3 * k) for k, u in enumerate(c3.UE)})
    traj.update({r: 1e-3 * sp.sin(1.7 * t + k) for k, r in enumerate(c3.IRREGULARITIES)})
    rates = {
        **{qd: sp.diff(traj[q], t) for q, qd in zip(c3.WHEELSET_DOFS, c3.WHEELSET_RATES, strict=True)},
        **{
            qdd: sp.diff(traj[q], t, 2)
            for q, qdd in zip(c3.WHEELSET_DOFS, c3.WHEELSET_ACCELERATIONS, strict=True)
        },
        **{ud: sp.diff(traj[u], t) for u, ud in zip(c3.UE, c3.UE_T, strict=True)},
        **{udd: sp.diff(traj[u], t, 2) for u, udd in zip(c3.UE, c3.UE_TT, strict=True)},
    }
    # the irregularities are functions of x = v t: their slopes and curvatures are d/dt over v
    rates.update(
        {
            rx: sp.diff(traj[r], t) / speed
            for r, rx in zip(c3.IRREGULARITIES, c3.IRREGULARITY_SLOPES, strict=True)
        }
    )
    rates.update(
        {
            rxx: sp.diff(traj[r], t, 2) / speed**2
            for r, rxx in zip(c3.IRREGULARITIES, c3.IRREGULARITY_CURVATURES, strict=True)
        }
    )
    fixed = {
        c3.v: speed,
        frame3d.le: le,
        c3.h_rail: 1.2,
        c3.clearance: 0.005,
        frame3d.xi: 0.1 + speed * t / le,
    }
    for contact, (g_t, g_tt) in zip(c3.contacts(), c3.flange_gap_rates(), strict=True):
        g = sp.lambdify(t, contact.flange_gap.subs(fixed).subs(traj))
        gt = sp.lambdify(t, g_t.subs(fixed).subs(rates).subs(traj))
        gtt = sp.lambdify(t, g_tt.subs(fixed).subs(rates).subs(traj))
        t0, h = 0.02, 1e-5
        assert gt(t0) == pytest.approx((g(t0 + h) - g(t0 - h)) / (2 * h), rel=1e-7)
        assert gtt(t0) == pytest.approx((g(t0 + h) - 2 * g(t0) + g(t0 - h)) / h**2, rel=1e-4)
