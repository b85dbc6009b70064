"""3D wheel-rail contact geometry: two contacts per wheelset on a twisting, swaying bridge deck.

A building block of the 3D model (docs/three-d.md), not yet used by runs. Axes and signs as in
:mod:`svbi.codegen.frame3d`: ``x`` forward, ``y`` left, ``z`` up; roll/twist ``phi`` about ``x``
(positive lifts the left side), yaw ``psi`` about ``z`` (positive nose left). Side ``s = +1`` is the
left contact, ``s = -1`` the right one. Everything below is derived from the geometry:

* **Rails.** Knife-edge rails at ``y = s b`` of the track centreline, at the rail top. The track
  centreline lies ``e`` (:data:`ecc`, the track eccentricity, positive left) beside the deck's shear
  centre and the rail top ``h`` (:data:`h_rail`) above it, so a rail point moves with the deck's
  lateral displacement ``v``, vertical ``w`` and twist ``phi_d`` at the contact section (the
  element's shape functions of :mod:`svbi.codegen.frame3d` at ``xi``) by
  ``dy = v - h phi_d``, ``dz = w + (e + s b) phi_d``. Irregularities add ``r_a`` (alignment) to both
  rails' ``y``, ``r_v`` (vertical profile) to both rails' ``z`` and ``s b r_c`` (cross-level ``r_c``,
  an angle) to the left rail's ``z`` and its opposite to the right rail's.
* **Wheels.** Each wheel is a cone of slope ``lam`` (the equivalent conicity): in the wheelset's
  frame (origin at the axle centre, which is ``r0`` above the rail top in the nominal state) the
  tread of side ``s`` is the straight line ``z' = -r0 + lam (s y' - b)`` of the cross-section; the
  rolling radius at the lateral position ``y'`` is ``r0 - lam (s y' - b)``. The wheelset has the
  lateral displacement ``y_w``, vertical ``z_w``, roll ``phi_w`` (exact rotation in the
  cross-section) and yaw ``psi_w``.
* **Normal gap** ``g_s``: the distance from the rail's knife edge to the wheel's tread along the
  tread's normal, positive when apart. For a cone on a knife edge this is exact in the
  cross-section: the rail point is taken into the wheelset frame and
  ``g_s = (-r0 + lam (s y' - b) - z') / sqrt(1 + lam^2)``. The normal (pointing from the rail into
  the wheel) is the tread's normal ``(0, -s lam, 1) / sqrt(1 + lam^2)`` turned by the roll: it leans
  inwards by the contact angle ``atan(lam)``, and a lateral load on the wheel arises from the
  normal force itself, so the gravitational stiffness comes out of the geometry.
* **Flange gap** ``g_F,s = c_f - s (y_w - y_r)``: the lateral clearance ``c_f`` minus the wheelset's
  lateral displacement relative to the track centreline ``y_r = v - h phi_d + r_a``, towards side
  ``s``. A unilateral constraint (``g_F >= 0``).
* **Yaw.** The contact of a yawed wheelset sits at ``x = -s b psi_w`` from the axle centre (first
  order); its effect on the gap and on the rolling radii is of second order in ``psi_w`` and is left
  out: the gap is taken in the cross-section through the axle.

Constraint rows and masses follow the 2D pattern of :mod:`svbi.codegen.constraints` (Eqs. 25-31):
each contact has an auxiliary point moving along its normal, ``g_V = J_w q_w - u^g`` (wheelset
side, the linearised gap's wheelset part) and ``g_B = u^g - J_e u_e - ...`` (deck side), with
``b^V = [J_w; -1] / (J_w J_w^T + 1)``, ``b^B = [1; -J_e] / (1 + J_e J_e^T)`` and the constraint masses
``b^T M b``. In 3D the gap is nonlinear in the roll, so the rows are the Jacobians at the current
state; :func:`centred_rows` gives them in the nominal state.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import sympy as sp

from svbi.codegen import frame3d

# wheelset DOFs
y_w, z_w, phi_w, psi_w = sp.symbols("y_w z_w phi_w psi_w", real=True)
"""Wheelset lateral (m, left), vertical (m, up, from the nominal height), roll (rad), yaw (rad)."""
WHEELSET_DOFS = (y_w, z_w, phi_w, psi_w)

# geometry
r0 = sp.Symbol("r0", positive=True)
"""Nominal rolling radius (m)."""
b = sp.Symbol("b", positive=True)
"""Half the distance between the contact points, the rails' lateral positions ``+-b`` (m)."""
lam = sp.Symbol("lam", nonnegative=True)
"""Equivalent conicity: the slope of the coned tread."""
ecc = sp.Symbol("e_t", real=True)
"""Track eccentricity: lateral offset of the track centreline from the deck's shear centre (m)."""
h_rail = sp.Symbol("h_t", real=True)
"""Height of the rail top above the deck's shear centre (m)."""
clearance = sp.Symbol("c_f", positive=True)
"""Lateral flange clearance of the centred wheelset, per side (m)."""

# irregularities under the wheelset
r_v, r_a, r_c = sp.symbols("r_v r_a r_c", real=True)
"""Vertical profile (m), alignment (m, left) and cross-level (rad, left rail up) under the axle."""
IRREGULARITIES = (r_v, r_a, r_c)

# deck
UE = sp.Matrix([sp.Symbol(f"ue_{name}", real=True) for name in frame3d.DOF_NAMES])
"""The deck element's 12 DOFs at the contact (:data:`svbi.codegen.frame3d.DOF_NAMES` order)."""

SIDES = (("left", 1), ("right", -1))

# rates: the contact moves along the deck at the constant speed v
v = sp.Symbol("v", positive=True)
"""Train speed (m/s)."""
WHEELSET_RATES = sp.symbols("ydot_w zdot_w phidot_w psidot_w", real=True)
"""Rates of ``[y_w, z_w, phi_w, psi_w]``."""
WHEELSET_ACCELERATIONS = sp.symbols("yddot_w zddot_w phiddot_w psiddot_w", real=True)
"""Second time derivatives of ``[y_w, z_w, phi_w, psi_w]``."""
UE_T = sp.Matrix([sp.Symbol(f"ue_t_{name}", real=True) for name in frame3d.DOF_NAMES])
"""Rates of the deck element's DOFs."""
UE_TT = sp.Matrix([sp.Symbol(f"ue_tt_{name}", real=True) for name in frame3d.DOF_NAMES])
"""Second time derivatives of the deck element's DOFs."""
IRREGULARITY_SLOPES = sp.symbols("r_v_x r_a_x r_c_x", real=True)
"""x-derivatives of ``[r_v, r_a, r_c]`` under the axle."""
IRREGULARITY_CURVATURES = sp.symbols("r_v_xx r_a_xx r_c_xx", real=True)
"""Second x-derivatives of ``[r_v, r_a, r_c]`` under the axle."""


def time_derivative(expr: sp.Expr) -> sp.Expr:
    """d/dt of an expression in the state and its first rates, the contact moving at ``v``:
    ``xi' = v / le`` (the convective terms ``v N'`` of the 2D gap, Eq. 21) and ``r' = v r_x``."""
    pairs = [
        *zip(WHEELSET_DOFS, WHEELSET_RATES, strict=True),
        *zip(WHEELSET_RATES, WHEELSET_ACCELERATIONS, strict=True),
        *zip(UE, UE_T, strict=True),
        *zip(UE_T, UE_TT, strict=True),
    ]
    out = sum((sp.diff(expr, q) * qd for q, qd in pairs), sp.Integer(0))
    out += sp.diff(expr, frame3d.xi) * v / frame3d.le
    slopes = [
        *zip(IRREGULARITIES, IRREGULARITY_SLOPES, strict=True),
        *zip(IRREGULARITY_SLOPES, IRREGULARITY_CURVATURES, strict=True),
    ]
    out += sum((sp.diff(expr, r) * v * rx for r, rx in slopes), sp.Integer(0))
    return out


def deck_section(ue: sp.Matrix = UE) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
    """Lateral ``v``, vertical ``w`` and twist ``phi_d`` of the deck at ``xi`` of the element."""
    n = frame3d.shape_functions()
    return (n["v"] * ue)[0, 0], (n["w"] * ue)[0, 0], (n["phi"] * ue)[0, 0]


def rail_point(sign: int, ue: sp.Matrix = UE) -> tuple[sp.Expr, sp.Expr]:
    """``(y, z)`` of the knife edge of side ``sign`` (relative to the nominal track centreline at the
    rail top), moved by the deck and the irregularities."""
    v, w, phi_d = deck_section(ue)
    y = sign * b + v - h_rail * phi_d + r_a
    z = w + (ecc + sign * b) * phi_d + r_v + sign * b * r_c
    return y, z


def track_lateral(ue: sp.Matrix = UE) -> sp.Expr:
    """Lateral displacement of the track centreline at the rail top, ``y_r = v - h phi_d + r_a``."""
    v, _, phi_d = deck_section(ue)
    return v - h_rail * phi_d + r_a


def _in_wheelset_frame(y: sp.Expr, z: sp.Expr) -> tuple[sp.Expr, sp.Expr]:
    """A point's coordinates in the wheelset's cross-section frame (rolled by ``phi_w``)."""
    dy, dz = y - y_w, z - (r0 + z_w)
    c, s = sp.cos(phi_w), sp.sin(phi_w)
    return c * dy + s * dz, -s * dy + c * dz


@dataclass(frozen=True)
class Contact3D:
    """One contact (``side`` left or right): geometry and gaps as expressions."""

    side: str
    sign: int
    gap: sp.Expr
    """Normal gap ``g_s`` (m), positive when apart."""
    rail: tuple[sp.Expr, sp.Expr]
    """The rail's contact point ``(y, z)``."""
    position: tuple[sp.Expr, sp.Expr, sp.Expr]
    """The contact point ``(x, y, z)`` relative to the axle centre (x to first order in the yaw)."""
    radius: sp.Expr
    """Rolling radius at the contact (m)."""
    normal: sp.Matrix
    """Unit normal (from the rail into the wheel) in the track axes."""
    flange_gap: sp.Expr
    """Lateral flange gap ``c_f - s (y_w - y_r)`` (m)."""


@cache
def contacts() -> tuple[Contact3D, Contact3D]:
    """Left and right contacts of the wheelset on the deck element."""
    out = []
    for side, sign in SIDES:
        y, z = rail_point(sign)
        yp, zp = _in_wheelset_frame(y, z)
        tread = -r0 + lam * (sign * yp - b)
        gap = (tread - zp) / sp.sqrt(1 + lam**2)
        radius = r0 - lam * (sign * yp - b)
        body_normal = sp.Matrix([0, -sign * lam, 1]) / sp.sqrt(1 + lam**2)
        c, s = sp.cos(phi_w), sp.sin(phi_w)
        roll = sp.Matrix([[1, 0, 0], [0, c, -s], [0, s, c]])
        yaw = sp.Matrix([[sp.cos(psi_w), -sp.sin(psi_w), 0], [sp.sin(psi_w), sp.cos(psi_w), 0], [0, 0, 1]])
        normal = yaw * roll * body_normal
        flange = clearance - sign * (y_w - track_lateral())
        out.append(
            Contact3D(
                side,
                sign,
                gap,
                (y, z),
                (-sign * b * psi_w, y - y_w, z - (r0 + z_w)),
                radius,
                normal,
                flange,
            )
        )
    return out[0], out[1]


@cache
def gap_rates() -> tuple[tuple[sp.Expr, sp.Expr], tuple[sp.Expr, sp.Expr]]:
    """``(g_t, g_tt)`` of the left and right normal gaps: exact time derivatives along the moving
    contact (the 3D counterpart of :func:`svbi.codegen.constraints.gap_bridge`'s ``g_t``, ``g_tt``)."""
    out = []
    for c in contacts():
        g_t = time_derivative(c.gap)
        out.append((g_t, time_derivative(g_t)))
    return out[0], out[1]


@cache
def flange_gap_rates() -> tuple[tuple[sp.Expr, sp.Expr], tuple[sp.Expr, sp.Expr]]:
    """``(g_t, g_tt)`` of the left and right flange gaps along the moving contact (as
    :func:`gap_rates`; the gap is linear in the DOFs, its rates carry the convective terms of the
    deck's shape functions and the alignment's slope and curvature)."""
    out = []
    for c in contacts():
        g_t = time_derivative(c.flange_gap)
        out.append((g_t, time_derivative(g_t)))
    return out[0], out[1]


def centred_state() -> dict[sp.Symbol, int]:
    """The nominal state: wheelset centred, deck undeformed, no irregularity."""
    state = dict.fromkeys(WHEELSET_DOFS, 0)
    state.update(dict.fromkeys(UE, 0))
    state.update(dict.fromkeys(IRREGULARITIES, 0))
    return state


@dataclass(frozen=True)
class ContactRows:
    """Jacobian rows of a gap: ``dg = J_w dq_w - J_e du_e + J_r dr`` (the 2D sign convention:
    ``J_e`` is the coefficient of the deck DOFs with the sign flipped, like ``W_hat``)."""

    wheelset: sp.Matrix
    """1x4 over ``[y_w, z_w, phi_w, psi_w]``."""
    deck: sp.Matrix
    """1x12 over the element DOFs (sign flipped: ``g`` decreases by ``J_e du_e``)."""
    irregularity: sp.Matrix
    """1x3 over ``[r_v, r_a, r_c]``."""


def rows(gap: sp.Expr) -> ContactRows:
    """The Jacobian rows of ``gap`` (any state; substitute to evaluate)."""
    jw = sp.Matrix([[sp.diff(gap, q) for q in WHEELSET_DOFS]])
    je = sp.Matrix([[-sp.diff(gap, u) for u in UE]])
    jr = sp.Matrix([[sp.diff(gap, r) for r in IRREGULARITIES]])
    return ContactRows(jw, je, jr)


@cache
def centred_rows() -> tuple[ContactRows, ContactRows]:
    """The normal-gap rows of both contacts in the nominal state."""
    state = centred_state()
    out = []
    for c in contacts():
        rw = rows(c.gap)
        out.append(
            ContactRows(
                rw.wheelset.subs(state).applyfunc(sp.simplify),
                rw.deck.subs(state).applyfunc(sp.expand),
                rw.irregularity.subs(state).applyfunc(sp.simplify),
            )
        )
    return out[0], out[1]


@cache
def flange_rows() -> tuple[ContactRows, ContactRows]:
    """The flange-gap rows (linear: the same in every state)."""
    out = []
    for c in contacts():
        rw = rows(c.flange_gap)
        out.append(ContactRows(rw.wheelset, rw.deck.applyfunc(sp.expand), rw.irregularity))
    return out[0], out[1]


# --------------------------------------------------------------------------------------------------
# b-vectors and constraint masses (the 2D pattern, Eqs. 25-31)

m_w = sp.Symbol("m_w", positive=True)
"""Wheelset mass (kg)."""
I_wx = sp.Symbol("I_wx", positive=True)
"""Wheelset roll inertia (kg m^2)."""
I_wz = sp.Symbol("I_wz", positive=True)
"""Wheelset yaw inertia (kg m^2)."""
m_g = sp.Symbol("m_g", positive=True)
"""Mass of an auxiliary contact point (kg)."""


def wheelset_mass() -> sp.Matrix:
    """Mass matrix over ``[y_w, z_w, phi_w, psi_w]``."""
    return sp.diag(m_w, m_w, I_wx, I_wz)


def b_wheelset(row: sp.Matrix) -> sp.Matrix:
    """``b^V = [J_w^T; -1] / (J_w J_w^T + 1)`` over ``[q_w; u^g]`` (Eq. 25 with ``E = 1``)."""
    return sp.Matrix.vstack(row.T, sp.Matrix([[-1]])) / ((row * row.T)[0, 0] + 1)


def b_deck(row: sp.Matrix) -> sp.Matrix:
    """``b^B = [1; -J_e^T] / (1 + J_e J_e^T)`` over ``[u^g; u_e]`` (Eq. 29)."""
    return sp.Matrix.vstack(sp.Matrix([[1]]), -row.T) / (1 + (row * row.T)[0, 0])


def mass_wheelset_constraint(row: sp.Matrix) -> sp.Expr:
    """``b^V^T diag(M_w, m_g) b^V`` (Eq. 27)."""
    bv = b_wheelset(row)
    return sp.simplify((bv.T * sp.diag(wheelset_mass(), m_g) * bv)[0, 0])


def mass_deck_constraint(row: sp.Matrix) -> sp.Expr:
    """``b^B^T diag(m_g, M_e) b^B`` with the 3D element's consistent mass (Eq. 31)."""
    norm = 1 + (row * row.T)[0, 0]
    quad = m_g + (row * frame3d.element_mass() * row.T)[0, 0]
    return sp.expand(quad) / sp.expand(norm) ** 2
