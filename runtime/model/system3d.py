"""Model glue of the 3D time step (a prototype; docs/three-d.md, "The 3D time step (prototype)").

A 3D vehicle (:mod:`svbi.codegen.vehicle3d`) on one simply supported 3D span
(:mod:`svbi.runtime.model.span3d`), each wheelset held on its two rails by the normal gaps of
:mod:`svbi.codegen.contact3d`. The vehicle matrices and the contact expressions (gaps, their
gradients and the discrete constraint residual ``g'' + 2 zeta omega g' + omega^2 g``) are turned into
NumPy callables by ``sympy.lambdify`` at set-up: acceptable for a prototype; emitting them as
kernels through the templates, like every other matrix of svbi, is the next step. This is the only
runtime module besides the emitter path that imports SymPy and ``svbi.codegen``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp

from ...codegen import contact3d as c3
from ...codegen import creep as creep2d
from ...codegen import creep3d
from ...codegen.beam import le as LE
from ...codegen.beam import xi as XI
from ...codegen.topology3d import Topology3D, load_topology3d
from ...codegen.vehicle3d import derive_vehicle3d
from .creep_law import CreepParameters
from .kalker3d import kalker_coefficients
from .span3d import Span3D

ARGS = (
    *c3.WHEELSET_DOFS,
    *c3.WHEELSET_RATES,
    *c3.WHEELSET_ACCELERATIONS,
    *c3.UE,
    *c3.UE_T,
    *c3.UE_TT,
    XI,
)
"""Arguments of every contact callable: wheelset ``[y, z, phi, psi]``, its rates and accelerations,
the element's 12 DOFs, their rates and accelerations, and ``xi``."""
NZ = 16
"""The contact's own unknowns: 4 wheelset DOFs and the element's 12."""
COMPLEX_STEP = 1e-30
"""Step of the complex-step derivatives (exact to round-off: no difference is taken)."""


@dataclass(frozen=True)
class Track3D:
    """Cone and track geometry of :mod:`svbi.codegen.contact3d` (SI units)."""

    conicity: float = 0.0
    """Slope ``lam`` of the coned treads."""
    eccentricity: float = 0.0
    """Lateral offset ``e_t`` of the track centreline from the deck's shear centre (positive left)."""
    rail_height: float = 0.0
    """Height ``h_t`` of the rail top above the deck's shear centre."""
    flange_clearance: float = 0.005
    """Lateral flange clearance ``c_f`` per side of the centred wheelset (m). Default 5 mm: half of
    the standard gauge less the back-to-back distance and two flange thicknesses of new wheels,
    ``(1435 - (1360 + 2 x 32.5)) / 2`` mm (assumed: no 3D topology carries its own)."""


@dataclass(frozen=True)
class Wheelset:
    """A wheelset body of the vehicle: where its contact DOFs sit and its geometry."""

    name: str
    dofs: np.ndarray
    """Vehicle indices of ``[y, z, phi, psi]``."""
    offset: float
    """Distance behind the car's leading axle (m)."""
    radius: float
    half_gauge: float


@dataclass
class Vehicle3DNumeric:
    """A 3D vehicle's matrices and its wheelsets."""

    dof_names: tuple[str, ...]
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    F: np.ndarray
    """Gravity load."""
    wheelsets: list[Wheelset]

    def index(self, name: str) -> int:
        return self.dof_names.index(name)


def vehicle3d(
    topology: Topology3D | str | Path, parameters: Mapping[str, float] | None = None
) -> Vehicle3DNumeric:
    """Derive and evaluate a 3D vehicle; find its wheelsets (a body with ``y, z, phi, psi`` and two
    wheels at ``+-b``, its reference at the axle centre: height = wheel radius). A wheelset's pitch
    (its spin) is left out."""
    topo = topology if isinstance(topology, Topology3D) else load_topology3d(str(topology))
    model = derive_vehicle3d(topo)
    num = model.numeric(dict(parameters or {}))
    values: dict[str, Any] = topo.defaults() | dict(parameters or {})
    subs = {p.symbol: values[n] for n, p in topo.parameters.items() if not isinstance(values[n], tuple)}

    def val(e: sp.Expr) -> float:
        return float(sp.sympify(e).subs(subs))

    wheelsets = []
    for body in topo.bodies:
        wheels = [w for w in topo.wheels if w.body == body.name]
        if not wheels:
            continue
        if len(wheels) != 2 or not {"y", "z", "phi", "psi"} <= set(body.dofs):
            raise ValueError(
                f"{topo.name}: body {body.name!r} carries wheels but is not a wheelset "
                "(two wheels at +-b and the DOFs y, z, phi, psi)"
            )
        lateral = sorted(val(w.lateral) for w in wheels)
        radius = val(wheels[0].radius)
        if not np.isclose(lateral[0], -lateral[1]) or abs(val(body.height) - radius) > 1e-12 * radius:
            raise ValueError(
                f"{topo.name}: wheelset {body.name!r} needs wheels at +-b and its reference at the axle "
                "centre (height = wheel radius)"
            )
        idx = np.array([num.index(f"{k}_{body.name}") for k in ("y", "z", "phi", "psi")])
        wheelsets.append(Wheelset(body.name, idx, val(body.position), radius, lateral[1]))
    # a wheelset's pitch is its spin: the contact model rolls the wheels at v / r0 and leaves the spin
    # perturbation out (docs/three-d.md), so the DOF goes (it has no stiffness: a static solve could
    # not hold it)
    names = list(num.dof_names)
    spin = {names.index(f"theta_{w.name}") for w in wheelsets if f"theta_{w.name}" in names}
    keep = np.array([i for i in range(len(names)) if i not in spin], dtype=int)
    renumber = {old: new for new, old in enumerate(keep)}
    wheelsets = [
        Wheelset(w.name, np.array([renumber[i] for i in w.dofs]), w.offset, w.radius, w.half_gauge)
        for w in wheelsets
    ]
    sub = np.ix_(keep, keep)
    return Vehicle3DNumeric(
        tuple(names[i] for i in keep), num.M[sub], num.C[sub], num.K[sub], num.F_gravity[keep], wheelsets
    )


C1, C0 = sp.symbols("c1 c0", real=True)
PARAMS = (c3.r0, c3.b, c3.lam, c3.ecc, c3.h_rail, c3.v, LE, C1, C0)


@cache
def _callables() -> tuple[Callable[..., Any], Callable[..., Any], Callable[..., Any]]:
    """Gaps, their gradients over ``z`` and the discrete constraint residuals of both contacts,
    lambdified once per process over :data:`ARGS`, :data:`PARAMS` and the irregularities."""
    z = [*c3.WHEELSET_DOFS, *c3.UE]
    gaps = [c.gap for c in c3.contacts()]
    grads = [sp.diff(g, q) for g in gaps for q in z]
    residuals = [gtt + C1 * gt + C0 * g for (gt, gtt), g in zip(c3.gap_rates(), gaps, strict=True)]
    rough = (*c3.IRREGULARITIES, *c3.IRREGULARITY_SLOPES, *c3.IRREGULARITY_CURVATURES)
    args = (*ARGS, *PARAMS, *rough)
    return tuple(sp.lambdify(args, e, "numpy", cse=True) for e in (gaps, grads, residuals))  # type: ignore[return-value]


class ContactKernel3D:
    """Both normal gaps of one wheelset on a deck element, as NumPy callables.

    ``gap``: ``g_s``; ``gradient``: ``dg_s/dz`` over ``z = [y_w, z_w, phi_w, psi_w, u_e (12)]``;
    ``hessian``: its derivative (complex step on the symbolic gradient); ``residual``: the discrete
    constraint ``E_s = g_s'' + c1 g_s' + c0 g_s`` (``c1 = 2 zeta omega``, ``c0 = omega^2``) with the
    exact rates of :func:`svbi.codegen.contact3d.gap_rates`; ``residual_jacobian``:
    ``dE/dz + a1 dE/dz' + a0 dE/dz''`` (Newmark's ``z' = a1 z - Q``, ``z'' = a0 z - P``).
    """

    def __init__(
        self, wheelset: Wheelset, track: Track3D, element_length: float, speed: float, c1: float, c0: float
    ) -> None:
        self._gap, self._grad, self._res = _callables()
        self._params = [
            wheelset.radius,
            wheelset.half_gauge,
            track.conicity,
            track.eccentricity,
            track.rail_height,
            speed,
            element_length,
            c1,
            c0,
            *[0.0] * 9,  # no irregularity
        ]

    def _call(self, fn: Callable[..., Any], args: list[Any], shape: tuple[int, ...]) -> np.ndarray:
        out = fn(*args, *self._params)
        return np.array([np.broadcast_to(np.asarray(o), shape) for o in out])

    @staticmethod
    def _args(z: np.ndarray, zd: np.ndarray, zdd: np.ndarray, xi: Any) -> list[Any]:
        return [*z[:4], *zd[:4], *zdd[:4], *z[4:], *zd[4:], *zdd[4:], xi]

    def gap(self, z: np.ndarray, xi: float) -> np.ndarray:
        """``[g_left, g_right]``."""
        zero = np.zeros(NZ)
        return self._call(self._gap, self._args(z, zero, zero, xi), ())

    def gradient(self, z: np.ndarray, xi: float) -> np.ndarray:
        """2 x 16."""
        zero = np.zeros(NZ)
        return self._call(self._grad, self._args(z, zero, zero, xi), ()).reshape(2, NZ)

    def hessian(self, z: np.ndarray, xi: float) -> np.ndarray:
        """2 x 16 x 16, by the complex step on the gradient."""
        h = COMPLEX_STEP
        zc = z[:, None] + 1j * h * np.eye(NZ)
        zero = np.zeros((NZ, NZ))
        out = self._call(self._grad, self._args(zc, zero, zero, xi), (NZ,))
        return (out.imag / h).reshape(2, NZ, NZ)

    def residual(self, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray, xi: float) -> np.ndarray:
        """``[E_left, E_right]``."""
        return self._call(self._res, self._args(z, zd, zdd, xi), ())

    def residual_jacobian(
        self, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray, xi: float, a1: float, a0: float
    ) -> np.ndarray:
        """2 x 16: the derivative of ``E`` along ``z_{n+1}`` with Newmark's rates."""
        h = COMPLEX_STEP
        eye = 1j * h * np.eye(NZ)
        args = self._args(z[:, None] + eye, zd[:, None] + a1 * eye, zdd[:, None] + a0 * eye, xi)
        return self._call(self._res, args, (NZ,)).imag / h


# --------------------------------------------------------------------------------------------------
# Flange gaps and creep forces: the callables of the unilateral flange contact and of the creep law,
# lambdified in this one place (emitted kernels of the flange gaps and creepages replace them).

FLANGE_PARAMS = (*PARAMS, c3.clearance)
CREEP_LAW_ARGS = (creep3d.f11, creep3d.f22, creep3d.f23, creep3d.normal_load, creep2d.friction)
CREEP_MATERIAL = (*creep2d.PARAMETERS, creep3d.kalker_c22, creep3d.kalker_c23)
CREEP_FORCES = (creep3d.creep_fx, creep3d.creep_fy, creep3d.creep_spin)


@cache
def _flange_creep_callables() -> dict[str, Callable[..., Any]]:
    """Lambdified once per process: ``flange_gap``, ``flange_gradient``, ``flange_residual`` (the
    discrete constraint of both flange gaps), ``creep`` (one per side: the saturated ``F_x``,
    ``F_y`` and the spin moment of Kalker's law), ``kalker`` (``f11, f22, f23`` under a normal
    load) and ``loads`` (the generalised creep loads of both contacts over ``z``)."""
    z = [*c3.WHEELSET_DOFS, *c3.UE]
    rough = (*c3.IRREGULARITIES, *c3.IRREGULARITY_SLOPES, *c3.IRREGULARITY_CURVATURES)
    gaps = [c.flange_gap for c in c3.contacts()]
    grads = [sp.diff(g, q) for g in gaps for q in z]
    residuals = [gtt + C1 * gt + C0 * g for (gt, gtt), g in zip(c3.flange_gap_rates(), gaps, strict=True)]
    args = (*ARGS, *FLANGE_PARAMS, *rough)

    def fn(exprs: list[sp.Expr], extra: tuple[sp.Symbol, ...] = ()) -> Callable[..., Any]:
        return sp.lambdify((*args, *extra), exprs, "numpy", cse=True)

    out: dict[str, Callable[..., Any]] = {
        "flange_gap": fn(gaps),
        "flange_gradient": fn(grads),
        "flange_residual": fn(residuals),
    }
    for force in creep3d.creep_forces():
        out[f"creep_{force.side}"] = fn([force.fx, force.fy, force.spin_moment], CREEP_LAW_ARGS)
    kalker = creep3d.kalker_coefficients()
    out["kalker"] = sp.lambdify(
        (creep3d.normal_load, *CREEP_MATERIAL), [kalker[k] for k in (creep3d.f11, creep3d.f22, creep3d.f23)]
    )
    loads = [e for ld in creep3d.creep_loads() for e in (*ld.wheelset, *ld.deck)]
    out["loads"] = fn(loads, CREEP_FORCES)
    return out


class FlangeCreepKernel3D:
    """Both flange gaps and both contacts' creep forces of one wheelset on a deck element, as
    NumPy callables (the counterpart of :class:`ContactKernel3D` for the flange and the creep law).

    ``flange_*``: as :class:`ContactKernel3D`'s ``gap``, ``gradient``, ``residual``,
    ``residual_jacobian`` for ``g_F,s = c_f - s (y_w - y_r)``; ``creep``: the creep forces of both
    contacts under their normal loads and their generalised loads on ``z``.
    """

    def __init__(
        self,
        wheelset: Wheelset,
        track: Track3D,
        element_length: float,
        speed: float,
        c1: float,
        c0: float,
        creep: CreepParameters | None = None,
    ) -> None:
        self._fn = _flange_creep_callables()
        self._params = [
            wheelset.radius,
            wheelset.half_gauge,
            track.conicity,
            track.eccentricity,
            track.rail_height,
            speed,
            element_length,
            c1,
            c0,
            track.flange_clearance,
            *[0.0] * 9,  # no irregularity
        ]
        self._material: list[float] | None = None
        self.friction = 0.0
        if creep is not None:
            creep = replace(creep, wheel_radius=wheelset.radius)
            named = creep.named_values()
            m, n = creep.hertz
            _, c22, c23 = kalker_coefficients(m / n, creep.poisson_ratio)
            self._material = [*(named[p.name] for p in creep2d.PARAMETERS), c22, c23]
            self.friction = creep.friction

    def _call(self, name: str, args: list[Any], shape: tuple[int, ...], extra: tuple = ()) -> np.ndarray:
        out = self._fn[name](*args, *self._params, *extra)
        return np.array([np.broadcast_to(np.asarray(o), shape) for o in out])

    _args = staticmethod(ContactKernel3D._args)

    def flange_gap(self, z: np.ndarray, xi: float) -> np.ndarray:
        """``[g_F,left, g_F,right]``."""
        zero = np.zeros(NZ)
        return self._call("flange_gap", self._args(z, zero, zero, xi), ())

    def flange_gradient(self, z: np.ndarray, xi: float) -> np.ndarray:
        """2 x 16 (the gap is linear in ``z``: no Hessian)."""
        zero = np.zeros(NZ)
        return self._call("flange_gradient", self._args(z, zero, zero, xi), ()).reshape(2, NZ)

    def flange_residual(self, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray, xi: float) -> np.ndarray:
        """``[E_F,left, E_F,right]``, ``E = g'' + c1 g' + c0 g``."""
        return self._call("flange_residual", self._args(z, zd, zdd, xi), ())

    def flange_residual_jacobian(
        self, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray, xi: float, a1: float, a0: float
    ) -> np.ndarray:
        """2 x 16: the derivative of ``E_F`` along ``z_{n+1}`` with Newmark's rates."""
        h = COMPLEX_STEP
        eye = 1j * h * np.eye(NZ)
        args = self._args(z[:, None] + eye, zd[:, None] + a1 * eye, zdd[:, None] + a0 * eye, xi)
        return self._call("flange_residual", args, (NZ,)).imag / h

    def coefficients(self, normal: float) -> tuple[float, float, float]:
        """Kalker's ``f11, f22, f23`` under the normal load ``normal`` (> 0)."""
        if self._material is None:
            return 0.0, 0.0, 0.0
        f11, f22, f23 = self._fn["kalker"](normal, *self._material)
        return float(f11), float(f22), float(f23)

    @property
    def creeps(self) -> bool:
        return self._material is not None

    def creep(
        self, z: np.ndarray, zd: np.ndarray, xi: float, normal: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(forces, load)``: each contact's ``[F_x, F_y, M_sp]`` (2 x 3, contact frame, on the
        wheel; zero for a contact with ``N <= 0``) and their generalised load on ``z`` (16)."""
        forces = np.zeros((2, 3))
        if self._material is None:
            return forces, np.zeros(NZ)
        args = self._args(z, zd, np.zeros(NZ), xi)
        for k, side in enumerate(("left", "right")):
            if normal[k] <= 0.0:
                continue
            f11, f22, f23 = self._fn["kalker"](normal[k], *self._material)
            law = (f11, f22, f23, normal[k], self.friction)
            forces[k] = self._call(f"creep_{side}", args, (), law)
        load = np.zeros(NZ)
        for k in range(2):
            per = self._call("loads", args, (), tuple(forces[k])).reshape(2, NZ)
            load += per[k]
        return forces, load


@dataclass
class System3D:
    """One 3D car on one simply supported 3D span, bilateral contact (docs/three-d.md)."""

    vehicle: Vehicle3DNumeric
    span: Span3D
    track: Track3D = field(default_factory=Track3D)
    speed: float = 0.0
    start: float = 0.0
    """x of the car's leading axle at t = 0 (m from the left support)."""
    load: np.ndarray | None = None
    """A constant external load on the vehicle DOFs (N, N m), besides gravity."""
    bridge_damping: np.ndarray | None = None
    """The span's damping matrix (default none)."""
    creep: CreepParameters | None = None
    """Wheel-rail material and friction of the creep forces (Kalker with Shen-Hedrick-Elkins
    saturation, :mod:`svbi.codegen.creep3d`; the wheel radius is each wheelset's own); None: no
    creep."""

    def contact_location(self, t: float) -> list[tuple[int, float]]:
        """``(element, xi)`` under each wheelset at ``t``; a wheelset must be on the span."""
        span = self.span
        le = span.length / span.n_elements
        out = []
        for w in self.vehicle.wheelsets:
            x = self.start + self.speed * t - w.offset
            if not 0.0 <= x <= span.length:
                raise ValueError(f"wheelset {w.name!r} is off the span at t = {t} s (x = {x} m)")
            e = min(int(x // le), span.n_elements - 1)
            out.append((e, x / le - e))
        return out

    def vehicle_load(self) -> np.ndarray:
        return self.vehicle.F + (0.0 if self.load is None else np.asarray(self.load, dtype=float))
