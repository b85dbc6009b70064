"""Linear lateral and yaw dynamics of a wheelset on a coned profile (Klingel, Wickens).

A wheelset of mass ``m_w`` and yaw inertia ``I_wz`` runs at constant speed ``v`` along straight
track, rolling without spin-slip about its axle at ``Omega = v / r0``. Its DOFs are the lateral
displacement ``y`` (positive left) and the yaw ``psi`` (positive nose left), axes as in
:mod:`svbi.codegen.topology3d` (``x`` forward, ``y`` left, ``z`` up). Everything below is derived
from the geometry, nothing is typed in as an equation of motion:

* **Profile.** Each wheel is a cone: its rolling radius at a lateral distance ``s`` outwards from the
  nominal tape circle is ``r0 - lam * s`` (``lam`` the equivalent conicity). On knife-edge rails at
  ``+-b`` the contact of a wheelset displaced by ``y`` sits at ``s = -y`` on the left wheel and
  ``s = +y`` on the right: ``r_L = r0 + lam y``, ``r_R = r0 - lam y``, and the wheelset rolls by
  ``phi = (r_L - r_R) / (2 b)``.
* **Contact normals.** The normal at each contact is inclined inwards by the contact angle
  ``delta0`` in the central position, turned by the wheelset's roll: ``delta_L = delta0 + phi``,
  ``delta_R = delta0 - phi`` (for a pure cone ``delta0 = lam``). The normal loads carry the axle load
  ``W``; their lateral components give the gravitational stiffness.
* **Creepages** (slip velocity of the wheel material at the contact over ``v``, to first order):
  longitudinal along the wheel's heading, lateral along the contact plane, spin about the normal,
  from the velocity of the wheelset centre and its angular velocity (spin about the yawed axle,
  yaw rate).
* **Creep forces** (Kalker's linear theory): ``Fx = -f11 xi_x``, ``Fy = -f22 xi_y - f23 xi_sp`` in
  the contact plane and the spin moment ``Mz = f23 xi_y`` about the normal, with
  ``f11 = G a b C11``, ``f22 = G a b C22``, ``f23 = G (a b)^(3/2) C23`` (:func:`kalker_coefficients`).
  The spin moment's own term ``-G (a b)^2 C33 xi_sp`` is left out (no table of C33 is carried).
* **Suspension.** A lateral spring ``k_y`` and a yaw spring ``k_psi`` to a frame moving at ``v``.

Left out, as in Wickens' linear model: the gyroscopic moments of the spinning axle, the
gravitational yaw stiffness, the longitudinal DOF, flange contact and creep saturation.

The generalized forces are the virtual work of the contact forces on the contact-point Jacobians,
linearised about the centred state: ``M q'' + C(v) q' + K(v) q = 0`` with ``q = [y, psi]``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import sympy as sp

y, psi = sp.symbols("y psi", real=True)
"""Lateral displacement (m, positive left) and yaw (rad, positive nose left)."""
ydot, psidot = sp.symbols("ydot psidot", real=True)
v = sp.Symbol("v", positive=True)
"""Speed (m/s)."""
m_w = sp.Symbol("m_w", positive=True)
"""Wheelset mass (kg)."""
I_wz = sp.Symbol("I_wz", positive=True)
"""Wheelset yaw inertia (kg m^2)."""
r0 = sp.Symbol("r0", positive=True)
"""Nominal rolling radius (m)."""
b = sp.Symbol("b", positive=True)
"""Half distance between the contact points (m)."""
lam = sp.Symbol("lam", positive=True)
"""Equivalent conicity."""
delta0 = sp.Symbol("delta0", nonnegative=True)
"""Contact angle (inclination of the contact normal) in the central position (rad)."""
W = sp.Symbol("W", nonnegative=True)
"""Axle load (N)."""
f11, f22, f23 = sp.symbols("f11 f22 f23", nonnegative=True)
"""Kalker's linear creep coefficients (N; f23 in N m)."""
k_y = sp.Symbol("k_y", nonnegative=True)
"""Lateral suspension stiffness (N/m)."""
k_psi = sp.Symbol("k_psi", nonnegative=True)
"""Yaw suspension stiffness (N m/rad)."""

G_wr = sp.Symbol("G_wr", positive=True)
"""Shear modulus of wheel and rail steel (Pa)."""
a_c, b_c = sp.symbols("a_c b_c", positive=True)
"""Semi-axes of the contact ellipse: a in the rolling direction, b across (m)."""
C11, C22, C23 = sp.symbols("C11 C22 C23", positive=True)
"""Kalker's creepage coefficients (Kalker 1990, Table E.3)."""

DOFS = (y, psi)
VELOCITIES = (ydot, psidot)
PARAMETERS = (m_w, I_wz, r0, b, lam, delta0, W, f11, f22, f23, k_y, k_psi)


def kalker_coefficients() -> dict[sp.Symbol, sp.Expr]:
    """``f11 = G a b C11``, ``f22 = G a b C22``, ``f23 = G (a b)^(3/2) C23``."""
    return {
        f11: G_wr * a_c * b_c * C11,
        f22: G_wr * a_c * b_c * C22,
        f23: G_wr * (a_c * b_c) ** sp.Rational(3, 2) * C23,
    }


@dataclass(frozen=True)
class Contact:
    """Kinematics of one wheel's contact, as functions of ``y, psi, ydot, psidot``."""

    side: str
    lateral: sp.Expr
    """Lateral position of the rail (``+b`` left, ``-b`` right)."""
    radius: sp.Expr
    delta: sp.Expr
    """Inclination of the contact normal, positive inwards."""
    xi_x: sp.Expr
    xi_y: sp.Expr
    xi_sp: sp.Expr


def _cone_radius(s: sp.Expr) -> sp.Expr:
    """Rolling radius of a cone at ``s`` outwards from the tape circle."""
    return r0 - lam * s


def _linear(expr: sp.Expr) -> sp.Expr:
    """Value plus first-order Taylor terms of ``expr`` about the centred state."""
    zero = dict.fromkeys((*DOFS, *VELOCITIES), 0)
    out = expr.subs(zero)
    for q in (*DOFS, *VELOCITIES):
        out += sp.diff(expr, q).subs(zero) * q
    return sp.expand(out)


@cache
def contacts() -> tuple[Contact, Contact]:
    """Both contacts, to first order in the state (left, right).

    Contact angles are small (``sin delta = delta``, ``cos delta = 1``, as in Wickens' linear
    model); the contact points lie on the axle line, under the rails.
    """
    omega = v / r0
    radii = {}
    for side, sign in (("left", 1), ("right", -1)):
        # the rail is at sign*b, the tape circle at sign*b + y, "outwards" points to sign*y
        s = sign * (sign * b - (sign * b + y))
        radii[side] = _cone_radius(s)
    roll = (radii["left"] - radii["right"]) / (2 * b)
    heading = sp.Matrix([1, psi, 0])
    axle = sp.Matrix([-psi, 1, 0])
    omega_vec = omega * axle + sp.Matrix([0, 0, psidot])
    centre = sp.Matrix([v, ydot, 0])
    out = []
    for side, sign in (("left", 1), ("right", -1)):
        radius = radii[side]
        delta = delta0 + sign * roll
        r_c = sp.Matrix([-sign * b * psi, sign * b, -radius])
        slip = centre + omega_vec.cross(r_c)
        normal = sp.Matrix([0, -sign * delta, 1])  # leans inwards by delta
        lateral_t = normal.cross(heading)  # in the contact plane, across the wheel, pointing left
        out.append(
            Contact(
                side,
                sign * b,
                sp.expand(radius),
                sp.expand(delta),
                _linear((slip.T * heading)[0, 0] / v),
                _linear((slip.T * lateral_t)[0, 0] / v),
                _linear((omega_vec.T * normal)[0, 0] / v),
            )
        )
    return out[0], out[1]


@dataclass(frozen=True)
class WheelsetModel:
    """``M q'' + C q' + K q = 0`` of the wheelset, ``q = [y, psi]``; C and K depend on ``v``."""

    mass_matrix: sp.Matrix
    damping_matrix: sp.Matrix
    stiffness_matrix: sp.Matrix
    kinematic_matrix: sp.Matrix
    """``A`` of ``q' = A q`` when both wheels roll without longitudinal and lateral creep."""


@cache
def derive_wheelset() -> WheelsetModel:
    """The linear wheelset model from :func:`contacts`: the contact forces' resultant force along
    ``y`` and moment about ``z``, to first order."""
    heading = sp.Matrix([1, psi, 0])
    force = sp.zeros(3, 1)
    moment_z = sp.Integer(0)
    for c in contacts():
        sign = 1 if c.side == "left" else -1
        normal = sp.Matrix([0, -sign * c.delta, 1])
        lateral_t = normal.cross(heading)
        # Kalker's linear law; the normal load carries half the axle load vertically
        f = -f11 * c.xi_x * heading + (-f22 * c.xi_y - f23 * c.xi_sp) * lateral_t + W / 2 * normal
        r_c = sp.Matrix([-sign * b * psi, sign * b, -c.radius])
        moment = r_c.cross(f)
        force += f
        moment_z += moment[2] + f23 * c.xi_y  # the spin moment about the normal (its z part)
    gen = [_linear(force[1] - k_y * y), _linear(moment_z - k_psi * psi)]
    residual = [g.subs(dict.fromkeys((*DOFS, *VELOCITIES), 0)) for g in gen]
    if any(sp.simplify(r) != 0 for r in residual):
        raise AssertionError(f"the centred wheelset is not in equilibrium: {residual}")
    damping = -sp.Matrix([[sp.diff(g, qd) for qd in VELOCITIES] for g in gen])
    stiffness = -sp.Matrix([[sp.diff(g, q) for q in DOFS] for g in gen])
    left = contacts()[0]
    # pure rolling (no longitudinal and no lateral creep), solved for the rates
    rates = sp.solve([left.xi_x, left.xi_y], VELOCITIES, dict=True)[0]
    kinematic = sp.Matrix([[sp.diff(rates[qd], q) for q in DOFS] for qd in VELOCITIES])
    return WheelsetModel(
        sp.diag(m_w, I_wz),
        damping.applyfunc(sp.simplify),
        stiffness.applyfunc(sp.simplify),
        kinematic.applyfunc(sp.simplify),
    )
