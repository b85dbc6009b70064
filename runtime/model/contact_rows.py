"""Numeric contact rows, point rows and constraint masses for the time loop, from generated kernels.

Nothing here is typed in by hand or derived at run time: every row and coefficient comes from the
generated module of the bridge element (``generated/frame2d/numpy_kernels.py``, emitted by
``svbi.codegen.python_emit`` from ``svbi.codegen.beam`` and ``svbi.codegen.constraints``). Within
one run the element length, the speed, the time step and the constraint coefficients are fixed, so
every contact row is a polynomial in the local coordinate ``xi`` of the contact; its coefficients
are generated functions of those run constants, evaluated once, and all rows of all contacts are
evaluated with one small matrix product per step::

    rows(xi) = [1, xi, xi^2, xi^3, ...] @ coefficients
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .kernels import frame2d
from .train import vehicle_model


class XiPolynomials:
    """Polynomials in ``xi`` given by their coefficients, evaluated for many ``xi`` at once."""

    def __init__(self, coefficients: np.ndarray) -> None:
        """``coefficients`` is ``(degree + 1, ncols)`` in ascending powers of xi (one column per
        polynomial), or ``(degree + 1,)`` for one polynomial."""
        coef = np.asarray(coefficients, dtype=np.float64)
        self.coefficients = coef.reshape(coef.shape[0], -1)
        self.degree = self.coefficients.shape[0] - 1

    def __call__(self, xi: np.ndarray) -> np.ndarray:
        """Values, shape ``(len(xi), ncols)``."""
        xi = np.asarray(xi, dtype=float)
        powers = xi[:, None] ** np.arange(self.degree + 1)[None, :]
        return powers @ self.coefficients


class SpanPolynomials:
    """:class:`XiPolynomials` per span: the element length differs between spans of unequal
    length, so each distinct value has its own coefficients (one table for the paper's bridge)."""

    def __init__(self, element_length: float | np.ndarray, build: Any, *more: float | np.ndarray) -> None:
        """``build(le, *more)`` returns the coefficient table for elements of length ``le``;
        ``element_length`` (and each of ``more``, e.g. the mass per length) is one value or one
        per span."""
        keys = np.column_stack([np.atleast_1d(np.asarray(v, dtype=float)) for v in (element_length, *more)])
        uniq, group = np.unique(keys, axis=0, return_inverse=True)
        self.group = group.reshape(-1)
        self.element_lengths = uniq[:, 0]
        self.polys = [XiPolynomials(build(*(float(x) for x in row))) for row in uniq]

    def __call__(self, xi: np.ndarray, span: np.ndarray | None = None) -> np.ndarray:
        if len(self.polys) == 1:
            return self.polys[0](xi)
        if span is None:
            raise ValueError("spans of unequal length: give the span of every point")
        xi = np.asarray(xi, dtype=float)
        g = self.group[np.asarray(span)]
        out = np.zeros((len(xi), self.polys[0].coefficients.shape[1]))
        for k, poly in enumerate(self.polys):
            sel = np.flatnonzero(g == k)
            if len(sel):
                out[sel] = poly(xi[sel])
        return out


# --------------------------------------------------------------------------------------------------
# contact rows on the bridge (Eqs. 10, 20-21 and their Newmark discretisation)

BRIDGE_HISTORY: tuple[str, ...] = tuple(frame2d().DATA["bridge_history"])
"""Scalar histories of ``h_B``, in the column order of the generated ``c_scalars``."""


def shape_tables(le: float, rail_height: float = 0.0) -> dict[str, np.ndarray]:
    """Coefficient tables ``(4, 6)`` of ``N0, N1, N2`` (``W_N^B`` and its x-derivatives), ``T0, T1``
    (``W_T^B`` and its x-derivative) and ``axial`` for elements of length ``le``."""
    names = ("N0", "N1", "N2", "T0", "T1", "axial")
    return dict(zip(names, frame2d().shape_coefficients(le, rail_height), strict=True))


def bridge_row_tables(
    le: float, speed: float, dt: float, kappa: float, zeta: float
) -> tuple[float, dict[str, np.ndarray]]:
    """``d`` and the coefficient tables of the discrete aux-bridge row: ``W_hat``, ``c_P_ue``,
    ``c_Q_ue`` (4 x 6) and ``c_scalars`` (4 x 5, columns ``BRIDGE_HISTORY``)."""
    w_hat, c_p, c_q, c_s, d = frame2d().bridge_row_coefficients(le, speed, (dt, kappa, zeta))
    return float(d), {"W_hat": w_hat, "c_P_ue": c_p, "c_Q_ue": c_q, "c_scalars": c_s}


def bridge_row_tables_changing_speed(
    le: float, dt: float, kappa: float, zeta: float
) -> list[dict[str, np.ndarray]]:
    """``[T0, T1, T2, Ta]``, each the tables of :func:`bridge_row_tables`, with which the discrete
    row of a train at speed v and acceleration a is ``T0 + v T1 + v^2 T2 + a Ta``: the row is an
    exact quadratic in v (taken at v = 0, 1, -1) and linear in a (``Ta`` is the generated
    ``bridge_row_acceleration_coefficients``; it changes ``W_hat`` and ``c_scalars`` only)."""
    t0, tp, tm = (bridge_row_tables(le, v, dt, kappa, zeta)[1] for v in (0.0, 1.0, -1.0))
    w_a, c_a = frame2d().bridge_row_acceleration_coefficients(le, (dt, kappa, zeta))
    t1 = {k: 0.5 * (tp[k] - tm[k]) for k in t0}
    t2 = {k: 0.5 * (tp[k] + tm[k]) - t0[k] for k in t0}
    ta = {k: np.zeros_like(v) for k, v in t0.items()}
    ta["W_hat"], ta["c_scalars"] = np.asarray(w_a, dtype=float), np.asarray(c_a, dtype=float)
    return [t0, t1, t2, ta]


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
    omega^2 g = 0`` with Newmark's relations at t_{n+1} (docs/design.md section 4b).
    """

    def __init__(
        self,
        le: float | np.ndarray,
        speed: float,
        dt: float,
        kappa: float,
        zeta: float,
        accelerating: bool = False,
    ) -> None:
        """``accelerating``: the speed changes during the run; every call then gives the speed and
        acceleration at its time (the rows are exact quadratics in v, and linear in a)."""

        # v = 0 (a held train) is a valid value: the tables are polynomials in v.
        def table(rows: dict[str, np.ndarray], shapes: dict[str, np.ndarray] | None) -> np.ndarray:
            n = [shapes[k] if shapes else np.zeros((4, 6)) for k in ("N0", "N1", "N2")]
            return np.hstack([*n, rows["W_hat"], rows["c_P_ue"], rows["c_Q_ue"], rows["c_scalars"]])

        self._poly = SpanPolynomials(
            le, lambda le: table(bridge_row_tables(le, speed, dt, kappa, zeta)[1], shape_tables(le))
        )
        self.d = bridge_row_tables(float(self._poly.element_lengths[0]), speed, dt, kappa, zeta)[0]
        self.accelerating = accelerating
        if accelerating:  # T0 + v T1 + v^2 T2 + a Ta; the shape rows are in T0 alone
            self._by_va = [
                SpanPolynomials(
                    le,
                    lambda le, k=k: table(
                        bridge_row_tables_changing_speed(le, dt, kappa, zeta)[k],
                        shape_tables(le) if k == 0 else None,
                    ),
                )
                for k in range(4)
            ]

    def __call__(
        self, xi: np.ndarray, span: np.ndarray | None = None, v: float | None = None, a: float = 0.0
    ) -> ContactRows:
        if self.accelerating and v is not None:
            p0, p1, p2, pa = self._by_va
            vals = p0(xi, span) + v * p1(xi, span) + (v * v) * p2(xi, span)
            if a != 0.0:
                vals = vals + a * pa(xi, span)
        else:
            vals = self._poly(xi, span)
        six = [vals[:, 6 * k : 6 * k + 6] for k in range(6)]
        s = vals[:, 36:]
        return ContactRows(*six, s[:, 0], s[:, 1], s[:, 2], s[:, 3], s[:, 4])


class ShapeKernel:
    """``W_N^B`` (and optionally its x-derivatives) at local coordinates ``xi`` of one element size."""

    def __init__(self, le: float | np.ndarray, orders: tuple[int, ...] = (0,)) -> None:
        self._poly = SpanPolynomials(
            le, lambda le: np.hstack([shape_tables(le)[f"N{order}"] for order in orders])
        )
        self.orders = orders

    def __call__(self, xi: np.ndarray, span: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
        vals = self._poly(xi, span)
        return tuple(vals[:, 6 * k : 6 * k + 6] for k in range(len(self.orders)))


class AxialShapeKernel:
    """Axial displacement of the neutral axis (linear shape functions) at ``xi``."""

    def __init__(self) -> None:
        self._poly = XiPolynomials(shape_tables(1.0)["axial"])

    def __call__(self, xi: np.ndarray) -> np.ndarray:
        return self._poly(xi)


class TangentialKernel:
    """``W_T^B = u - h dw/dx`` and its x-derivative (Eqs. 10, 16) at ``xi``: ``(n, 12)``."""

    def __init__(self, le: float | np.ndarray, rail_height: float) -> None:
        def table(le: float) -> np.ndarray:
            shapes = shape_tables(le, rail_height)
            return np.hstack([shapes["T0"], shapes["T1"]])

        self._poly = SpanPolynomials(le, table)

    def __call__(self, xi: np.ndarray, span: np.ndarray | None = None) -> np.ndarray:
        return self._poly(xi, span)


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

    def off_bridge_target(self, P: np.ndarray, Q: np.ndarray, contacts: Any) -> np.ndarray:
        """Target of a contact off the bridge: the rail on the rigid ground, ``Z = q + r`` with its
        time derivatives following the contact (``r' = v r_x``, ``r'' = v^2 r_xx + a r_x``, with the
        train's speed and acceleration at the contacts' time)."""
        c, v = contacts, contacts.v
        r2 = v * v * c.r2 if c.a == 0.0 else v * v * c.r2 + c.a * c.r1
        return self.target(P, Q, c.q + c.r, c.q1 + v * c.r1, c.q2 + r2)

    def wheel_target(
        self, P_wheel: np.ndarray, Q_wheel: np.ndarray, P_aux: np.ndarray, Q_aux: np.ndarray
    ) -> np.ndarray:
        """``h_V`` of the wheel-aux rows: the target of the gap ``W^T u^V - u^g`` at t_{n+1} from the
        Newmark histories of the wheel (``W^T P^V``, ``W^T Q^V``) and of its aux point."""
        return self.c_P * (P_wheel - P_aux) + self.c_Q * (Q_wheel - Q_aux)


def point_row(dt: float, kappa: float, zeta: float) -> PointRow:
    """The generated ``point_row_coefficients`` (``constraints.discrete_point_row()``,
    docs/design.md section 4)."""
    d, c = frame2d().point_row_coefficients((dt, kappa, zeta))
    return PointRow(float(d), *(float(x) for x in c))


# --------------------------------------------------------------------------------------------------
# constraint masses (Eqs. 25-35), used by the monolithic coupled-dynamic method


class BridgeConstraintMass:
    """Eq. (31): ``m_N^B(xi)``, with the consistent mass of the element holding the contact."""

    def __init__(self, le: float | np.ndarray, mu: float | np.ndarray, aux_mass: float) -> None:
        """One ``le`` and ``mu``, or one per span."""
        kernel = frame2d().bridge_constraint_mass_coefficients
        self._num = SpanPolynomials(le, lambda le, mu: kernel(le, mu, aux_mass)[0], mu)
        self._den = SpanPolynomials(le, lambda le, mu: kernel(le, mu, aux_mass)[1], mu)

    def __call__(self, xi: np.ndarray, span: np.ndarray | None = None) -> np.ndarray:
        return (self._num(xi, span) / self._den(xi, span))[:, 0]

    @property
    def tables(self) -> tuple[np.ndarray, np.ndarray]:
        """Numerator and denominator coefficients in ascending powers of ``xi`` (one span kind:
        the C loop evaluates them itself)."""
        if len(self._num.polys) != 1:
            raise ValueError("spans of different element length or mass: one table per span kind")
        return self._num.polys[0].coefficients[:, 0], self._den.polys[0].coefficients[:, 0]


def support_constraint_masses(le: float, mu: float, element_dofs: list[int]) -> np.ndarray:
    """Eq. (34): ``b^T m^B b`` for support constraints on the given element DOFs (0..5)."""
    masses = np.asarray(frame2d().support_constraint(mu, le), dtype=np.float64)
    return masses[np.asarray(element_dofs, dtype=int)]


def vehicle_constraint_masses(topology: str, values: dict[str, Any], a: float) -> np.ndarray:
    """Eq. (27): ``m_N^V`` of each wheel-aux constraint, with the active vehicle mass."""
    return vehicle_model(topology).constraint_masses(values, a)
