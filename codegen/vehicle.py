"""Vehicle equations of motion derived from a declarative topology (paper Section 2.1, Eqs. 2-8).

The vehicle is a set of rigid bodies with small vertical translations ``z`` and pitch rotations
``theta``, joined by linear suspensions. Lagrange's equations

    d/dt dL/dq' - dL/dq + dD/dq' = Q,   L = T - V,

with the kinetic energy ``T``, the elastic potential ``V``, the Rayleigh dissipation function ``D`` and
the generalized gravity forces ``Q``, give ``M q'' + C q' + K q = F`` (Eq. 4). For a linear topology
``T``, ``V`` and ``D`` are quadratic forms, so ``M``, ``K`` and ``C`` are their Hessians; gravity is the
gradient of the potential of the weights. The contact direction matrices ``W_N^V`` and ``W_T^V`` are
the Jacobians of the wheel contact point displacements.

The auxiliary contact points of Section 2.3 take the share ``a`` of each wheel mass:
``m^g = a (W^V)^T m^V W^V`` and the active vehicle mass is ``m~^V = m^V - W^V m^g (W^V)^T``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
import sympy as sp

from svbi.codegen.plain_types import GRAVITY, NumericVehicle, TopologyError, mechanism_problem, validate_split
from svbi.codegen.topology import Topology, load_topology

g = sp.Symbol("g", positive=True)
"""Gravitational acceleration (m/s^2); 9.81 in the runtime (docs/design.md section 2)."""
a_split = sp.Symbol("a", positive=True)
"""Split coefficient: share of each wheel mass given to its auxiliary contact point, 0 < a < 1."""


@dataclass
class VehicleModel:
    """Symbolic vehicle model: DOFs, matrices of Eq. (4) and contact directions, all in SymPy."""

    topology: Topology
    dofs: list[sp.Symbol]
    mass_matrix: sp.Matrix
    damping_matrix: sp.Matrix
    stiffness_matrix: sp.Matrix
    gravity_load: sp.Matrix
    contact_normal: sp.Matrix
    contact_tangential: sp.Matrix
    wheel_offsets: list[sp.Expr]
    wheel_radii: list[sp.Expr]

    @property
    def name(self) -> str:
        return self.topology.name

    @property
    def kind(self) -> str:
        return self.topology.kind

    @property
    def parameters(self) -> list[sp.Symbol]:
        """Scalar parameter symbols in sorted order: the parameter vector of every kernel."""
        return self.topology.symbols

    @property
    def carbody(self) -> str | None:
        return self.topology.bodies[0].name if self.topology.bodies else None

    @property
    def car_length(self) -> sp.Symbol:
        return self.topology.parameters["car_length"].symbol

    @cached_property
    def wheel_masses(self) -> list[sp.Expr]:
        """Mass seen by each contact direction, ``W_i^T m^V W_i`` (Section 2.3)."""
        w = self.contact_normal
        return [sp.simplify((w[:, i].T * self.mass_matrix * w[:, i])[0, 0]) for i in range(w.shape[1])]

    def aux_masses(self, a: sp.Expr = a_split) -> sp.Matrix:
        """Diagonal mass matrix of the auxiliary contact points, ``m^g = a W^T m^V W`` (Section 2.3)."""
        if isinstance(a, int | float):
            validate_split(a)
        return sp.diag(*[a * m for m in self.wheel_masses]) if self.wheel_masses else sp.zeros(0, 0)

    def active_mass_matrix(self, a: sp.Expr = a_split) -> sp.Matrix:
        """Active vehicle mass ``m~^V = m^V - W m^g W^T`` of Eq. (4)."""
        if isinstance(a, int | float):
            validate_split(a)
        w = self.contact_normal
        if w.shape[1] == 0:
            return self.mass_matrix
        return (self.mass_matrix - w * self.aux_masses(a) * w.T).applyfunc(sp.expand)

    def dof_index(self, body: str, dof: str) -> int | None:
        name = f"{dof}_{body}"
        return next((i for i, q in enumerate(self.dofs) if q.name == name), None)

    def numeric(self, values: dict[str, Any] | None = None) -> NumericVehicle:
        """Evaluate the model at ``values`` (defaults filled in, validated) with g = 9.81 m/s^2."""
        vals = self.topology.values(values)
        subs: dict[sp.Symbol, Any] = {
            p.symbol: vals[n] for n, p in self.topology.parameters.items() if not isinstance(vals[n], tuple)
        }
        subs[g] = GRAVITY

        def arr(m: sp.Matrix) -> np.ndarray:
            return np.array(m.subs(subs).evalf(17).tolist(), dtype=float).reshape(m.shape)

        carbody = self.carbody
        numeric = NumericVehicle(
            name=self.name,
            kind=self.kind,
            dof_names=tuple(q.name for q in self.dofs),
            M=arr(self.mass_matrix),
            C=arr(self.damping_matrix),
            K=arr(self.stiffness_matrix),
            F_gravity=arr(self.gravity_load).reshape(-1),
            W_N=arr(self.contact_normal),
            W_T=arr(self.contact_tangential),
            wheel_offsets=np.array([float(e.subs(subs)) for e in self.wheel_offsets]),
            wheel_masses=np.array([float(e.subs(subs)) for e in self.wheel_masses]),
            wheel_radii=np.array([float(e.subs(subs)) for e in self.wheel_radii]),
            car_length=float(vals["car_length"]),
            carbody_z=self.dof_index(carbody, "z") if carbody else None,
            carbody_theta=self.dof_index(carbody, "theta") if carbody else None,
            axle_loads=np.array(vals.get("axle_loads", ()), dtype=float),
            axle_offsets=np.array(vals.get("axle_offsets", ()), dtype=float),
        )
        springs = tuple(
            (s.name, s.body_a, s.body_b, float(s.stiffness.subs(subs))) for s in self.topology.suspensions
        )
        problem = mechanism_problem(numeric, tuple(w.name for w in self.topology.wheels), springs)
        if problem:
            raise TopologyError(self.topology.path or self.name, "bodies", problem)
        return numeric


def derive_vehicle(topology: Topology | str) -> VehicleModel:
    """Derive the symbolic vehicle model (Eqs. 2-4) from a topology or a topology name/path."""
    topo = load_topology(topology) if isinstance(topology, str) else topology
    dofs: list[sp.Symbol] = []
    qd: list[sp.Symbol] = []
    coords: dict[str, dict[str, sp.Expr]] = {}
    for body in topo.bodies:
        coords[body.name] = {}
        for dof in ("z", "theta"):
            if dof in body.dofs:
                q = sp.Symbol(f"{dof}_{body.name}", real=True)
                dofs.append(q)
                qd.append(sp.Symbol(f"{dof}dot_{body.name}", real=True))
                coords[body.name][dof] = q
            else:
                coords[body.name][dof] = sp.Integer(0)
    velocity = dict(zip(dofs, qd, strict=True))
    bodies = {b.name: b for b in topo.bodies}

    def vertical(body: str, offset: sp.Expr) -> sp.Expr:
        # A point `offset` behind the body reference: pitch positive lifts points ahead of it.
        c = coords[body]
        return c["z"] - offset * c["theta"]

    def rate(expr: sp.Expr) -> sp.Expr:
        return sum((sp.diff(expr, q) * velocity[q] for q in dofs), sp.Integer(0))

    kinetic = sp.Integer(0)
    gravity_potential = sp.Integer(0)
    for body in topo.bodies:
        c = coords[body.name]
        kinetic += body.mass * rate(c["z"]) ** 2 / 2
        if body.inertia is not None:
            kinetic += body.inertia * rate(c["theta"]) ** 2 / 2
        gravity_potential += body.mass * g * c["z"]

    elastic = sp.Integer(0)
    dissipation = sp.Integer(0)
    for s in topo.suspensions:
        stretch = vertical(s.body_a, s.offset_a) - vertical(s.body_b, s.offset_b)
        elastic += s.stiffness * stretch**2 / 2
        dissipation += s.damping * rate(stretch) ** 2 / 2

    def hessian(expr: sp.Expr, variables: list[sp.Symbol]) -> sp.Matrix:
        if not variables:
            return sp.zeros(0, 0)
        return sp.hessian(sp.expand(expr), variables).applyfunc(sp.factor_terms)

    contact_normal = sp.zeros(len(dofs), len(topo.wheels))
    contact_tangential = sp.zeros(len(dofs), len(topo.wheels))
    for j, wheel in enumerate(topo.wheels):
        body = bodies[wheel.body]
        z_contact = vertical(wheel.body, wheel.position - body.position)
        # The contact point lies `radius` below the body reference: a pitch theta moves it
        # forward by radius * theta (Eq. 16, W_T^V).
        x_contact = wheel.radius * coords[wheel.body]["theta"]
        for i, q in enumerate(dofs):
            contact_normal[i, j] = sp.diff(z_contact, q)
            contact_tangential[i, j] = sp.diff(x_contact, q)

    gravity = sp.Matrix([-sp.diff(gravity_potential, q) for q in dofs]) if dofs else sp.zeros(0, 1)
    return VehicleModel(
        topology=topo,
        dofs=dofs,
        mass_matrix=hessian(kinetic, qd),
        damping_matrix=hessian(dissipation, qd),
        stiffness_matrix=hessian(elastic, dofs),
        gravity_load=gravity,
        contact_normal=contact_normal,
        contact_tangential=contact_tangential,
        wheel_offsets=[w.position for w in topo.wheels],
        wheel_radii=[w.radius for w in topo.wheels],
    )
