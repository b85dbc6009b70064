"""3D creep forces of a wheelset's two contacts: creepages, Kalker's linear law, saturation.

A building block of the 3D model (docs/three-d.md); the 3D time step evaluates it through the
generated kernels of :mod:`svbi.codegen.contact3d_kernels` (``generated/contact3d/``). The contact geometry is
:mod:`svbi.codegen.contact3d`'s (coned treads on knife-edge rails on a deck element); axes, signs
and DOF symbols are its own.

* **Creepages** of side ``s``: the slip velocity of the wheel material at the contact point relative
  to the rail's, over the speed ``v``, in the contact frame: ``xi_x`` along the wheel's heading
  ``t_x = R e_x`` (``R`` the wheelset's yaw and roll), ``xi_y`` along ``t_y = n x t_x`` (across, in the
  contact plane, pointing left) and the spin ``xi_sp = (omega_wheel - omega_rail) . n / v``. The wheel
  moves forward at ``v`` and spins about its axle ``R e_y`` at ``Omega = v / r0`` (constant speed:
  the longitudinal DOF and the spin perturbation are left out) plus its roll and yaw rates; the rail
  point moves with the deck's velocity at the moving contact, ``d/dt = d/dt|_x + v d/dx`` (the
  convective terms of the 2D gap, Eq. 21), along ``x`` too (the axial displacement, less the pitch
  times the rail height ``h`` as the 2D law's ``W_T^B``, less the deck's yaw times ``e + s b``),
  and turns with the deck's twist, pitch and yaw rates.
* **Kalker's linear law** (Kalker 1967; 1990, Table E.3): ``F_x = -f11 xi_x``,
  ``F_y = -f22 xi_y - f23 xi_sp`` in the contact plane and the spin moment ``M_sp = f23 xi_y - f33
  xi_sp`` about the normal, ``f11 = G a b C11``, ``f22 = G a b C22``, ``f23 = G (a b)^(3/2) C23``,
  ``f33 = G (a b)^2 C33``. **C33 is not carried** (no table of it is in the project), so ``f33 = 0``:
  the spin moment's own term is left out, as in :mod:`svbi.codegen.wheelset3d`.
  The semi-axes ``a, b`` of the Hertz ellipse under the normal load ``N`` are those of the 2D law
  (:func:`svbi.codegen.creep.hertz_semi_axes`); ``C11, C22, C23`` come from
  ``svbi.runtime.model.kalker3d.kalker_coefficients``.
* **Saturation** (Shen, Hedrick & Elkins 1983, the 2D law's :func:`svbi.codegen.creep.she_factor`):
  with the linear resultant ``F_lin = sqrt(F_x^2 + F_y^2)`` and ``beta = F_lin / (mu N)`` both
  tangential forces are scaled by ``eps(beta)``; the spin moment is left unsaturated. A contact
  out of load (``N <= 0``) has no creep force.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import sympy as sp

from svbi.codegen import contact3d as c3
from svbi.codegen import creep, frame3d

v = c3.v
"""Train speed (m/s); :data:`svbi.codegen.contact3d.v`."""
WHEELSET_RATES = c3.WHEELSET_RATES
UE_T = c3.UE_T
IRREGULARITY_SLOPES = c3.IRREGULARITY_SLOPES

f11, f22, f23 = sp.symbols("f11 f22 f23", nonnegative=True)
"""Kalker's linear creep coefficients (N; f23 in N m)."""
kalker_c22 = sp.Symbol("kalker_c22", positive=True)
"""Kalker's lateral creepage coefficient C22."""
kalker_c23 = sp.Symbol("kalker_c23", positive=True)
"""Kalker's lateral-spin coefficient C23."""
normal_load = creep.normal_load
"""Normal load of the contact (N), positive in compression."""


def _rotation() -> sp.Matrix:
    c, s = sp.cos(c3.phi_w), sp.sin(c3.phi_w)
    roll = sp.Matrix([[1, 0, 0], [0, c, -s], [0, s, c]])
    cz, sz = sp.cos(c3.psi_w), sp.sin(c3.psi_w)
    yaw = sp.Matrix([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return yaw * roll


@dataclass(frozen=True)
class Creepages:
    """Creepages of one contact and its contact frame."""

    side: str
    xi_x: sp.Expr
    xi_y: sp.Expr
    xi_sp: sp.Expr
    t_x: sp.Matrix
    t_y: sp.Matrix
    normal: sp.Matrix


@cache
def creepages() -> tuple[Creepages, Creepages]:
    """Creepages of the left and right contacts, exact in the state (small deck rotations)."""
    rot = _rotation()
    t_x = rot * sp.Matrix([1, 0, 0])
    axle = rot * sp.Matrix([0, 1, 0])
    rates = dict(zip(c3.WHEELSET_DOFS, WHEELSET_RATES, strict=True))
    # angular velocity of the wheelset: spin about the axle, roll about x, yaw about z
    # (yaw, then roll about the yawed x axis)
    yawed_x = sp.Matrix([sp.cos(c3.psi_w), sp.sin(c3.psi_w), 0])
    omega = (v / c3.r0) * axle + rates[c3.phi_w] * yawed_x + sp.Matrix([0, 0, rates[c3.psi_w]])
    n = frame3d.shape_functions()
    _, _, phi_d = c3.deck_section()
    u_d = (n["u"] * c3.UE)[0, 0]
    theta_d = (frame3d.d_dx(n["w"]) * c3.UE)[0, 0]
    psi_d = (frame3d.d_dx(n["v"]) * c3.UE)[0, 0]
    # the deck's angular velocity: twist about x, pitch about -y (theta = dw/dx), yaw about z
    dt = c3.time_derivative
    omega_rail = sp.Matrix([dt(phi_d), -dt(theta_d), dt(psi_d)])
    centre = sp.Matrix([v, rates[c3.y_w], rates[c3.z_w]])
    out = []
    for contact in c3.contacts():
        r_c = sp.Matrix(contact.position)
        wheel = centre + omega.cross(r_c)
        y_rail, z_rail = contact.rail
        # the rail head moves along x with the deck's axial displacement, its pitch (at the height
        # h above the shear centre, as the 2D W_T^B) and its yaw (at e + s b beside it)
        x_rail = u_d - c3.h_rail * theta_d - (c3.ecc + contact.sign * c3.b) * psi_d
        rail = sp.Matrix([dt(x_rail), dt(y_rail), dt(z_rail)])
        slip = wheel - rail
        normal = contact.normal
        t_y = normal.cross(t_x)
        out.append(
            Creepages(
                contact.side,
                (slip.T * t_x)[0, 0] / v,
                (slip.T * t_y)[0, 0] / v,
                ((omega - omega_rail).T * normal)[0, 0] / v,
                t_x,
                t_y,
                normal,
            )
        )
    return out[0], out[1]


def kalker_coefficients(load: sp.Expr = normal_load) -> dict[sp.Symbol, sp.Expr]:
    """``f11 = G a b C11``, ``f22 = G a b C22``, ``f23 = G (a b)^(3/2) C23`` under the normal load,
    with the Hertz semi-axes of the 2D law."""
    a, bb = creep.hertz_semi_axes(load)
    g = creep.shear_modulus()
    return {
        f11: g * a * bb * creep.kalker_c11,
        f22: g * a * bb * kalker_c22,
        f23: g * (a * bb) ** sp.Rational(3, 2) * kalker_c23,
    }


@dataclass(frozen=True)
class CreepForce:
    """Creep forces of one contact: linear (Kalker) and saturated, in the contact frame."""

    side: str
    fx_linear: sp.Expr
    fy_linear: sp.Expr
    spin_moment: sp.Expr
    fx: sp.Expr
    fy: sp.Expr
    creepages: Creepages

    def force_vector(self, saturated: bool = True) -> sp.Matrix:
        """The tangential force on the wheel in the track axes."""
        fx, fy = (self.fx, self.fy) if saturated else (self.fx_linear, self.fy_linear)
        return fx * self.creepages.t_x + fy * self.creepages.t_y


def linear_law(xi_x: sp.Expr, xi_y: sp.Expr, xi_sp: sp.Expr) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
    """Kalker's linear ``(F_x, F_y, M_sp)``; the spin moment without its C33 term."""
    return -f11 * xi_x, -f22 * xi_y - f23 * xi_sp, f23 * xi_y


creepage_x, creepage_y, creepage_spin = sp.symbols("xi_cx xi_cy xi_csp", real=True)
"""A contact's creepages as plain symbols (longitudinal, lateral, spin in 1/m): the arguments of
the law on its own (:func:`saturated_law`, the generated ``creep_forces``)."""


def saturated_law(
    xi_x: sp.Expr, xi_y: sp.Expr, xi_sp: sp.Expr
) -> tuple[sp.Expr, sp.Expr, sp.Expr, sp.Expr, sp.Expr]:
    """``(F_x, F_y, M_sp)`` of Kalker's linear law and the saturated ``(F_x, F_y)`` (zero for
    ``N <= 0``) in the creepages, ``f11, f22, f23``, :data:`normal_load` and the friction."""
    beta = sp.Symbol("beta", nonnegative=True)
    fx, fy, mz = linear_law(xi_x, xi_y, xi_sp)
    resultant = sp.sqrt(fx**2 + fy**2)
    eps = creep.she_factor(beta).subs(beta, resultant / (creep.friction * normal_load))
    fx_sat = sp.Piecewise((sp.S.Zero, normal_load <= 0), (eps * fx, True))
    fy_sat = sp.Piecewise((sp.S.Zero, normal_load <= 0), (eps * fy, True))
    return fx, fy, mz, fx_sat, fy_sat


@cache
def creep_forces() -> tuple[CreepForce, CreepForce]:
    """Both contacts' creep forces as functions of the state, the rates and ``N`` (one symbol,
    :data:`normal_load`, for each contact's own load): :func:`saturated_law` at the creepages."""
    out = []
    for cr in creepages():
        fx, fy, mz, fx_sat, fy_sat = saturated_law(cr.xi_x, cr.xi_y, cr.xi_sp)
        out.append(CreepForce(cr.side, fx, fy, mz, fx_sat, fy_sat, cr))
    return out[0], out[1]


creep_fx, creep_fy, creep_spin = sp.symbols("F_cx F_cy M_csp", real=True)
"""A contact's creep forces in its contact frame: along ``t_x``, along ``t_y`` (N) and the spin
moment about the normal (N m), on the wheel."""


@dataclass(frozen=True)
class CreepLoads:
    """Generalised forces of one contact's creep forces (:data:`creep_fx`, :data:`creep_fy`,
    :data:`creep_spin` on the wheel; their opposites on the rail), by virtual work."""

    side: str
    wheelset: sp.Matrix
    """4 x 1 over ``[y_w, z_w, phi_w, psi_w]``: the force's lateral and vertical components, and
    the roll and yaw moments about the axle centre (the spin moment's components included)."""
    deck: sp.Matrix
    """12 x 1 over the element DOFs: the reaction at the rail point (moving with the deck as the
    creepages' rail point: ``x = u - h theta - (e + s b) psi``, ``y``, ``z`` of
    :func:`svbi.codegen.contact3d.rail_point`) and the spin moment's reaction on the deck's
    twist, pitch (about ``-y``) and yaw."""


@cache
def creep_loads() -> tuple[CreepLoads, CreepLoads]:
    """The generalised creep loads of both contacts on the wheelset and the deck element: the
    virtual work ``f . dr_wheel + M_sp n . dtheta_wheel - f . dr_rail - M_sp n . dtheta_deck``."""
    n = frame3d.shape_functions()
    _, _, phi_d = c3.deck_section()
    u_d = (n["u"] * c3.UE)[0, 0]
    theta_d = (frame3d.d_dx(n["w"]) * c3.UE)[0, 0]
    psi_d = (frame3d.d_dx(n["v"]) * c3.UE)[0, 0]
    out = []
    for cr, contact in zip(creepages(), c3.contacts(), strict=True):
        f = creep_fx * cr.t_x + creep_fy * cr.t_y
        moment = creep_spin * cr.normal
        r = sp.Matrix(contact.position)
        about_centre = r.cross(f) + moment
        wheelset = sp.Matrix([f[1], f[2], about_centre[0], about_centre[2]])
        y_rail, z_rail = contact.rail
        x_rail = u_d - c3.h_rail * theta_d - (c3.ecc + contact.sign * c3.b) * psi_d
        rail = sp.Matrix([x_rail, y_rail, z_rail])
        turn = sp.Matrix([phi_d, -theta_d, psi_d])
        work = -(f.T * rail)[0, 0] - (moment.T * turn)[0, 0]
        # the rail point and the deck's rotations are linear in the element DOFs: the coefficient
        # of each DOF in the virtual work is its generalised force
        deck = sp.Matrix([sp.diff(work, u) for u in c3.UE])
        out.append(CreepLoads(cr.side, wheelset, deck))
    return out[0], out[1]
