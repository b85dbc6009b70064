"""Kinematic constraints: gap functions, b-vectors, constraint masses and their discrete rows.

Paper Section 3. Three families of bilateral constraints tie the subsystems together:

* vehicle - auxiliary point, Eq. (18): ``g_V = W_i^T u^V - u^g_i``;
* auxiliary point - bridge, Eqs. (20)-(21): ``g_B = u^g_i - W_N^B(x)^T u^B - r(x)`` with the contact
  moving at speed ``v``, so ``g_B'`` and ``g_B''`` carry the convective terms ``v W'`` and ``v^2 W''``;
* bridge support - ground, Eq. (23): ``g_G = q - E^T u^B``.

Every constraint is imposed as the second-order ODE ``m g'' + c g' + k g = 0`` (Eqs. 17, 20, 22) with
``c = 2 zeta omega m`` and ``k = omega^2 m``. Inserting Newmark's (gamma = 1/2, beta = 1/4) relations
``u'' = a0 u - P`` and ``u' = a1 u - Q`` at t_{n+1} turns each into one linear row in the unknown
positions, derived here symbolically (``discrete_*`` functions); the runtime evaluates those rows.

The b-vectors (Eqs. 25, 29, 33) give each constraint's direction in the space of the DOFs it touches,
and the constraint masses (Eqs. 27, 31, 34) are ``b^T M b`` with the masses of those DOFs.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from svbi.codegen import beam

# Moving-contact kinematics
v = sp.Symbol("v", positive=True)
a_x = sp.Symbol("a_x", real=True)
"""Acceleration of the train along the track, x'' (m/s^2; negative when braking)."""
"""Train speed (m/s)."""
r, r1, r2 = sp.symbols("r r_x r_xx", real=True)
"""Rail irregularity under the contact and its first and second x-derivatives."""
q, q1, q2 = sp.symbols("q q_t q_tt", real=True)
"""Ground displacement at a support and its first and second time derivatives."""

# Newmark and constraint-ODE coefficients
dt = sp.Symbol("dt", positive=True)
kappa = sp.Symbol("kappa", nonnegative=True)
zeta = sp.Symbol("zeta", nonnegative=True)
a0 = 4 / dt**2
a1 = 2 / dt
omega = kappa / dt


def gap_vehicle(w_column: sp.Matrix, u_vehicle: sp.Matrix, u_aux: sp.Expr) -> sp.Expr:
    """Eq. (18): gap between a wheel (direction ``W_N,i^V``) and its auxiliary contact point."""
    return (w_column.T * u_vehicle)[0, 0] - u_aux


@dataclass(frozen=True)
class BridgeGap:
    """Eqs. (20)-(21): the aux-bridge gap of a contact moving at speed v through one element."""

    g: sp.Expr
    g_t: sp.Expr
    g_tt: sp.Expr
    u_aux: tuple[sp.Symbol, sp.Symbol, sp.Symbol]
    u_elem: tuple[sp.Matrix, sp.Matrix, sp.Matrix]


def gap_bridge(accelerating: bool = False) -> BridgeGap:
    """Aux-bridge gap ``g = u^g - N(x)^T u_e - r(x)`` and its exact time derivatives.

    The contact point moves, ``x' = v``, so d/dt of ``N(x(t))^T u_e(t)`` is ``N^T u_e' + v N'^T u_e``
    and the second derivative adds ``2 v N'^T u_e' + v^2 N''^T u_e`` (the convective terms of Eq. 21).
    ``accelerating``: the train's speed changes, ``x'' = a_x``, which adds ``a_x (N'^T u_e + r')`` to
    the second derivative.
    """
    ug, ug1, ug2 = sp.symbols("ug ug_t ug_tt", real=True)
    ue, ue1, ue2 = beam.element_dofs("ue"), beam.element_dofs("ue_t"), beam.element_dofs("ue_tt")
    n0, n1, n2 = beam.normal_row(0), beam.normal_row(1), beam.normal_row(2)
    g = ug - (n0 * ue)[0, 0] - r
    g_t = ug1 - (n0 * ue1)[0, 0] - v * (n1 * ue)[0, 0] - v * r1
    g_tt = ug2 - (n0 * ue2)[0, 0] - 2 * v * (n1 * ue1)[0, 0] - v**2 * (n2 * ue)[0, 0] - v**2 * r2
    if accelerating:
        g_tt = g_tt - a_x * (n1 * ue)[0, 0] - a_x * r1
    return BridgeGap(g, g_t, g_tt, (ug, ug1, ug2), (ue, ue1, ue2))


def gap_support(u_support: sp.Expr) -> sp.Expr:
    """Eq. (23): gap between a bridge support DOF and the ground motion ``q``."""
    return q - u_support


# --------------------------------------------------------------------------------------------------
# b-vectors and constraint masses


def b_vehicle(w_column: sp.Matrix, e_column: sp.Matrix) -> sp.Matrix:
    """Eq. (25): ``b_i^V = (W_i^T W_i + E_i^T E_i)^-1 [W_i; -E_i]`` over the DOFs ``[u^V; u^g]``."""
    norm = (w_column.T * w_column)[0, 0] + (e_column.T * e_column)[0, 0]
    return (sp.Matrix.vstack(w_column, -e_column) / norm).applyfunc(sp.simplify)


def mass_vehicle_constraint(b: sp.Matrix, active_mass: sp.Matrix, aux_mass: sp.Matrix) -> sp.Expr:
    """Eq. (27): ``m_N,ii^V = b_i^T diag(m~^V, m^g) b_i`` (active vehicle mass, Section 2.3)."""
    return sp.simplify((b.T * sp.diag(active_mass, aux_mass) * b)[0, 0])


def b_bridge(n_row: sp.Matrix | None = None) -> sp.Matrix:
    """Eq. (29): ``b_i^B = (E^T E + W^T W)^-1 [E; -W]`` over ``[u^g_i; u_e]`` (element DOFs)."""
    n_row = beam.normal_row(0) if n_row is None else n_row
    norm = 1 + (n_row * n_row.T)[0, 0]
    return sp.Matrix.vstack(sp.Matrix([[1]]), -n_row.T) / norm


def mass_bridge_constraint(aux_mass: sp.Expr) -> sp.Expr:
    """Eq. (31): ``m_N,ii^B = b^T diag(m^g, m_e) b`` with the consistent mass of the element.

    Positive for every ``xi``: the numerator is a sum of the positive aux mass and the positive
    definite element mass quadratic form.
    """
    n_row = beam.normal_row(0)
    norm = 1 + (n_row * n_row.T)[0, 0]
    quad = aux_mass + (n_row * beam.element_mass() * n_row.T)[0, 0]
    return sp.factor_terms(sp.expand(quad)) / sp.expand(norm) ** 2


def b_support(dof: int, ndof: int = beam.NDOF) -> sp.Matrix:
    """Eq. (33): the support constraint direction is the column of ``E^{B,g}``, a unit vector."""
    col = sp.zeros(ndof, 1)
    col[dof, 0] = 1
    return col


def mass_support_constraint(dof: int) -> sp.Expr:
    """Eq. (34): ``b^T m^B b``, the element mass on the support DOF ``dof`` (0..5)."""
    b = b_support(dof)
    return sp.simplify((b.T * beam.element_mass() * b)[0, 0])


# --------------------------------------------------------------------------------------------------
# Discrete constraint rows: g'' + 2 zeta omega g' + omega^2 g = 0 at t_{n+1} with Newmark


@dataclass(frozen=True)
class DiscreteRow:
    """A constraint at t_{n+1} written as ``coef^T u_{n+1} = rhs`` after dividing by ``d``.

    ``d = a0 + 2 zeta omega a1 + omega^2`` is the coefficient of the position in the discrete ODE.
    """

    d: sp.Expr
    row: sp.Matrix
    rhs: sp.Expr


def _newmark(u: sp.Symbol, p: sp.Symbol, qq: sp.Symbol) -> tuple[sp.Expr, sp.Expr]:
    """Newmark velocity and acceleration at t_{n+1} in terms of the new position ``u``."""
    return a1 * u - qq, a0 * u - p


def discrete_bridge_row(accelerating: bool = False) -> tuple[DiscreteRow, dict[str, sp.Matrix | sp.Symbol]]:
    """Aux-bridge constraint (Eqs. 20-21) at t_{n+1}: ``u^g - W_hat^T u_e = h_B``.

    Returns the row ``W_hat`` (1x6, coefficient of the element DOFs, with the sign flipped so the
    constraint reads ``u^g - W_hat u_e = h_B``) and ``h_B`` in terms of the Newmark history vectors
    ``P_e = a0 u_n + (4/dt) u'_n + u''_n`` and ``Q_e = a1 u_n + u'_n`` of the element DOFs and of the
    aux point, and of r, r', r''. The history symbols are returned by name. ``accelerating``: with
    the train's acceleration ``a_x`` (:func:`gap_bridge`).
    """
    gap = gap_bridge(accelerating)
    ug, ug1, ug2 = gap.u_aux
    ue, ue1, ue2 = gap.u_elem
    pg, qg = sp.symbols("P_ug Q_ug", real=True)
    pe, qe = beam.element_dofs("P_ue"), beam.element_dofs("Q_ue")
    ug_new = sp.Symbol("ug_new", real=True)
    ue_new = beam.element_dofs("ue_new")
    subs: dict[sp.Symbol, sp.Expr] = {}
    vel, acc = _newmark(ug_new, pg, qg)
    subs.update({ug: ug_new, ug1: vel, ug2: acc})
    for i in range(beam.NDOF):
        vel, acc = _newmark(ue_new[i], pe[i], qe[i])
        subs.update({ue[i]: ue_new[i], ue1[i]: vel, ue2[i]: acc})
    ode = sp.expand((gap.g_tt + 2 * zeta * omega * gap.g_t + omega**2 * gap.g).xreplace(subs))
    d = sp.factor(ode.coeff(ug_new))
    row = sp.Matrix([[-sp.expand(sp.cancel(ode.coeff(ue_new[i]) / d)) for i in range(beam.NDOF)]])
    rest = ode.subs({ug_new: 0, **{s: 0 for s in ue_new}})
    rhs = sp.expand(-rest / d)
    names: dict[str, sp.Matrix | sp.Symbol] = {"P_ug": pg, "Q_ug": qg, "P_ue": pe, "Q_ue": qe}
    return DiscreteRow(d, row, rhs), names


def discrete_point_row() -> tuple[DiscreteRow, dict[str, sp.Symbol]]:
    """A constraint ``g = target - y`` with a prescribed target (supports, Eqs. 22-24; off-bridge).

    Gives ``y_{n+1} = rhs`` with ``rhs = [(q'' + P_y) + 2 zeta omega (q' + Q_y) + omega^2 q] / d``.
    """
    y, py, qy = sp.symbols("y P_y Q_y", real=True)
    vel, acc = _newmark(y, py, qy)
    ode = sp.expand((q2 - acc) + 2 * zeta * omega * (q1 - vel) + omega**2 * (q - y))
    d = sp.factor(-ode.coeff(y))
    rhs = sp.expand(ode.subs(y, 0) / d)
    return DiscreteRow(d, sp.Matrix([[1]]), rhs), {"P_y": py, "Q_y": qy}
