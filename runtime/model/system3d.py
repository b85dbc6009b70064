"""Model glue of the 3D time step (docs/three-d.md, "The 3D time step").

A 3D vehicle (derived in :mod:`svbi.codegen.vehicle3d`) on one simply supported 3D span
(:mod:`svbi.runtime.model.span3d`), each wheelset held on its two rails by the normal gaps of
:mod:`svbi.codegen.contact3d`. Nothing here derives: the contact expressions (gaps, their
gradients and Hessians, the discrete constraint residuals and their Jacobians, the flange gaps, the
creepages, the creep law and its generalised loads) are the generated kernels of
``generated/contact3d/numpy_kernels.py`` (:mod:`svbi.codegen.contact3d_kernels`), and a built-in
3D vehicle's matrices its generated module ``generated/<name>/numpy_kernels.py``. A 3D topology
file of the user's (or a parsed topology object) is derived and emitted once into the compile cache
(:func:`svbi.runtime.toolchain.python_module_3d`,
the cache of the 2D topology files), which takes SymPy at that first set-up only.
"""

from __future__ import annotations

import os
import types
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from ...codegen.plain_types import TopologyError, builtin_topologies_3d
from ..toolchain import load_topology3d, python_module_3d
from .creep_law import CreepParameters
from .ground import seen_moving
from .kalker3d import kalker_coefficients
from .kernels import CONTACT3D, load, load_path
from .span3d import Deck3D

NZ = 16
"""The contact's own unknowns ``z = [y_w, z_w, phi_w, psi_w, u_e (12)]``: 4 wheelset DOFs and the
element's 12."""
NIRREGULARITY = 9
GROUND = -1
"""The element that :meth:`System3D.contact_location` gives a wheelset on the approach track (the
rigid track before and after the deck, moving with the ground)."""
"""Irregularity arguments of the contact kernels: ``[r_v, r_a, r_c]``, their slopes and curvatures."""


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


def _vehicle_module(topology: Any) -> types.ModuleType:
    """The generated module of a built-in 3D vehicle name, a 3D topology file or a parsed topology
    (an object with its TOML ``text``, as :func:`svbi.codegen.topology3d.parse_topology3d` returns)."""
    if isinstance(topology, str | Path):
        name = str(topology)
        if name in builtin_topologies_3d():
            return load(name)
        if not Path(name).is_file():
            known = ", ".join(builtin_topologies_3d())
            raise TopologyError(name, "vehicle", f"not a built-in 3D vehicle ({known}) and no such file")
        return load_path(python_module_3d(name))
    text = getattr(topology, "text", "")
    if not text:
        raise TypeError(
            f"{topology!r} is not a 3D vehicle name, a topology file or a parsed topology with its text"
        )
    return load_path(python_module_3d(text=text, source=getattr(topology, "source", "<string>")))


@dataclass(frozen=True)
class VehicleParameter3D:
    """A 3D vehicle's parameter as a scenario's checks and defaults see it."""

    value: float | tuple[float, ...]
    """The default: a number or a list (a bump stop's table)."""
    signed: bool
    """Whether it may be negative."""


@dataclass(frozen=True)
class VehicleParameters3D:
    """A 3D vehicle's name and its parameters (defaults, sign), by name in file order."""

    name: str
    parameters: dict[str, VehicleParameter3D]


def vehicle_parameters3d(name_or_path: str | Path) -> VehicleParameters3D:
    """The parameters of a built-in 3D vehicle's name or a 3D topology file, for the checks and
    defaults of a 3D scenario. A built-in vehicle's come from its generated module's ``DATA`` (no
    SymPy); a file is parsed and validated (:func:`svbi.runtime.toolchain.load_topology3d`, which
    imports SymPy), once per process while the file is unchanged. ``TopologyError`` (key
    ``vehicle``) for a name that is neither."""
    ref = str(name_or_path)
    if ref in builtin_topologies_3d():
        data = load(ref).DATA
        signed = set(data["signed"])
        return VehicleParameters3D(
            str(data["name"]),
            {n: VehicleParameter3D(v, n in signed) for n, v in data["parameters"]},
        )
    if not os.path.lexists(ref):
        known = ", ".join(builtin_topologies_3d())
        raise TopologyError(ref, "vehicle", f"not a built-in 3D vehicle ({known}) and no such file")
    try:
        st = os.stat(ref)
        stamp: tuple[int, int, int] = (st.st_ino, st.st_size, st.st_mtime_ns)
    except OSError:
        stamp = (0, 0, 0)
    return _file_parameters3d(os.path.abspath(ref), ref, stamp)


@lru_cache(maxsize=16)
def _file_parameters3d(path: str, ref: str, stamp: tuple[int, int, int]) -> VehicleParameters3D:
    """:func:`vehicle_parameters3d` of a topology file, parsed once per ``(path, stamp)`` (a file
    whose size, inode or modification time changes is parsed again; errors are not cached)."""
    topo = load_topology3d(ref)  # SymPy: the parser's expressions
    return VehicleParameters3D(
        topo.name, {n: VehicleParameter3D(p.value, bool(p.signed)) for n, p in topo.parameters.items()}
    )


def vehicle3d(topology: Any, parameters: Mapping[str, float] | None = None) -> Vehicle3DNumeric:
    """Evaluate a 3D vehicle's generated matrices and find its wheelsets (a body with
    ``y, z, phi, psi`` and two wheels at ``+-b``, its reference at the axle centre: height = wheel
    radius). A wheelset's pitch (its spin) is left out.

    ``topology``: a built-in 3D vehicle's name (its committed module, no SymPy), a 3D topology file
    or a parsed :class:`svbi.codegen.topology3d.Topology3D` (derived and emitted once into the
    compile cache at the first set-up, which imports SymPy then; later set-ups only load it).
    ``parameters`` override the topology's defaults."""
    module = _vehicle_module(topology)
    data = module.DATA
    name = data["name"]
    values: dict[str, Any] = dict(data["parameters"])
    for key, value in (parameters or {}).items():
        if key not in values:
            raise KeyError(f"{name}: unknown parameter {key!r}")
        values[key] = float(value)
    p = [float(values[n]) for n in data["parameter_vector"]]
    names = list(data["dof_names"])
    n = len(names)
    M, C, K = (
        np.asarray(f(p), dtype=float).reshape(n, n)
        for f in (module.mass_matrix, module.damping_matrix, module.stiffness_matrix)
    )
    F = np.asarray(module.gravity_load(p), dtype=float).reshape(n)
    _, laterals, radii = (np.atleast_1d(np.asarray(a, dtype=float)) for a in module.wheel_geometry(p))
    body_positions, heights = (np.atleast_1d(np.asarray(a, dtype=float)) for a in module.body_geometry(p))

    wheelsets = []
    for j, (body, dofs) in enumerate(data["bodies"]):
        wheels = [k for k, (_, wheel_body) in enumerate(data["wheels"]) if wheel_body == body]
        if not wheels:
            continue
        if len(wheels) != 2 or not {"y", "z", "phi", "psi"} <= set(dofs):
            raise ValueError(
                f"{name}: body {body!r} carries wheels but is not a wheelset "
                "(two wheels at +-b and the DOFs y, z, phi, psi)"
            )
        lateral = sorted(float(laterals[k]) for k in wheels)
        radius = float(radii[wheels[0]])
        if not np.isclose(lateral[0], -lateral[1]) or abs(heights[j] - radius) > 1e-12 * radius:
            raise ValueError(
                f"{name}: wheelset {body!r} needs wheels at +-b and its reference at the axle "
                "centre (height = wheel radius)"
            )
        idx = np.array([names.index(f"{k}_{body}") for k in ("y", "z", "phi", "psi")])
        wheelsets.append(Wheelset(body, idx, float(body_positions[j]), radius, lateral[1]))
    # a wheelset's pitch is its spin: the contact model rolls the wheels at v / r0 and leaves the spin
    # perturbation out (docs/three-d.md), so the DOF goes (it has no stiffness: a static solve could
    # not hold it)
    spin = {names.index(f"theta_{w.name}") for w in wheelsets if f"theta_{w.name}" in names}
    keep = np.array([i for i in range(len(names)) if i not in spin], dtype=int)
    renumber = {old: new for new, old in enumerate(keep)}
    wheelsets = [
        Wheelset(w.name, np.array([renumber[i] for i in w.dofs]), w.offset, w.radius, w.half_gauge)
        for w in wheelsets
    ]
    sub = np.ix_(keep, keep)
    return Vehicle3DNumeric(tuple(names[i] for i in keep), M[sub], C[sub], K[sub], F[keep], wheelsets)


class ContactKernel3D:
    """Both contacts of one wheelset on a deck element: the generated kernels of
    ``generated/contact3d/`` (:mod:`svbi.codegen.contact3d_kernels`) at this wheelset's geometry.

    ``z = [y_w, z_w, phi_w, psi_w, u_e (12)]`` (:data:`NZ`), ``zd``, ``zdd`` its rates and
    accelerations, ``xi`` the contact's position in the element. Every result has the left contact
    (side ``s = +1``) first, the right one second.

    Normal contact:

    * ``gap``: ``[g_left, g_right]``; ``gradient``: ``dg_s/dz`` (2 x 16); ``hessian``: its
      derivative (2 x 16 x 16);
    * ``residual``: the discrete constraint ``E_s = g_s'' + c1 g_s' + c0 g_s`` (``c1 = 2 zeta
      omega``, ``c0 = omega^2``) with the exact rates of :func:`svbi.codegen.contact3d.gap_rates`;
      ``residual_jacobian``: ``dE/dz + a1 dE/dz' + a0 dE/dz''`` (Newmark's ``z' = a1 z - Q``,
      ``z'' = a0 z - P``), 2 x 16.

    Flange contact (the lateral clearance ``flange_clearance`` per side; unilateral, ``g_F >= 0``):
    ``flange_gap``, ``flange_gradient`` (2 x 16; the gap is linear: no Hessian), ``flange_residual``,
    ``flange_residual_jacobian``, as the normal ones.

    Creep (:mod:`svbi.codegen.creep3d`): ``creepages`` ``[[xi_x, xi_y, xi_sp]_left,
    [...]_right]`` (2 x 3), ``creepage_gradient`` over ``z`` and ``creepage_rate_gradient`` over
    ``z'`` (2 x 3 x 16 each). The slip velocity is linear in ``z'``, so ``v`` times a rate gradient
    row is the generalized-force direction of the matching creep force (its power on the slip):
    ``Q = v (F_x dxi_x/dz' + F_y dxi_y/dz' + M_sp dxi_sp/dz')`` on ``z`` (wheelset and deck
    together) for the force ``(F_x, F_y)`` along ``(t_x, t_y)`` and the moment ``M_sp`` about the
    normal that the rail exerts on the wheel (their power on the slip is ``Q . z'`` plus terms free
    of ``z'``). ``creep_load_direction`` (2 x 16 x 3): the generalised loads on ``z`` of a unit
    ``[F_x, F_y, M_sp]`` of each contact by the virtual work of
    :func:`svbi.codegen.creep3d.creep_loads` (the loads the step applies).

    ``irregularity`` (9: ``[r_v, r_a, r_c]`` under the axle, their slopes and curvatures along
    ``x``) is an attribute the step may set before calling; zero by default. So is
    ``element_length``: the length of the element under the wheelset (a deck of spans of different
    lengths has elements of different lengths).
    """

    def __init__(
        self,
        wheelset: Wheelset,
        track: Track3D,
        element_length: float,
        speed: float,
        c1: float,
        c0: float,
        flange_clearance: float = 0.0,
    ) -> None:
        self._k = load(CONTACT3D)
        self._geometry = [
            wheelset.radius,
            wheelset.half_gauge,
            track.conicity,
            track.eccentricity,
            track.rail_height,
            flange_clearance,
            speed,
            element_length,
        ]
        self._c1, self._c0 = c1, c0
        self.irregularity = np.zeros(NIRREGULARITY)

    @property
    def element_length(self) -> float:
        """The length of the deck element the kernels are evaluated on (m): the last entry of their
        geometry argument, which the step sets to the element under the wheelset before calling
        (:meth:`System3D.element_length_at`)."""
        return float(self._geometry[7])

    @element_length.setter
    def element_length(self, value: float) -> None:
        self._geometry[7] = float(value)

    def _call(
        self,
        name: str,
        z: np.ndarray,
        zd: np.ndarray | None,
        zdd: np.ndarray | None,
        xi: float,
        a1: float = 0.0,
        a0: float = 0.0,
    ) -> Any:
        zero = np.zeros(NZ)
        zd = zero if zd is None else zd
        zdd = zero if zdd is None else zdd
        fn = getattr(self._k, name)
        return fn(
            z[:4],
            zd[:4],
            zdd[:4],
            z[4:],
            zd[4:],
            zdd[4:],
            xi,
            self._geometry,
            self.irregularity,
            (self._c1, self._c0, a1, a0),
        )

    # normal contact

    def gap(self, z: np.ndarray, xi: float) -> np.ndarray:
        """``[g_left, g_right]``."""
        return np.asarray(self._call("normal_gaps", z, None, None, xi))

    def gradient(self, z: np.ndarray, xi: float) -> np.ndarray:
        """2 x 16."""
        return np.asarray(self._call("normal_gap_gradients", z, None, None, xi))

    def hessian(self, z: np.ndarray, xi: float) -> np.ndarray:
        """2 x 16 x 16."""
        return np.array(self._call("normal_gap_hessians", z, None, None, xi))

    def residual(self, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray, xi: float) -> np.ndarray:
        """``[E_left, E_right]``."""
        return np.asarray(self._call("normal_residuals", z, zd, zdd, xi))

    def residual_jacobian(
        self, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray, xi: float, a1: float, a0: float
    ) -> np.ndarray:
        """2 x 16: the derivative of ``E`` along ``z_{n+1}`` with Newmark's rates."""
        return np.asarray(self._call("normal_residual_jacobians", z, zd, zdd, xi, a1, a0))

    # flange contact

    def flange_gap(self, z: np.ndarray, xi: float) -> np.ndarray:
        """``[g_F_left, g_F_right]`` (m)."""
        return np.asarray(self._call("flange_gaps", z, None, None, xi))

    def flange_gradient(self, z: np.ndarray, xi: float) -> np.ndarray:
        """2 x 16 (constant in ``z``)."""
        return np.asarray(self._call("flange_gap_gradients", z, None, None, xi), dtype=float)

    def flange_residual(self, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray, xi: float) -> np.ndarray:
        """``[E_F_left, E_F_right]``, ``E_F = g_F'' + c1 g_F' + c0 g_F``."""
        return np.asarray(self._call("flange_residuals", z, zd, zdd, xi))

    def flange_residual_jacobian(
        self, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray, xi: float, a1: float, a0: float
    ) -> np.ndarray:
        """2 x 16: the derivative of ``E_F`` along ``z_{n+1}`` with Newmark's rates."""
        return np.asarray(self._call("flange_residual_jacobians", z, zd, zdd, xi, a1, a0))

    # creep

    def creepages(self, z: np.ndarray, zd: np.ndarray, xi: float) -> np.ndarray:
        """2 x 3: ``[xi_x, xi_y, xi_sp]`` of each side."""
        return np.asarray(self._call("creepages", z, zd, None, xi)).reshape(2, 3)

    def creepage_gradient(self, z: np.ndarray, zd: np.ndarray, xi: float) -> np.ndarray:
        """2 x 3 x 16: ``d xi / dz``."""
        return np.asarray(self._call("creepage_gradients", z, zd, None, xi)).reshape(2, 3, NZ)

    def creepage_rate_gradient(self, z: np.ndarray, zd: np.ndarray, xi: float) -> np.ndarray:
        """2 x 3 x 16: ``d xi / dz'``."""
        return np.asarray(self._call("creepage_rate_gradients", z, zd, None, xi)).reshape(2, 3, NZ)

    def creep_load_direction(self, z: np.ndarray, xi: float) -> np.ndarray:
        """2 x 16 x 3: the generalised loads on ``z`` of a unit ``[F_x, F_y, M_sp]`` of each side."""
        return np.array(self._call("creep_load_directions", z, None, None, xi), dtype=float)


class FlangeCreepKernel3D:
    """Both flange gaps and both contacts' creep forces of one wheelset on a deck element, on the
    generated kernels of ``generated/contact3d/`` (:mod:`svbi.codegen.contact3d_kernels`).

    ``flange_*``: as :class:`ContactKernel3D`'s ``gap``, ``gradient``, ``residual``,
    ``residual_jacobian`` for ``g_F,s = c_f - s (y_w - y_r)``; ``creep``: the creep forces of both
    contacts under their normal loads (the ``creepages`` of each side through the generated
    ``creep_forces``: Kalker's law with Shen-Hedrick-Elkins saturation) and their generalised loads
    on ``z`` (``creep_load_directions`` times the forces); ``coefficients``: Kalker's ``f11, f22,
    f23`` under a normal load (``kalker_coefficients``).
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
        contact: ContactKernel3D | None = None,
    ) -> None:
        # ``contact``: the step's own normal-contact kernel of this wheelset, shared so that the
        # irregularities a run sets on it reach the flange gaps and the creepages too
        self._contact = contact or ContactKernel3D(
            wheelset, track, element_length, speed, c1, c0, flange_clearance=track.flange_clearance
        )
        self._k = load(CONTACT3D)
        self._material: np.ndarray | None = None
        self.friction = 0.0
        if creep is not None:
            creep = replace(creep, wheel_radius=wheelset.radius)
            named = {**creep.named_values()}
            m, n = creep.hertz
            _, named["kalker_c22"], named["kalker_c23"] = kalker_coefficients(m / n, creep.poisson_ratio)
            self._material = np.array([named[name] for name in self._k.DATA["creep_names"]], dtype=float)
            self.friction = creep.friction

    def flange_gap(self, z: np.ndarray, xi: float) -> np.ndarray:
        """``[g_F,left, g_F,right]``."""
        return self._contact.flange_gap(z, xi)

    def flange_gradient(self, z: np.ndarray, xi: float) -> np.ndarray:
        """2 x 16 (the gap is linear in ``z``: no Hessian)."""
        return self._contact.flange_gradient(z, xi)

    def flange_residual(self, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray, xi: float) -> np.ndarray:
        """``[E_F,left, E_F,right]``, ``E = g'' + c1 g' + c0 g``."""
        return self._contact.flange_residual(z, zd, zdd, xi)

    def flange_residual_jacobian(
        self, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray, xi: float, a1: float, a0: float
    ) -> np.ndarray:
        """2 x 16: the derivative of ``E_F`` along ``z_{n+1}`` with Newmark's rates."""
        return self._contact.flange_residual_jacobian(z, zd, zdd, xi, a1, a0)

    def coefficients(self, normal: float) -> tuple[float, float, float]:
        """Kalker's ``f11, f22, f23`` under the normal load ``normal`` (> 0)."""
        if self._material is None:
            return 0.0, 0.0, 0.0
        f11, f22, f23 = self._k.kalker_coefficients(np.zeros(3), normal, self._material)
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
        creepages = self._contact.creepages(z, zd, xi)
        for k in range(2):
            if normal[k] <= 0.0:
                continue
            forces[k] = self._k.creep_forces(creepages[k], float(normal[k]), self._material)
        directions = self._contact.creep_load_direction(z, xi)
        load = directions[0] @ forces[0] + directions[1] @ forces[1]
        return forces, load


@dataclass
class System3D:
    """One 3D car (or train) on a 3D span or bridge and the rigid approach track before and after
    it, under an optional ground motion (docs/three-d.md)."""

    vehicle: Vehicle3DNumeric
    span: Deck3D
    """A simply supported span (:class:`~svbi.runtime.model.span3d.Span3D`) or a bridge of several
    spans (:class:`~svbi.runtime.model.bridge3d.Bridge3D`)."""
    track: Track3D = field(default_factory=Track3D)
    speed: float = 0.0
    start: float = 0.0
    """x of the car's leading axle at t = 0 (m from the left support; negative: on the approach
    track before the deck)."""
    load: np.ndarray | None = None
    """A constant external load on the vehicle DOFs (N, N m), besides gravity."""
    bridge_damping: np.ndarray | None = None
    """The span's damping matrix (default none)."""
    creep: CreepParameters | None = None
    """Wheel-rail material and friction of the creep forces (Kalker with Shen-Hedrick-Elkins
    saturation, :mod:`svbi.codegen.creep3d`; the wheel radius is each wheelset's own); None: no
    creep."""
    ground: Any = None
    """The ground motion, with the interface of the 2D ground (:mod:`svbi.runtime.model.ground`:
    ``motion(t, x)`` gives the vertical and longitudinal ``(q, q', q'')`` at fixed points, ``lateral(t,
    x)`` the transverse one, positive left, ``apparent_velocity`` a travelling wave's speed or
    None): a :class:`~svbi.runtime.model.ground.FunctionGround` or the ground of a scenario
    (``ground_from_scenario``). The supports follow it line by line (the deck must be a
    :class:`~svbi.runtime.model.bridge3d.Bridge3D`), the approach track under the wheels too. None:
    the ground at rest."""

    element_lengths: np.ndarray = field(init=False, repr=False)
    """The length of every deck element (m), as the contact kernels take it
    (:meth:`element_length_at`)."""
    ground_element_length: float = field(init=False, repr=False)
    """The element length the contact kernels take on the approach track (m): the deck's mean,
    ``length / n_elements``. The ground's "element" is a rigid translation (equal at both nodes, no
    rotation), on which the kernels do not depend on the length but through round-off."""

    def __post_init__(self) -> None:
        span = self.span
        self.ground_element_length = span.length / span.n_elements
        lengths = np.asarray(span.deck_element_length, dtype=float)
        if lengths.shape != (span.n_elements,) or not (np.isfinite(lengths).all() and (lengths > 0).all()):
            raise ValueError(f"the deck's element lengths must be {span.n_elements} positive numbers")
        if np.allclose(lengths, lengths[0], rtol=1e-12, atol=0.0):
            # a deck of equal elements: every element takes length / n_elements, as it always has
            lengths = np.full(span.n_elements, self.ground_element_length)
        self.element_lengths = lengths
        if self.ground is not None and not hasattr(self.span, "support_motion"):
            raise ValueError(
                "a ground motion needs a deck with supports on the ground (a Bridge3D; a Span3D has "
                "no support lines)"
            )

    def positions(self, t: float) -> np.ndarray:
        """x of every wheelset at ``t`` (m from the deck's start)."""
        return np.array([self.start + self.speed * t - w.offset for w in self.vehicle.wheelsets])

    def contact_location(self, t: float) -> list[tuple[int, float]]:
        """``(element, xi)`` under each wheelset at ``t``: a deck element (``span.deck_location``)
        for ``0 <= x < span.length``, else :data:`GROUND` (the approach track; ``xi`` 0). As in 2D
        the last abutment is off the deck: there the deck and the track are both the ground."""
        out = []
        for x in self.positions(t):
            out.append(self.span.deck_location(x) if 0.0 <= x < self.span.length else (GROUND, 0.0))
        return out

    def contact_locations(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`contact_location` at many times at once: ``(element, xi)``, each ``(len(t),
        wheelsets)`` (int, float), ``element`` :data:`GROUND` and ``xi`` 0 off the deck."""
        offsets = np.array([w.offset for w in self.vehicle.wheelsets])
        x = self.start + self.speed * np.asarray(t, dtype=float)[:, None] - offsets[None, :]
        on = (x >= 0.0) & (x < self.span.length)
        element = np.full(x.shape, GROUND, dtype=np.intp)
        xi = np.zeros(x.shape)
        element[on], xi[on] = self.span.deck_locations(x[on])
        return element, xi

    def element_length_at(self, element: int) -> float:
        """The element length that the contact kernels take on ``element`` (a deck element, or
        :data:`GROUND`: :attr:`ground_element_length`)."""
        return self.ground_element_length if element == GROUND else float(self.element_lengths[element])

    def ground_motion(self, t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(q, q', q'')`` of the ground at fixed points ``x``, each ``(len(x), 3)``: the ``x``
        (longitudinal), ``y`` (lateral) and ``z`` (vertical) components (partial time
        derivatives)."""
        x = np.atleast_1d(np.asarray(x, dtype=float))
        if self.ground is None:
            z = np.zeros((len(x), 3))
            return z, z.copy(), z.copy()
        vertical, longitudinal = self.ground.motion(t, x)
        lateral = self.ground.lateral(t, x)
        return tuple(  # type: ignore[return-value]
            np.stack([np.broadcast_to(c[k], x.shape) for c in (longitudinal, lateral, vertical)], axis=-1)
            for k in range(3)
        )

    def ground_motions(self, times: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`ground_motion` at many times at once: ``(q, q', q'')``, each ``(len(times), m,
        3)``, at the fixed points ``x`` (``(m,)``) or at points that differ from time to time
        (``(len(times), m)``); the same numbers (the ground's
        :meth:`~svbi.runtime.model.ground.Ground.motions`)."""
        times = np.atleast_1d(np.asarray(times, dtype=float))
        x = np.broadcast_to(np.asarray(x, dtype=float), (times.size, np.shape(x)[-1]))
        if self.ground is None:
            z = np.zeros((*x.shape, 3))
            return z, z.copy(), z.copy()
        parts = [self.ground.motions(name, times, x) for name in ("longitudinal", "lateral", "vertical")]
        q, q1, q2 = (np.stack([p[k] for p in parts], axis=-1) for k in range(3))
        return q, q1, q2

    def ground_under(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The ground under every wheelset at ``t`` as three rigid "elements": ``(z_e, z_e', z_e'')``,
        each ``(wheelsets, 12)``, the translation ``[q_x, q_y, q_z, 0, 0, 0]`` at both nodes with its
        total time derivatives along the moving wheelset (``(1 - v/c)`` and its square for a
        travelling wave, as :meth:`svbi.runtime.model.ground.Ground.under`). The contact kernels on
        such an element are the rigid track moving with the ground."""
        nW = len(self.vehicle.wheelsets)
        out = [np.zeros((nW, 12)) for _ in range(3)]
        if self.ground is None:
            return out[0], out[1], out[2]
        q = self.ground_motion(t, self.positions(t))
        moving = seen_moving(*q, getattr(self.ground, "apparent_velocity", None), self.speed)
        for k in range(3):
            out[k][:, 0:3] = moving[k]
            out[k][:, 6:9] = moving[k]
        return out[0], out[1], out[2]

    def vehicle_load(self) -> np.ndarray:
        return self.vehicle.F + (0.0 if self.load is None else np.asarray(self.load, dtype=float))
