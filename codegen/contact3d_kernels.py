"""Kernels of the 3D wheel-rail contact (model ``contact3d``): what the 3D time step evaluates.

The expressions are those of :mod:`svbi.codegen.contact3d` (normal and flange gaps of a wheelset's
two contacts on a deck element) and :mod:`svbi.codegen.creep3d` (creepages); this module only
arranges them into named groups, each emitted as one function of ``generated/contact3d/``
(``svbi generate --all``), so the runtime evaluates them without SymPy. Adding a group is one entry
in :data:`GROUPS` (or :data:`LAW_GROUPS`) and a regeneration.

Every group of :data:`GROUPS` takes the same arguments, in this order (the ABI of the generated
functions):

* ``q_w`` ``[y_w, z_w, phi_w, psi_w]``: the wheelset's lateral, vertical, roll and yaw;
* ``q_w_t``, ``q_w_tt``: their rates and accelerations;
* ``u_e`` (12): the deck element's DOFs (:data:`svbi.codegen.frame3d.DOF_NAMES` order);
  ``u_e_t``, ``u_e_tt``: their rates and accelerations;
* ``xi``: the contact's position in the element (0 to 1);
* ``geometry`` ``[r0, b, lam, e_t, h_t, c_f, v, le]``: rolling radius, half the contact distance,
  conicity, track eccentricity, rail-top height above the shear centre, flange clearance, speed,
  element length;
* ``irregularity`` ``[r_v, r_a, r_c, r_v_x, r_a_x, r_c_x, r_v_xx, r_a_xx, r_c_xx]``: vertical
  profile, alignment, cross-level under the axle, their slopes and curvatures along ``x``;
* ``coefficients`` ``[c1, c0, a1, a0]``: the stabilisation of the discrete constraints
  ``E = g'' + c1 g' + c0 g`` (``c1 = 2 zeta omega``, ``c0 = omega^2``) and Newmark's
  ``z' = a1 z - Q``, ``z'' = a0 z - P`` of the residual Jacobians.

A group leaves unused arguments unused. ``z = [q_w, u_e]`` (16) is the contact's own unknowns; "left"
is side ``s = +1``, "right" ``s = -1``. Gradients, Hessians and Jacobians are derived symbolically
(no finite or complex step at run time).

The creep law of one contact (:data:`LAW_GROUPS`, :mod:`svbi.codegen.creep3d`) takes its own
arguments (:data:`LAW_INPUTS`):

* ``creepage`` ``[xi_x, xi_y, xi_sp]``: the contact's creepages (what the ``creepages`` group
  returns for one side);
* ``N``: its normal load (N, positive in compression);
* ``creep`` ``[E_wr, nu_wr, R_wheel, R_rail, hertz_m, hertz_n, kalker_c11, mu_f, kalker_c22,
  kalker_c23]``: the material, the radii, the Hertz coefficients, Kalker's ``C11``, the friction,
  Kalker's ``C22`` and ``C23`` (:data:`svbi.codegen.creep.PARAMETERS`, then the two 3D ones).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache

import sympy as sp

from svbi.codegen import contact3d as c3
from svbi.codegen import creep, creep3d
from svbi.codegen.beam import le, xi
from svbi.codegen.kernels import CONTACT3D, KernelSpec, ModelSpec, column

__all__ = ["CONTACT3D", "GROUPS", "INPUTS", "LAW_GROUPS", "LAW_INPUTS", "contact3d_model_spec"]

c1, c0, a1, a0 = sp.symbols("c1 c0 a1 a0", real=True)
"""Stabilisation coefficients of the discrete constraints and Newmark's rate coefficients."""

Z = (*c3.WHEELSET_DOFS, *c3.UE)
"""``z = [y_w, z_w, phi_w, psi_w, u_e (12)]``: the unknowns the gradients are taken over."""
Z_T = (*c3.WHEELSET_RATES, *c3.UE_T)
"""Rates of ``z``."""
Z_TT = (*c3.WHEELSET_ACCELERATIONS, *c3.UE_TT)
"""Accelerations of ``z``."""
GEOMETRY = (c3.r0, c3.b, c3.lam, c3.ecc, c3.h_rail, c3.clearance, c3.v, le)
"""``[r0, b, lam, e_t, h_t, c_f, v, le]``."""
IRREGULARITY = (*c3.IRREGULARITIES, *c3.IRREGULARITY_SLOPES, *c3.IRREGULARITY_CURVATURES)
"""``[r_v, r_a, r_c]``, their slopes and their curvatures."""
COEFFICIENTS = (c1, c0, a1, a0)

INPUTS: list[tuple[str, sp.ImmutableMatrix]] = [
    ("q_w", column(c3.WHEELSET_DOFS)),
    ("q_w_t", column(c3.WHEELSET_RATES)),
    ("q_w_tt", column(c3.WHEELSET_ACCELERATIONS)),
    ("u_e", column(list(c3.UE))),
    ("u_e_t", column(list(c3.UE_T))),
    ("u_e_tt", column(list(c3.UE_TT))),
    ("xi", column([xi])),
    ("geometry", column(GEOMETRY)),
    ("irregularity", column(IRREGULARITY)),
    ("coefficients", column(COEFFICIENTS)),
]
"""Arguments of every group, in ABI order (see the module docstring)."""

SAMPLE: dict[str, float] = {
    **{s.name: 1e-3 * (1 + 0.3 * i) * (-1) ** i for i, s in enumerate(Z)},
    **{s.name: 1e-2 * (1 + 0.2 * i) * (-1) ** (i + 1) for i, s in enumerate(Z_T)},
    **{s.name: 0.1 * (1 + 0.1 * i) * (-1) ** i for i, s in enumerate(Z_TT)},
    "xi": 0.3,
    "r0": 0.46,
    "b": 0.75,
    "lam": 0.15,
    "e_t": 0.4,
    "h_t": 1.2,
    "c_f": 0.008,
    "v": 50.0,
    "le": 5.0,
    **{s.name: 1e-3 * (1 + 0.5 * i) for i, s in enumerate(IRREGULARITY)},
    "c1": 2e3,
    "c0": 1e6,
    "a1": 2e3,
    "a0": 4e6,
}
"""A typical point (a slightly displaced wheelset at 50 m/s on a 5 m element)."""


def _jacobian(exprs: list[sp.Expr], over: tuple[sp.Symbol, ...]) -> sp.Matrix:
    return sp.Matrix([[sp.diff(e, q) for q in over] for e in exprs])


@cache
def normal_gaps() -> list[sp.Expr]:
    """``[g_left, g_right]``."""
    return [c.gap for c in c3.contacts()]


@cache
def normal_residuals() -> list[sp.Expr]:
    """``E_s = g_s'' + c1 g_s' + c0 g_s`` with the exact rates of :func:`contact3d.gap_rates`."""
    return [gtt + c1 * gt + c0 * g for (gt, gtt), g in zip(c3.gap_rates(), normal_gaps(), strict=True)]


@cache
def flange_gaps() -> list[sp.Expr]:
    """``[g_F,left, g_F,right]``."""
    return [c.flange_gap for c in c3.contacts()]


@cache
def flange_residuals() -> list[sp.Expr]:
    """``E_F,s = g_F'' + c1 g_F' + c0 g_F`` along the moving contact."""
    out = []
    for g in flange_gaps():
        g_t = c3.time_derivative(g)
        out.append(c3.time_derivative(g_t) + c1 * g_t + c0 * g)
    return out


def residual_jacobian(residuals: list[sp.Expr]) -> sp.Matrix:
    """``dE/dz + a1 dE/dz' + a0 dE/dz''``: the derivative along ``z_{n+1}`` with Newmark's rates."""
    return _jacobian(residuals, Z) + a1 * _jacobian(residuals, Z_T) + a0 * _jacobian(residuals, Z_TT)


@cache
def creepages() -> list[sp.Expr]:
    """``[xi_x, xi_y, xi_sp]`` of the left contact, then of the right one
    (:func:`svbi.codegen.creep3d.creepages`)."""
    return [e for cr in creep3d.creepages() for e in (cr.xi_x, cr.xi_y, cr.xi_sp)]


@cache
def creep_load_directions() -> list[sp.Matrix]:
    """Per side, the 16 x 3 derivative of the generalised creep loads on ``z`` (wheelset, then
    element) over the contact's ``[F_x, F_y, M_sp]`` (:func:`svbi.codegen.creep3d.creep_loads`:
    linear in them, so the load is this matrix times the forces)."""
    forces = (creep3d.creep_fx, creep3d.creep_fy, creep3d.creep_spin)
    return [_jacobian([*ld.wheelset, *ld.deck], forces) for ld in creep3d.creep_loads()]


CREEPAGE = (creep3d.creepage_x, creep3d.creepage_y, creep3d.creepage_spin)
"""One contact's ``[xi_x, xi_y, xi_sp]``."""
MATERIAL = (*creep.PARAMETERS, creep3d.kalker_c22, creep3d.kalker_c23)
"""``[E_wr, nu_wr, R_wheel, R_rail, hertz_m, hertz_n, kalker_c11, mu_f, kalker_c22, kalker_c23]``."""

LAW_INPUTS: list[tuple[str, sp.ImmutableMatrix]] = [
    ("creepage", column(CREEPAGE)),
    ("N", column([creep3d.normal_load])),
    ("creep", column(MATERIAL)),
]
"""Arguments of every creep-law group, in ABI order (see the module docstring)."""

LAW_SAMPLE: dict[str, float] = {
    "xi_cx": 1e-3,
    "xi_cy": -2e-3,
    "xi_csp": 0.05,
    "N_c": 8e4,
    "E_wr": 2.1e11,
    "nu_wr": 0.28,
    "R_wheel": 0.46,
    "R_rail": 0.3,
    "hertz_m": 1.2,
    "hertz_n": 0.85,
    "kalker_c11": 4.1,
    "mu_f": 0.3,
    "kalker_c22": 3.6,
    "kalker_c23": 1.5,
}
"""A typical contact (a wheel load of 80 kN, below saturation)."""


@cache
def kalker_coefficients() -> list[sp.Expr]:
    """``[f11, f22, f23]`` under the normal load (:func:`svbi.codegen.creep3d.kalker_coefficients`)."""
    f = creep3d.kalker_coefficients()
    return [f[creep3d.f11], f[creep3d.f22], f[creep3d.f23]]


@cache
def creep_law() -> list[sp.Expr]:
    """The saturated ``[F_x, F_y]`` and the spin moment of one contact in its creepages
    (:func:`svbi.codegen.creep3d.saturated_law`), Kalker's coefficients under its load; all three
    zero for a contact out of load (``N <= 0``)."""
    _, _, mz, fx, fy = creep3d.saturated_law(*CREEPAGE)
    mz = sp.Piecewise((sp.S.Zero, creep3d.normal_load <= 0), (mz, True))
    f = dict(zip((creep3d.f11, creep3d.f22, creep3d.f23), kalker_coefficients(), strict=True))
    return [e.xreplace(f) for e in (fx, fy, mz)]


def _hessians(exprs: list[sp.Expr], names: tuple[str, str]) -> list[tuple[str, sp.Matrix]]:
    out = []
    for name, e in zip(names, exprs, strict=True):
        grad = [sp.diff(e, q) for q in Z]
        out.append((name, _jacobian(grad, Z)))
    return out


@dataclass(frozen=True)
class Group:
    """One generated function: its name, what it returns (docstring) and its outputs."""

    name: str
    doc: str
    outputs: Callable[[], list[tuple[str, sp.Matrix]]]
    inputs: list[tuple[str, sp.ImmutableMatrix]] | None = None
    """Its arguments; None: :data:`INPUTS`."""
    sample: dict[str, float] | None = None
    """A typical point of its arguments; None: :data:`SAMPLE`."""


GROUPS: list[Group] = [
    Group(
        "normal_gaps",
        "Normal gaps [g_left, g_right] (m, positive apart)",
        lambda: [("g", sp.Matrix(normal_gaps()))],
    ),
    Group(
        "normal_gap_gradients",
        "Gradients of the normal gaps over z = [q_w, u_e], one row per side",
        lambda: [("dg_dz", _jacobian(normal_gaps(), Z))],
    ),
    Group(
        "normal_gap_hessians",
        "Hessians of the normal gaps over z (16x16 each)",
        lambda: _hessians(normal_gaps(), ("H_left", "H_right")),
    ),
    Group(
        "normal_residuals",
        "Discrete normal constraints E = g'' + c1 g' + c0 g of both sides (exact rates, moving contact)",
        lambda: [("E", sp.Matrix(normal_residuals()))],
    ),
    Group(
        "normal_residual_jacobians",
        "dE/dz + a1 dE/dz' + a0 dE/dz'' of the normal constraints, one row per side",
        lambda: [("dE_dz", residual_jacobian(normal_residuals()))],
    ),
    Group(
        "flange_gaps",
        "Flange gaps [g_F_left, g_F_right] = c_f - s (y_w - y_r) (m, unilateral: g_F >= 0)",
        lambda: [("g_F", sp.Matrix(flange_gaps()))],
    ),
    Group(
        "flange_gap_gradients",
        "Gradients of the flange gaps over z, one row per side (linear gaps: no Hessian)",
        lambda: [("dgF_dz", _jacobian(flange_gaps(), Z))],
    ),
    Group(
        "flange_residuals",
        "Discrete flange constraints E_F = g_F'' + c1 g_F' + c0 g_F of both sides",
        lambda: [("E_F", sp.Matrix(flange_residuals()))],
    ),
    Group(
        "flange_residual_jacobians",
        "dE_F/dz + a1 dE_F/dz' + a0 dE_F/dz'' of the flange constraints, one row per side",
        lambda: [("dEF_dz", residual_jacobian(flange_residuals()))],
    ),
    Group(
        "creepages",
        "Creepages [xi_x, xi_y, xi_sp] of the left contact, then the right (dimensionless; spin in 1/m)",
        lambda: [("creepage", sp.Matrix(creepages()))],
    ),
    Group(
        "creepage_gradients",
        "Gradients of the six creepages over z (rows as creepages)",
        lambda: [("dxi_dz", _jacobian(creepages(), Z))],
    ),
    Group(
        "creepage_rate_gradients",
        "Gradients of the six creepages over the rates z' (rows as creepages); v times a row is the "
        "generalized-force direction of the matching creep force (the slip velocity is linear in z')",
        lambda: [("dxi_dzt", _jacobian(creepages(), Z_T))],
    ),
    Group(
        "creep_load_directions",
        "Generalised loads on z of a unit [F_x, F_y, M_sp] of the left contact, then the right "
        "(16x3 each, by virtual work: the load is this matrix times the contact's forces)",
        lambda: [(f"B_{side}", m) for (side, _), m in zip(c3.SIDES, creep_load_directions(), strict=True)],
    ),
]
"""The groups over the state (:data:`INPUTS`), in emission order."""

LAW_GROUPS: list[Group] = [
    Group(
        "kalker_coefficients",
        "Kalker's [f11, f22, f23] under the normal load N (N, N, N m; the creepages unused)",
        lambda: [("f", sp.Matrix(kalker_coefficients()))],
        LAW_INPUTS,
        LAW_SAMPLE,
    ),
    Group(
        "creep_forces",
        "Saturated creep forces [F_x, F_y] (Kalker, Shen-Hedrick-Elkins) and the unsaturated spin "
        "moment M_sp of one contact, on the wheel in its contact frame (all zero for N <= 0)",
        lambda: [("F", sp.Matrix(creep_law()))],
        LAW_INPUTS,
        LAW_SAMPLE,
    ),
]
"""The creep law of one contact (:data:`LAW_INPUTS`), emitted after :data:`GROUPS`."""


@cache
def contact3d_model_spec() -> ModelSpec:
    """The kernels of the 3D contact (model ``contact3d``), one per :data:`GROUPS` entry."""
    kernels = [
        KernelSpec(g.name, g.doc, g.inputs or INPUTS, g.outputs(), g.sample or SAMPLE)
        for g in (*GROUPS, *LAW_GROUPS)
    ]
    return ModelSpec(
        name=CONTACT3D,
        doc="3D wheel-rail contact of one wheelset on a deck element: gaps, constraints, creep.",
        kernels=kernels,
        parameters=[(s.name, SAMPLE[s.name]) for s in GEOMETRY],
        sizes={"n_z": len(Z), "n_sides": 2},
    )


def contact3d_data() -> dict[str, object]:
    """Plain data of the module: argument names, the order of ``z`` and the groups."""
    return {
        "z_names": tuple(s.name for s in Z),
        "geometry_names": tuple(s.name for s in GEOMETRY),
        "irregularity_names": tuple(s.name for s in IRREGULARITY),
        "coefficient_names": tuple(s.name for s in COEFFICIENTS),
        "creep_names": tuple(s.name for s in MATERIAL),
        "sides": tuple(side for side, _ in c3.SIDES),
    }
