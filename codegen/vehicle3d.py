"""3D vehicle equations of motion derived from a 3D topology (:mod:`svbi.codegen.topology3d`).

Rigid bodies with small lateral ``y``, vertical ``z``, roll ``phi``, pitch ``theta`` and yaw ``psi``
motions (the longitudinal one is left out: the car runs at constant speed), joined by suspension
units with springs and dashpots along ``x``, ``y`` and ``z`` at a point, and by torsion springs
between rotations. As in 2D (:mod:`svbi.codegen.vehicle`), the mass, damping and stiffness matrices
are the Hessians of the kinetic energy, the Rayleigh dissipation and the elastic potential (over the
rates and the DOFs), written from the displacement of each attachment point under a small rotation
``(phi, -theta, psi)``::

    dx = -theta * rz - psi * ry,   dy = y + psi * rx - phi * rz,   dz = z + phi * ry + theta * rx

for a point ``(rx, ry, rz)`` (forward, left, up) from the body's centre of mass. Restricted to
``z`` and ``theta`` this is the 2D model. Principal axes of inertia along the body axes; the
potential of gravity enters only as a load (its second-order roll and pitch terms are left out).
Bump stops are data only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from svbi.codegen.plain_types import GRAVITY
from svbi.codegen.topology3d import DOF_KINDS_3D, Topology3D, load_topology3d
from svbi.codegen.vehicle import g


@dataclass
class NumericVehicle3D:
    """A 3D vehicle's matrices at a parameter set (NumPy, SI)."""

    dof_names: tuple[str, ...]
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    F_gravity: np.ndarray
    W_contact: np.ndarray

    def index(self, name: str) -> int:
        return self.dof_names.index(name)


@dataclass
class VehicleModel3D:
    """Symbolic 3D vehicle model: DOFs and the matrices of ``M q'' + C q' + K q = F``.

    ``contact_jacobian`` is ``n x 3 nw``: columns ``3 j, 3 j + 1, 3 j + 2`` are the ``x``, ``y`` and
    ``z`` displacement directions of the contact point of wheel ``j`` (the transposes map the contact
    forces to generalized forces).
    """

    topology: Topology3D
    dofs: list[sp.Symbol]
    mass_matrix: sp.Matrix
    damping_matrix: sp.Matrix
    stiffness_matrix: sp.Matrix
    gravity_load: sp.Matrix
    contact_jacobian: sp.Matrix

    @property
    def name(self) -> str:
        return self.topology.name

    def numeric(self, values: dict[str, float] | None = None) -> NumericVehicle3D:
        """Evaluate at the topology's defaults with ``values`` overriding them (g = 9.81 m/s^2)."""
        vals: dict[str, Any] = self.topology.defaults()
        for key, value in (values or {}).items():
            if key not in vals:
                raise KeyError(f"{self.name}: unknown parameter {key!r}")
            vals[key] = float(value)
        subs: dict[sp.Symbol, Any] = {
            p.symbol: vals[n] for n, p in self.topology.parameters.items() if not isinstance(vals[n], tuple)
        }
        subs[g] = GRAVITY

        symbols = list(subs)
        numbers = [float(subs[x]) for x in symbols]

        def arr(m: sp.Matrix) -> np.ndarray:
            if m.shape[0] * m.shape[1] == 0:
                return np.zeros(m.shape)
            return np.array(sp.lambdify(symbols, m, "numpy")(*numbers), dtype=float).reshape(m.shape)

        return NumericVehicle3D(
            tuple(q.name for q in self.dofs),
            arr(self.mass_matrix),
            arr(self.damping_matrix),
            arr(self.stiffness_matrix),
            arr(self.gravity_load).reshape(-1),
            arr(self.contact_jacobian),
        )


def derive_vehicle3d(topology: Topology3D | str) -> VehicleModel3D:
    """Derive the symbolic 3D vehicle model from a 3D topology or its name/path."""
    topo = load_topology3d(topology) if isinstance(topology, str) else topology
    dofs: list[sp.Symbol] = []
    coords: dict[str, dict[str, sp.Expr]] = {}
    for body in topo.bodies:
        coords[body.name] = {}
        for kind in DOF_KINDS_3D:
            if kind in body.dofs:
                q = sp.Symbol(f"{kind}_{body.name}", real=True)
                dofs.append(q)
                coords[body.name][kind] = q
            else:
                coords[body.name][kind] = sp.Integer(0)
    bodies = {b.name: b for b in topo.bodies}

    def point(body: str, position: sp.Expr, lateral: sp.Expr, height: sp.Expr) -> sp.Matrix:
        """Displacement (x, y, z) of the body's point at (position, lateral, height)."""
        b, c = bodies[body], coords[body]
        rx, ry, rz = -(position - b.position), lateral, height - b.height
        return sp.Matrix(
            [
                -c["theta"] * rz - c["psi"] * ry,
                c["y"] + c["psi"] * rx - c["phi"] * rz,
                c["z"] + c["phi"] * ry + c["theta"] * rx,
            ]
        )

    # Every energy is a sum of c s^2 / 2 with s linear in the DOFs (or, for the kinetic energy and the
    # dissipation, in their rates): its Hessian is the sum of c grad(s) grad(s)^T, formed so rather
    # than by expanding the squares (the same matrices, far faster for 35 DOFs).
    kinetic: list[tuple[sp.Expr, sp.Expr]] = []
    elastic: list[tuple[sp.Expr, sp.Expr]] = []
    dissipation: list[tuple[sp.Expr, sp.Expr]] = []
    gravity_potential = sp.Integer(0)
    for body in topo.bodies:
        c = coords[body.name]
        kinetic += [(body.mass, c["y"]), (body.mass, c["z"])]
        kinetic += [(inertia, c[kind]) for kind, inertia in body.inertias.items()]
        gravity_potential += body.mass * g * c["z"]
    for s in topo.suspensions:
        stretch = point(s.body_a, s.position, s.lateral, s.height) - point(
            s.body_b, s.position, s.lateral, s.height
        )
        for k in range(3):
            elastic.append((s.stiffness[k], stretch[k]))
            dissipation.append((s.damping[k], stretch[k]))
    for r in topo.rotational_springs:
        twist = coords[r.body_a][r.axis] - coords[r.body_b][r.axis]
        elastic.append((r.stiffness, twist))
        dissipation.append((r.damping, twist))

    def hessian(terms: list[tuple[sp.Expr, sp.Expr]]) -> sp.Matrix:
        """Hessian of sum(c s^2 / 2) over the DOFs (of the rates, for a sum over rates)."""
        out = sp.zeros(len(dofs), len(dofs))
        for coefficient, expr in terms:
            if coefficient == 0:
                continue
            if sp.Poly(expr, *dofs).total_degree() > 1:
                raise AssertionError(f"{expr} is not linear in the DOFs")
            grad = sp.Matrix([sp.diff(expr, q) for q in dofs])
            out += coefficient * grad * grad.T
        return out.applyfunc(lambda e: sp.factor_terms(sp.expand(e)))

    jacobian = sp.zeros(len(dofs), 3 * len(topo.wheels))
    for j, wheel in enumerate(topo.wheels):
        body = bodies[wheel.body]
        contact = point(wheel.body, wheel.position, wheel.lateral, body.height - wheel.radius)
        for k in range(3):
            for i, q in enumerate(dofs):
                jacobian[i, 3 * j + k] = sp.diff(contact[k], q)

    return VehicleModel3D(
        topology=topo,
        dofs=dofs,
        mass_matrix=hessian(kinetic),
        damping_matrix=hessian(dissipation),
        stiffness_matrix=hessian(elastic),
        gravity_load=sp.Matrix([-sp.diff(gravity_potential, q) for q in dofs]),
        contact_jacobian=jacobian,
    )


# --------------------------------------------------------------------------------------------------
# the generated module of a 3D vehicle (``generated/<name>/numpy_kernels.py``)


def vehicle3d_model_spec(model: VehicleModel3D) -> Any:
    """The kernels of a 3D vehicle, functions of its scalar parameter vector ``p``
    (:attr:`Topology3D.symbols` order): ``M``, ``C``, ``K``, the gravity load (g = 9.81 m/s^2), the
    wheels' and the bodies' positions."""
    from svbi.codegen.kernels import KernelSpec, ModelSpec, column

    topo = model.topology
    params = topo.symbols
    defaults = topo.defaults()
    sample = {s.name: float(defaults[s.name]) for s in params}  # type: ignore[arg-type]
    inputs = [("p", column(params))]

    def spec(name: str, doc: str, outputs: list[tuple[str, sp.Matrix]]) -> KernelSpec:
        return KernelSpec(name, doc, inputs, outputs, sample)

    def col(values: list[sp.Expr]) -> sp.Matrix:
        return sp.Matrix(len(values), 1, values)

    kernels = [
        spec("mass_matrix", "3D vehicle mass matrix", [("M", model.mass_matrix)]),
        spec("damping_matrix", "3D vehicle damping matrix", [("C", model.damping_matrix)]),
        spec("stiffness_matrix", "3D vehicle stiffness matrix", [("K", model.stiffness_matrix)]),
        spec(
            "gravity_load",
            "Generalized gravity forces on the 3D vehicle DOFs (g = 9.81 m/s^2)",
            [("F", model.gravity_load.xreplace({g: GRAVITY}))],
        ),
        spec(
            "wheel_geometry",
            "Per wheel: position behind the car's leading axle, lateral position, rolling radius",
            [
                ("positions", col([w.position for w in topo.wheels])),
                ("laterals", col([w.lateral for w in topo.wheels])),
                ("radii", col([w.radius for w in topo.wheels])),
            ],
        ),
        spec(
            "body_geometry",
            "Per body: position of the centre of mass behind the car's leading axle, its height",
            [
                ("positions", col([b.position for b in topo.bodies])),
                ("heights", col([b.height for b in topo.bodies])),
            ],
        ),
    ]
    return ModelSpec(
        name=topo.name,
        doc=f"3D vehicle model {topo.name}: {topo.description}",
        kernels=kernels,
        parameters=[(s.name, sample[s.name]) for s in params],
        sizes={"n_dofs": len(model.dofs), "n_wheels": len(topo.wheels)},
    )


def vehicle3d_data(model: VehicleModel3D) -> dict[str, Any]:
    """Plain data of a 3D vehicle's module: names, defaults (and which parameters may be negative),
    DOFs, bodies and wheels: what a run needs of the topology, without SymPy."""
    topo = model.topology
    return {
        "name": topo.name,
        "dimensions": 3,
        "description": topo.description,
        "parameters": tuple((p.name, p.value) for p in topo.parameters.values()),
        "signed": tuple(p.name for p in topo.parameters.values() if p.signed),
        "parameter_vector": tuple(s.name for s in topo.symbols),
        "dof_names": tuple(q.name for q in model.dofs),
        "bodies": tuple((b.name, tuple(b.dofs)) for b in topo.bodies),
        "wheels": tuple((w.name, w.body) for w in topo.wheels),
    }


def render_vehicle3d(topology: Topology3D | str) -> tuple[str, bytes]:
    """``(name, source)`` of the generated NumPy module of a 3D topology (or its name or path)."""
    from svbi.codegen.python_emit import render_module

    model = derive_vehicle3d(topology)
    return model.name, render_module(vehicle3d_model_spec(model), vehicle3d_data(model))


def render_vehicle3d_text(text: str, source: str = "<string>") -> bytes:
    """The generated NumPy module of a 3D topology's TOML text (errors name ``source``)."""
    from svbi.codegen.topology3d import parse_topology3d

    return render_vehicle3d(parse_topology3d(text, source))[1]
