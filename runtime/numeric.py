"""Numeric evaluation of the symbolic core (``svbi.codegen``) for the NumPy backend.

Nothing here is typed in by hand: every row and coefficient comes from ``svbi.codegen.beam`` and
``svbi.codegen.constraints``. Within one run the element length, the speed, the time step and the
constraint coefficients are fixed, so after substituting them every contact row is a polynomial in
the local coordinate ``xi`` of the contact. We extract the polynomial coefficients once and evaluate
all rows of all contacts with one small matrix product per step::

    rows(xi) = [1, xi, xi^2, xi^3, ...] @ coefficients

This is exact (the shape functions are polynomials) and avoids both the cost of ``lambdify`` calls in
the time loop and its broadcasting trap (a constant entry of a lambdified matrix does not broadcast
over an array argument).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
import sympy as sp
from svbi.codegen import beam, constraints


class XiPolynomials:
    """A list of expressions polynomial in ``beam.xi``, evaluated for many ``xi`` at once."""

    def __init__(self, exprs: list[sp.Expr], subs: dict[sp.Symbol, float]) -> None:
        polys = []
        for k, e in enumerate(exprs):
            value = sp.expand(sp.sympify(e).xreplace(subs))
            extra = value.free_symbols - {beam.xi}
            if extra:
                names = ", ".join(sorted(map(str, extra)))
                raise ValueError(f"expression {k} still depends on {names} after substitution")
            polys.append(sp.Poly(value, beam.xi))
        degree = max((p.degree() for p in polys), default=0)
        degree = max(degree, 0)
        coef = np.zeros((degree + 1, len(exprs)))
        for k, p in enumerate(polys):
            for (power,), c in p.terms():
                coef[power, k] = float(c)
        self.degree = degree
        self.coefficients = coef

    def __call__(self, xi: np.ndarray) -> np.ndarray:
        """Values, shape ``(len(xi), len(exprs))``."""
        xi = np.asarray(xi, dtype=float)
        powers = xi[:, None] ** np.arange(self.degree + 1)[None, :]
        return powers @ self.coefficients


# --------------------------------------------------------------------------------------------------
# contact rows on the bridge (Eqs. 10, 20-21 and their Newmark discretisation)

BRIDGE_HISTORY = ("P_ug", "Q_ug", "r", "r_x", "r_xx")


@cache
def _bridge_row_symbolic() -> tuple[sp.Expr, list[sp.Expr], dict[str, list[sp.Expr]]]:
    """The codegen discrete row, split into ``W_hat`` and the coefficients of ``h_B``.

    ``h_B`` is linear in the Newmark histories and the irregularity; we take its coefficients by
    differentiation and check that nothing is left over.
    """
    row, names = constraints.discrete_bridge_row()
    rhs = row.rhs
    scalars = {
        "P_ug": names["P_ug"],
        "Q_ug": names["Q_ug"],
        "r": constraints.r,
        "r_x": constraints.r1,
        "r_xx": constraints.r2,
    }
    coefs: dict[str, list[sp.Expr]] = {}
    rest = rhs
    for key, sym in scalars.items():
        c = sp.diff(rhs, sym)
        coefs[key] = [c]
        rest = rest - c * sym
    for key in ("P_ue", "Q_ue"):
        vec = names[key]
        cs = [sp.diff(rhs, vec[i]) for i in range(beam.NDOF)]
        coefs[key] = cs
        rest = rest - sum(c * vec[i] for i, c in enumerate(cs))
    if sp.simplify(sp.expand(rest)) != 0:
        raise AssertionError("h_B of the discrete bridge row is not linear in its histories")
    return row.d, list(row.row), coefs


@dataclass(frozen=True)
class ContactRows:
    """Shape rows and the discrete aux-bridge row of the contacts at one instant.

    All arrays are ``(n, 6)`` in element DOF order ``[u1, w1, theta1, u2, w2, theta2]`` except the
    scalar coefficients of ``h_B`` which are ``(n,)``.
    """

    N0: np.ndarray
    N1: np.ndarray
    N2: np.ndarray
    W_hat: np.ndarray
    c_P_ue: np.ndarray
    c_Q_ue: np.ndarray
    c_P_ug: np.ndarray
    c_Q_ug: np.ndarray
    c_r: np.ndarray
    c_r_x: np.ndarray
    c_r_xx: np.ndarray

    def h_bridge(
        self, p_aux: np.ndarray, q_aux: np.ndarray, p_elem: np.ndarray, q_elem: np.ndarray, contacts: Any
    ) -> np.ndarray:
        """Right-hand side ``h_B`` of the discrete aux-bridge row for contacts on the bridge.

        ``p_aux``/``q_aux`` are the Newmark histories of the point held by the row (the aux point, or
        the wheel in coupled-classic), ``p_elem``/``q_elem`` those of the element DOFs ``(n, 6)``.
        """
        return (
            self.c_P_ug * p_aux
            + self.c_Q_ug * q_aux
            + np.einsum("ij,ij->i", self.c_P_ue, p_elem)
            + np.einsum("ij,ij->i", self.c_Q_ue, q_elem)
            + self.c_r * contacts.r
            + self.c_r_x * contacts.r1
            + self.c_r_xx * contacts.r2
        )


class ContactRowKernel:
    """Evaluates ``W_N^B``, ``W_N^B'``, ``W_N^B''`` and the discrete row ``(W_hat, h_B)`` in ``xi``.

    ``W_hat`` and ``h_B`` are ``constraints.discrete_bridge_row()``: the aux-bridge gap (Eqs. 20-21,
    with the convective terms ``v W'`` and ``v^2 W''``) inserted into ``g'' + 2 zeta omega g' +
    omega^2 g = 0`` with Newmark's relations at t_{n+1} (method-notes section 2b).
    """

    def __init__(self, le: float, speed: float, dt: float, kappa: float, zeta: float) -> None:
        d, w_hat, coefs = _bridge_row_symbolic()
        subs = {
            beam.le: le,
            constraints.v: speed,
            constraints.dt: dt,
            constraints.kappa: kappa,
            constraints.zeta: zeta,
        }
        # v = 0 (a held train) is a valid substitution; SymPy's positive assumption on v only
        # matters for simplification, not for xreplace.
        exprs: list[sp.Expr] = []
        exprs += list(beam.normal_row(0))
        exprs += list(beam.normal_row(1))
        exprs += list(beam.normal_row(2))
        exprs += w_hat
        exprs += coefs["P_ue"] + coefs["Q_ue"]
        exprs += [coefs[k][0] for k in BRIDGE_HISTORY]
        self._poly = XiPolynomials(exprs, subs)
        self.d = float(d.xreplace(subs))

    def __call__(self, xi: np.ndarray) -> ContactRows:
        vals = self._poly(xi)
        six = [vals[:, 6 * k : 6 * k + 6] for k in range(6)]
        s = vals[:, 36:]
        return ContactRows(*six, s[:, 0], s[:, 1], s[:, 2], s[:, 3], s[:, 4])


class ShapeKernel:
    """``W_N^B`` (and optionally its x-derivatives) at local coordinates ``xi`` of one element size."""

    def __init__(self, le: float, orders: tuple[int, ...] = (0,)) -> None:
        exprs: list[sp.Expr] = []
        for order in orders:
            exprs += list(beam.normal_row(order))
        self._poly = XiPolynomials(exprs, {beam.le: le})
        self.orders = orders

    def __call__(self, xi: np.ndarray) -> tuple[np.ndarray, ...]:
        vals = self._poly(xi)
        return tuple(vals[:, 6 * k : 6 * k + 6] for k in range(len(self.orders)))


class AxialShapeKernel:
    """Axial displacement of the neutral axis (linear shape functions) at ``xi``."""

    def __init__(self) -> None:
        self._poly = XiPolynomials(list(beam.axial_shape()), {})

    def __call__(self, xi: np.ndarray) -> np.ndarray:
        return self._poly(xi)


# --------------------------------------------------------------------------------------------------
# point constraints with a prescribed target: supports (Eqs. 22-24), off-bridge contacts, wheel-aux


@dataclass(frozen=True)
class PointRow:
    """``y_{n+1} = c_P P_y + c_Q Q_y + c_q2 q'' + c_q1 q' + c_q q`` for a gap ``g = q - y``."""

    d: float
    c_P: float
    c_Q: float
    c_q2: float
    c_q1: float
    c_q: float

    def target(
        self, P: np.ndarray, Q: np.ndarray, q: np.ndarray, q1: np.ndarray, q2: np.ndarray
    ) -> np.ndarray:
        return self.c_P * P + self.c_Q * Q + self.c_q2 * q2 + self.c_q1 * q1 + self.c_q * q


@cache
def _point_row_symbolic() -> tuple[sp.Expr, sp.Expr, dict[str, sp.Symbol]]:
    row, names = constraints.discrete_point_row()
    return row.d, row.rhs, names


def point_row(dt: float, kappa: float, zeta: float) -> PointRow:
    """Numeric ``constraints.discrete_point_row()`` (method-notes section 2c)."""
    d, rhs, names = _point_row_symbolic()
    subs = {constraints.dt: dt, constraints.kappa: kappa, constraints.zeta: zeta}
    syms = (names["P_y"], names["Q_y"], constraints.q2, constraints.q1, constraints.q)
    coefs = [float(sp.diff(rhs, s).xreplace(subs)) for s in syms]
    return PointRow(float(d.xreplace(subs)), *coefs)


# --------------------------------------------------------------------------------------------------
# constraint masses (Eqs. 25-35), used by the monolithic coupled-dynamic method


class BridgeConstraintMass:
    """Eq. (31): ``m_N^B(xi)``, with the consistent mass of the element holding the contact."""

    def __init__(self, le: float, mu: float, aux_mass: float) -> None:
        m_g = sp.Symbol("m_g", positive=True)
        expr = constraints.mass_bridge_constraint(m_g)
        num, den = sp.fraction(sp.together(expr))
        subs = {beam.le: le, beam.mu: mu, m_g: aux_mass}
        self._num = XiPolynomials([num], subs)
        self._den = XiPolynomials([den], subs)

    def __call__(self, xi: np.ndarray) -> np.ndarray:
        return (self._num(xi) / self._den(xi))[:, 0]


def support_constraint_masses(le: float, mu: float, element_dofs: list[int]) -> np.ndarray:
    """Eq. (34): ``b^T m^B b`` for support constraints on the given element DOFs (0..5)."""
    subs = {beam.le: le, beam.mu: mu}
    return np.array([float(constraints.mass_support_constraint(k).xreplace(subs)) for k in element_dofs])


@cache
def _vehicle_constraint_mass_exprs(topology: str) -> tuple[tuple[sp.Expr, ...], tuple[sp.Symbol, ...]]:
    from svbi.codegen.vehicle import a_split, derive_vehicle

    model = derive_vehicle(topology)
    nw = model.contact_normal.shape[1]
    active, aux = model.active_mass_matrix(a_split), model.aux_masses(a_split)
    out = []
    for i in range(nw):
        e_col = sp.zeros(nw, 1)
        e_col[i, 0] = 1
        b = constraints.b_vehicle(model.contact_normal[:, i], e_col)
        out.append(constraints.mass_vehicle_constraint(b, active, aux))
    return tuple(out), tuple(p.symbol for p in model.topology.parameters.values())


def vehicle_constraint_masses(topology: str, values: dict[str, float], a: float) -> np.ndarray:
    """Eq. (27): ``m_N^V`` of each wheel-aux constraint, with the active vehicle mass."""
    from svbi.codegen.vehicle import GRAVITY, a_split, g

    exprs, symbols = _vehicle_constraint_mass_exprs(topology)
    subs: dict[sp.Symbol, float] = {a_split: a, g: GRAVITY}
    for sym in symbols:
        val = values.get(sym.name)
        if isinstance(val, int | float):
            subs[sym] = float(val)
    return np.array([float(e.xreplace(subs)) for e in exprs])
