"""2D Euler-Bernoulli frame element and the bridge contact rows (paper Section 2.2, Eq. 10).

Element DOFs, in this order: ``[u1, w1, theta1, u2, w2, theta2]`` — axial displacement, vertical
displacement (positive up) and rotation ``theta = dw/dx`` at the left and right node. Axial motion
uses linear shape functions, bending the Hermite cubics. Mass and stiffness matrices are obtained by
integrating the shape functions over the element, never typed in.

The contact rows are the rows of ``W_N^B`` and ``W_T^B`` of Eq. (10) for a contact at local
coordinate ``xi`` in the element: ``W_N^B`` interpolates the vertical displacement of the rail; ``W_T^B``
the longitudinal displacement of the rail head, which sits ``h`` above the neutral axis, so plane
sections give ``u_rail = u - h * dw/dx`` and the rail height couples axial and rotation DOFs.
"""

from __future__ import annotations

from functools import cache

import sympy as sp

xi = sp.Symbol("xi", real=True)
"""Local coordinate of a point in the element, 0 at the left node and 1 at the right node."""
le = sp.Symbol("le", positive=True)
"""Element length (m)."""
E = sp.Symbol("E", positive=True)
"""Young's modulus (Pa)."""
A = sp.Symbol("A", positive=True)
"""Cross-section area (m^2)."""
I = sp.Symbol("I", positive=True)  # noqa: E741 - the engineer's name for the second moment
"""Second moment of area for vertical bending (m^4)."""
mu = sp.Symbol("mu", positive=True)
"""Mass per unit length (kg/m)."""
h = sp.Symbol("h", real=True)
"""Rail head height above the neutral axis (m)."""

NDOF = 6
AXIAL = (0, 3)
BENDING = (1, 2, 4, 5)
DOF_NAMES = ("u1", "w1", "theta1", "u2", "w2", "theta2")


def element_dofs(prefix: str = "ue") -> sp.Matrix:
    """Column of symbols for the element DOF vector (e.g. displacements, velocities)."""
    return sp.Matrix([sp.Symbol(f"{prefix}_{name}", real=True) for name in DOF_NAMES])


@cache
def axial_shape() -> sp.Matrix:
    """Linear axial shape functions as a 1x6 row in element DOF order."""
    row = sp.zeros(1, NDOF)
    row[0, 0] = 1 - xi
    row[0, 3] = xi
    return row


@cache
def bending_shape() -> sp.Matrix:
    """Hermite cubic shape functions (vertical displacement) as a 1x6 row.

    The rotation entries carry ``le`` because ``theta = dw/dx = (1/le) dw/dxi``.
    """
    row = sp.zeros(1, NDOF)
    row[0, 1] = 1 - 3 * xi**2 + 2 * xi**3
    row[0, 2] = le * (xi - 2 * xi**2 + xi**3)
    row[0, 4] = 3 * xi**2 - 2 * xi**3
    row[0, 5] = le * (-(xi**2) + xi**3)
    return row


def d_dx(row: sp.Matrix, order: int = 1) -> sp.Matrix:
    """x-derivative of a row of shape functions of ``xi``: d/dx = (1/le) d/dxi."""
    out = row
    for _ in range(order):
        out = (out.diff(xi) / le).applyfunc(sp.expand)
    return out


def _integral_over_element(expr: sp.Expr) -> sp.Expr:
    """Integral over 0 <= xi <= 1 of a polynomial in ``xi`` (exact, as ``sympy.integrate`` but
    through ``Poly``, which is a hundred times faster on these integrands)."""
    antiderivative = sp.Poly(sp.expand(expr), xi).integrate()
    return sp.factor(antiderivative.eval(1) - antiderivative.eval(0))


@cache
def element_mass() -> sp.Matrix:
    """Consistent mass matrix: integral of mu N^T N over the element (axial + bending)."""
    na, nb = axial_shape(), bending_shape()
    integrand = mu * (na.T * na + nb.T * nb) * le
    return integrand.applyfunc(_integral_over_element)


@cache
def element_stiffness() -> sp.Matrix:
    """Stiffness matrix: integral of EA u'^2 + EI w''^2 over the element."""
    dna = d_dx(axial_shape(), 1)
    ddnb = d_dx(bending_shape(), 2)
    integrand = (E * A * dna.T * dna + E * I * ddnb.T * ddnb) * le
    return integrand.applyfunc(_integral_over_element)


@cache
def column_rotation() -> sp.Matrix:
    """Global ``(u, w, theta)`` of both nodes to the local DOFs of an element whose axis points up.

    A pier column is the frame element turned a quarter turn anticlockwise (its local x along global
    z): local axial ``= w``, local transverse ``= -u``, rotation unchanged.
    """
    phi = sp.pi / 2
    c, s = sp.cos(phi), sp.sin(phi)
    node = sp.Matrix([[c, s, 0], [-s, c, 0], [0, 0, 1]])
    return sp.diag(node, node)


@cache
def column_mass() -> sp.Matrix:
    """Consistent mass of a vertical column element in global DOFs ``[u1, w1, theta1, u2, w2,
    theta2]`` (node 1 at the bottom): ``R^T M_e R``."""
    r = column_rotation()
    return (r.T * element_mass() * r).applyfunc(sp.factor)


@cache
def column_stiffness() -> sp.Matrix:
    """Stiffness of a vertical column element in global DOFs (node 1 at the bottom): ``R^T K_e R``."""
    r = column_rotation()
    return (r.T * element_stiffness() * r).applyfunc(sp.factor)


@cache
def normal_row(order: int = 0) -> sp.Matrix:
    """Row of ``W_N^B(x)`` (Eq. 10) for a contact at ``xi``, or its ``order``-th x-derivative."""
    if order not in (0, 1, 2):
        raise ValueError(f"normal_row: order must be 0, 1 or 2, got {order}")
    return d_dx(bending_shape(), order)


@cache
def tangential_row(order: int = 0) -> sp.Matrix:
    """Row of ``W_T^B(x)`` (Eqs. 10, 16): rail-head longitudinal displacement ``u - h dw/dx``."""
    if order not in (0, 1):
        raise ValueError(f"tangential_row: order must be 0 or 1, got {order}")
    base = axial_shape() - h * d_dx(bending_shape(), 1)
    return d_dx(base, order) if order else base.applyfunc(sp.expand)


integral_over_element = _integral_over_element
"""Exact integral over the element of a polynomial in ``xi`` (shared with ``svbi.codegen.frame3d``)."""
