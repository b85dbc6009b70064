"""3D Euler-Bernoulli frame element: axial, bending in two planes and St-Venant torsion.

Axes (the bridge's, right-handed): ``x`` along the span in the direction of travel, ``y`` lateral
(positive to the left of a train moving towards ``+x``), ``z`` vertical (positive up).

Element DOFs, 6 per node, in this order::

    [u1, v1, w1, phi1, theta1, psi1, u2, v2, w2, phi2, theta2, psi2]

``u`` axial, ``v`` lateral, ``w`` vertical displacement; ``phi`` the twist (rotation about ``x``,
right hand: positive lifts the left side), ``theta = dw/dx`` the vertical slope (as in the 2D element
of :mod:`svbi.codegen.beam`: a rotation about ``-y``) and ``psi = dv/dx`` the lateral slope (a rotation
about ``z``, right hand). With ``theta`` defined as in 2D, the element restricted to ``[u, w,
theta]`` of both nodes *is* the 2D element (``I_y`` in place of ``I``); restricted to ``[u, v, psi]``
it is the 2D element with ``I_z`` in place of ``I``.

Shape functions: linear for ``u`` and ``phi``, Hermite cubics for ``v`` and ``w`` (the same as 2D).
The consistent mass integrates ``mu (u^2 + v^2 + w^2) + I_m phi^2`` over the element: ``mu`` is the mass
per length and ``I_m`` the torsional mass moment of inertia per length (kg m), its own parameter. The
default that callers use for ``I_m`` is ``mu (I_y + I_z) / A`` (mass per length times the polar radius of
gyration squared of the section); ``rho J = mu J / A`` would underestimate it several times for a box
girder, whose St-Venant constant ``J`` is far below its polar moment ``I_y + I_z``. Rotary inertia of
bending and shear deformation are left out (Euler-Bernoulli, as in 2D). The stiffness integrates
``EA u'^2 + E I_z v''^2 + E I_y w''^2 + G J phi'^2``; ``G = E / (2 (1 + nu))`` when only Poisson's ratio
is known (:func:`shear_modulus`).

Nothing here is typed in: mass and stiffness come from integrating the shape functions.
"""

from __future__ import annotations

from functools import cache

import sympy as sp

from svbi.codegen.beam import d_dx, integral_over_element, le, xi
from svbi.codegen.kernels import FRAME3D, KernelSpec, ModelSpec, column

__all__ = [
    "FRAME3D",
    "column_mass",
    "column_rotation",
    "column_stiffness",
    "element_mass",
    "element_stiffness",
    "frame3d_model_spec",
    "shear_modulus",
]

E = sp.Symbol("E", positive=True)
"""Young's modulus (Pa)."""
G = sp.Symbol("G", positive=True)
"""Shear modulus (Pa)."""
A = sp.Symbol("A", positive=True)
"""Cross-section area (m^2)."""
I_y = sp.Symbol("I_y", positive=True)
"""Second moment of area for vertical bending, about the lateral axis (m^4); ``I`` of the 2D element."""
I_z = sp.Symbol("I_z", positive=True)
"""Second moment of area for lateral bending, about the vertical axis (m^4)."""
J = sp.Symbol("J", positive=True)
"""St-Venant torsion constant (m^4)."""
mu = sp.Symbol("mu", positive=True)
"""Mass per unit length (kg/m)."""
I_m = sp.Symbol("I_m", positive=True)
"""Torsional mass moment of inertia per unit length (kg m)."""
nu = sp.Symbol("nu", real=True)
"""Poisson's ratio."""

NODE_DOFS = ("u", "v", "w", "phi", "theta", "psi")
NDOF = 12
DOF_NAMES = tuple(f"{name}{node}" for node in (1, 2) for name in NODE_DOFS)
VERTICAL_PLANE = (0, 2, 4, 6, 8, 10)
"""Indices of ``[u1, w1, theta1, u2, w2, theta2]``: the 2D element's DOFs, in its order."""
LATERAL_PLANE = (0, 1, 5, 6, 7, 11)
"""Indices of ``[u1, v1, psi1, u2, v2, psi2]``: the plan-view element."""
POISSON_DEFAULT = 0.2
"""Poisson's ratio used for ``G`` when neither ``G`` nor ``poisson_ratio`` is given (concrete)."""


def shear_modulus(young: sp.Expr = E, poisson: sp.Expr = nu) -> sp.Expr:
    """``G = E / (2 (1 + nu))`` of an isotropic material."""
    return young / (2 * (1 + poisson))


def torsional_mass_default() -> sp.Expr:
    """Default ``I_m``: mass per length times the polar radius of gyration squared,
    ``mu (I_y + I_z) / A``."""
    return mu * (I_y + I_z) / A


def _linear(first: int, second: int) -> sp.Matrix:
    row = sp.zeros(1, NDOF)
    row[0, first] = 1 - xi
    row[0, second] = xi
    return row


def _hermite(w1: int, slope1: int, w2: int, slope2: int) -> sp.Matrix:
    """Hermite cubics of a displacement whose node slopes are ``d/dx`` of it (``le`` in the slope
    entries because ``d/dx = (1/le) d/dxi``)."""
    row = sp.zeros(1, NDOF)
    row[0, w1] = 1 - 3 * xi**2 + 2 * xi**3
    row[0, slope1] = le * (xi - 2 * xi**2 + xi**3)
    row[0, w2] = 3 * xi**2 - 2 * xi**3
    row[0, slope2] = le * (-(xi**2) + xi**3)
    return row


@cache
def shape_functions() -> dict[str, sp.Matrix]:
    """Rows (1x12) interpolating ``u``, ``v``, ``w`` and ``phi`` at ``xi`` from the element DOFs."""
    i = {name: k for k, name in enumerate(DOF_NAMES)}
    return {
        "u": _linear(i["u1"], i["u2"]),
        "v": _hermite(i["v1"], i["psi1"], i["v2"], i["psi2"]),
        "w": _hermite(i["w1"], i["theta1"], i["w2"], i["theta2"]),
        "phi": _linear(i["phi1"], i["phi2"]),
    }


@cache
def element_mass() -> sp.Matrix:
    """Consistent mass: integral of ``mu (Nu^T Nu + Nv^T Nv + Nw^T Nw) + I_m Nphi^T Nphi``."""
    n = shape_functions()
    integrand = (
        mu * (n["u"].T * n["u"] + n["v"].T * n["v"] + n["w"].T * n["w"]) + I_m * n["phi"].T * n["phi"]
    ) * le
    return integrand.applyfunc(integral_over_element)


@cache
def element_stiffness() -> sp.Matrix:
    """Stiffness: integral of ``EA u'^2 + E I_z v''^2 + E I_y w''^2 + G J phi'^2``."""
    n = shape_functions()
    du, dphi = d_dx(n["u"], 1), d_dx(n["phi"], 1)
    ddv, ddw = d_dx(n["v"], 2), d_dx(n["w"], 2)
    integrand = (
        E * A * du.T * du + E * I_z * ddv.T * ddv + E * I_y * ddw.T * ddw + G * J * dphi.T * dphi
    ) * le
    return integrand.applyfunc(integral_over_element)


@cache
def column_rotation() -> sp.Matrix:
    """Global DOFs of both nodes to the local DOFs of an element whose axis points up (a pier).

    The local axes in global components: ``x'`` up (``Z``), ``y'`` lateral (``Y``), ``z' = x' x y'``
    (``-X``); their direction cosines ``Lambda`` (rows) take a global translation or rotation vector
    to local components. The rotation DOFs are ``(phi, theta, psi) = (r_x, -r_y, r_z)`` in both frames
    (``theta`` turns about ``-y``), so they transform with ``S Lambda S``, ``S = diag(1, -1, 1)``.
    Local axial ``u' = W``, local lateral ``v' = V``, local vertical ``w' = -U``: restricted to
    ``(u, w, theta)`` this is the 2D column's quarter turn (:func:`svbi.codegen.beam.column_rotation`).
    """
    x_local = sp.Matrix([0, 0, 1])
    y_local = sp.Matrix([0, 1, 0])
    z_local = x_local.cross(y_local)
    lam = sp.Matrix.vstack(x_local.T, y_local.T, z_local.T)
    s = sp.diag(1, -1, 1)
    node = sp.diag(lam, s * lam * s)
    return sp.diag(node, node)


@cache
def column_mass() -> sp.Matrix:
    """Consistent mass of a vertical 3D column element in global DOFs (node 1 at the bottom):
    ``R^T M_e R``. Its local ``I_y`` bends it along ``x`` (longitudinal sway), ``I_z`` along ``y``."""
    r = column_rotation()
    return r.T * element_mass() * r


@cache
def column_stiffness() -> sp.Matrix:
    """Stiffness of a vertical 3D column element in global DOFs (node 1 at the bottom): ``R^T K_e R``."""
    r = column_rotation()
    return r.T * element_stiffness() * r


SAMPLE: dict[str, float] = {
    # A 32 m box-girder span (the 17WCEE example's section), 2 m elements.
    "E": 35.5e9,
    "G": 35.5e9 / 2.4,
    "A": 8.63,
    "I_y": 6.58,
    "I_z": 85.86,
    "J": 15.21,
    "mu": 22.4e3,
    "I_m": 22.4e3 * (6.58 + 85.86) / 8.63,
    "le": 2.0,
}


@cache
def frame3d_model_spec() -> ModelSpec:
    """The kernels of the 3D element (model ``frame3d``): element mass and stiffness, horizontal (a
    deck) and vertical (a pier column)."""
    kernels = [
        KernelSpec(
            "element_mass",
            "Consistent mass matrix of the 3D frame element",
            [("section", column([mu, I_m])), ("le", column([le]))],
            [("M_e", element_mass())],
            {k: SAMPLE[k] for k in ("mu", "I_m", "le")},
        ),
        KernelSpec(
            "element_stiffness",
            "Stiffness matrix of the 3D frame element",
            [("section", column([E, G, A, I_y, I_z, J])), ("le", column([le]))],
            [("K_e", element_stiffness())],
            {k: SAMPLE[k] for k in ("E", "G", "A", "I_y", "I_z", "J", "le")},
        ),
        KernelSpec(
            "column_mass",
            "Consistent mass matrix of a vertical 3D column element (global DOFs, node 1 at the bottom)",
            [("section", column([mu, I_m])), ("le", column([le]))],
            [("M_e", column_mass())],
            {k: SAMPLE[k] for k in ("mu", "I_m", "le")},
        ),
        KernelSpec(
            "column_stiffness",
            "Stiffness matrix of a vertical 3D column element (global DOFs, node 1 at the bottom)",
            [("section", column([E, G, A, I_y, I_z, J])), ("le", column([le]))],
            [("K_e", column_stiffness())],
            {k: SAMPLE[k] for k in ("E", "G", "A", "I_y", "I_z", "J", "le")},
        ),
        KernelSpec(
            "shape_functions",
            "Rows (4 x 12) interpolating u, v, w and phi at xi from the element DOFs",
            [("le", column([le])), ("xi", column([xi]))],
            [("N", sp.Matrix.vstack(*(shape_functions()[k] for k in ("u", "v", "w", "phi"))))],
            {"le": SAMPLE["le"], "xi": 0.3},
        ),
    ]
    return ModelSpec(
        name=FRAME3D,
        doc="3D Euler-Bernoulli frame element (axial, two bending planes, St-Venant torsion).",
        kernels=kernels,
        parameters=[(s.name, SAMPLE[s.name]) for s in (E, G, A, I_y, I_z, J, mu, I_m)],
        sizes={"n_dofs": NDOF, "n_nodes": 2},
    )
