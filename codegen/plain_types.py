"""SymPy-free definitions shared by the symbolic pipeline and the runtime.

A run of a built-in vehicle imports only these and the generated NumPy modules, never SymPy: the
numeric vehicle container, the value of g, the split check, and the checks and error type of
topology parameter values. ``svbi.codegen.vehicle`` and ``svbi.codegen.topology`` re-export them.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from importlib import resources
from typing import Any

import numpy as np

from .input_files import key_line

PYTHON_KERNELS_FILE = "numpy_kernels.py"
"""Name of a model's generated NumPy module (``svbi.codegen.python_emit``) in its folder."""

GRAVITY = 9.81
"""g in m/s^2 (docs/design.md section 2); the symbolic kernels substitute it exactly as 981/100."""


class TopologyError(ValueError):
    """A topology file or a parameter override is invalid. The message names file, key and problem,
    and the key's line when the source is a file that writes it (``file:line: key: problem``)."""

    def __init__(self, source: str, key: str, problem: str) -> None:
        self.source, self.key, self.problem = source, key, problem
        line = key_line(source, key)
        super().__init__(f"{source}{f':{line}' if line else ''}: {key}: {problem}")


def builtin_topologies() -> list[str]:
    """Names of the topologies that ship with svbi."""
    folder = resources.files("svbi.codegen.vehicles")
    return sorted(p.name[: -len(".toml")] for p in folder.iterdir() if p.name.endswith(".toml"))


def builtin_topologies_3d() -> list[str]:
    """Names of the 3D topologies that ship with svbi."""
    folder = resources.files("svbi.codegen.vehicles3d")
    return sorted(p.name[: -len(".toml")] for p in folder.iterdir() if p.name.endswith(".toml"))


def check_value(source: str, key: str, raw: Any, signed: bool, like: Any) -> float | tuple[float, ...]:
    """A parameter value: a finite number (non-negative unless ``signed``), or a non-empty list of
    them when ``like`` (the default) is a list."""
    if isinstance(like, tuple) or isinstance(raw, list | tuple):
        if not isinstance(raw, list | tuple) or not raw:
            raise TopologyError(source, key, "must be a non-empty list of numbers")
        return tuple(check_value(source, f"{key}[{i}]", v, signed, 0.0) for i, v in enumerate(raw))
    if isinstance(raw, bool) or not isinstance(raw, int | float):
        raise TopologyError(source, key, f"must be a number, got {raw!r}")
    value = float(raw)
    if not math.isfinite(value):
        raise TopologyError(source, key, "must be finite")
    if value < 0 and not signed:
        raise TopologyError(source, key, f"must not be negative, got {value:g}")
    return value


def validate_split(a: float, where: str = "solver.contact_split") -> float:
    """Check the split coefficient: 0 < a < 1 keeps both wheel and aux masses positive (Section 2.3)."""
    if isinstance(a, bool) or not isinstance(a, int | float) or not 0.0 < float(a) < 1.0:
        raise ValueError(f"{where}: the split coefficient a must lie strictly between 0 and 1, got {a!r}")
    return float(a)


@dataclass(frozen=True)
class NumericVehicle:
    """One vehicle's matrices evaluated at a parameter set (NumPy arrays, SI units)."""

    name: str
    kind: str
    dof_names: tuple[str, ...]
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    F_gravity: np.ndarray
    W_N: np.ndarray
    W_T: np.ndarray
    wheel_offsets: np.ndarray
    wheel_masses: np.ndarray
    wheel_radii: np.ndarray
    car_length: float
    carbody_z: int | None
    carbody_theta: int | None
    axle_loads: np.ndarray = field(default_factory=lambda: np.zeros(0))
    axle_offsets: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def ndof(self) -> int:
        return len(self.dof_names)

    @property
    def nwheels(self) -> int:
        return len(self.wheel_offsets)


def c_identifier(name: str) -> str:
    """C-safe spelling of a model name: ``pioneer-2d`` -> ``pioneer_2d``.

    Runs of underscores collapse and none is left at either end: the identifier is also a prefix of
    CasADi function names (``svbi_<model>_<kernel>``), which must not hold two underscores in a row
    (``"two axle wagon!"`` -> ``two_axle_wagon``)."""
    ident = re.sub(r"_+", "_", re.sub(r"[^A-Za-z0-9_]", "_", name)).strip("_")
    if not ident or ident[0].isdigit():
        ident = "m_" + ident
    return ident


def _dof_body(dof_name: str) -> tuple[str, str]:
    """``("z" | "theta", body)`` of a vehicle DOF name such as ``theta_wheelset_1``."""
    kind, _, body = dof_name.partition("_")
    return kind, body


def spin_dofs(vehicle: NumericVehicle) -> list[int]:
    """DOFs that are a wheel's spin: a rotation that moves a contact point along the rail (its row of
    ``W_T`` is non-zero) but not up or down (its row of ``W_N`` is zero). With the wheels held on rigid
    track they are the only motions allowed to be free (the creep force of Eq. 16 acts on them)."""
    if not vehicle.nwheels:
        return []
    tol = 1e-12 * max(float(np.abs(vehicle.W_N).max()), 1.0)
    return [
        i
        for i, name in enumerate(vehicle.dof_names)
        if name.startswith("theta_")
        and np.abs(vehicle.W_N[i]).max() <= tol
        and np.abs(vehicle.W_T[i]).max() > 0
    ]


def mechanism_problem(
    vehicle: NumericVehicle,
    wheel_names: tuple[str, ...] = (),
    suspensions: tuple[tuple[str, str, str, float], ...] = (),
) -> str | None:
    """Why the vehicle is not restrained with its wheels held on rigid track, or ``None``.

    The motions that neither the suspensions (``K``) nor the wheel contacts (``W_N^T``) resist are the
    null space of ``[K; W_N^T]``; every such motion must be a wheel spin (:func:`spin_dofs`), otherwise
    the static start (docs/design.md section 2) has no solution. Also rejected: wheel contacts that repeat one
    another (``W_N`` without full column rank), which make the constraint masses of Eq. (27) singular.
    The message names the bodies that move, and a wheel that sits away from its body's reference point
    on a body whose rotation is then not a spin, and the suspensions of zero stiffness that touch a
    moving body (``suspensions``: name, body_a, body_b, stiffness value, where known).
    """
    if vehicle.kind != "rigid-body" or not vehicle.ndof:
        return None
    for label, matrix in (("mass", vehicle.M), ("damping", vehicle.C), ("stiffness", vehicle.K)):
        if not np.isfinite(matrix).all():
            return f"the {label} matrix is not finite with these parameter values (an overflow)"
    if not (np.isfinite(vehicle.W_N).all() and np.isfinite(vehicle.W_T).all()):
        return "the wheel contact directions are not finite with these parameter values (an overflow)"
    names = wheel_names or tuple(f"wheels[{j}]" for j in range(vehicle.nwheels))
    if vehicle.nwheels:
        s = np.linalg.svd(vehicle.W_N, compute_uv=False)
        if s.min() <= 1e-9 * s.max():
            _, _, vt = np.linalg.svd(vehicle.W_N)
            dependent = [names[j] for j in np.nonzero(np.abs(vt[-1]) > 1e-6)[0]]
            return (
                f"wheels {', '.join(repr(n) for n in dependent)} hold the same motion of their bodies "
                "(redundant contacts): give each wheel its own body or its own position on a pitching body"
            )
    # Jacobi scaling D K D (D = diag(K)^-1/2): a stiff suspension beside a soft one must not make the
    # soft one look like zero stiffness; motions are u = D u'
    diag = np.diag(vehicle.K).astype(float)
    d = np.where(diag > 0, 1.0 / np.sqrt(np.where(diag > 0, diag, 1.0)), 1.0)
    k_scaled = vehicle.K * d[:, None] * d[None, :]
    held = np.vstack([k_scaled, vehicle.W_N.T * d[None, :]]) if vehicle.nwheels else k_scaled
    sv_full = np.linalg.svd(held, full_matrices=True)
    sv, vt = sv_full[1], sv_full[2]
    rank = int(np.sum(sv > 1e-10 * max(float(sv.max()), 1e-300)))
    free = vt[rank:].T * d[:, None]  # columns: the unrestrained motions u = D u'
    if free.size:
        free = free / np.abs(free).max(axis=0, keepdims=True)
    if not free.size:
        return None
    spins = spin_dofs(vehicle)
    others = [i for i in range(vehicle.ndof) if i not in spins]
    moving = free[others]
    if not moving.size or np.abs(moving).max() <= 1e-8:
        return None
    # bodies with a visible share of an unrestrained motion that is not a wheel spin
    u, s, _ = np.linalg.svd(moving, full_matrices=False)
    bad = u[:, s > 1e-8 * s.max()]
    weight = np.sqrt((bad**2).sum(axis=1))
    bodies: list[str] = []
    for i, w in zip(others, weight, strict=True):
        body = _dof_body(vehicle.dof_names[i])[1]
        if w > 0.05 * weight.max() and body not in bodies:
            bodies.append(body)
    hints = []
    for j, wname in enumerate(names):
        for i, dof in enumerate(vehicle.dof_names):
            kind, body = _dof_body(dof)
            # the wheel's body is the one whose rotation tilts the contact: W_N = -(distance)
            if kind == "theta" and body in bodies and vehicle.W_N[i, j] != 0:
                hints.append(
                    f"wheel {wname!r} sits {abs(vehicle.W_N[i, j]):.4g} m from the reference point of "
                    f"body {body!r}, so that body's rotation is not a free spin"
                )
    for i, dof in enumerate(vehicle.dof_names):
        kind, body = _dof_body(dof)
        carries_wheel = any(
            vehicle.W_N[k, j] != 0
            for k, other in enumerate(vehicle.dof_names)
            if other == f"z_{body}"
            for j in range(vehicle.nwheels)
        )
        if kind == "theta" and body in bodies and carries_wheel and not np.abs(vehicle.W_T[i]).max() > 0:
            hints.append(f"the wheel of body {body!r} has no radius, so its rotation is not a spin")
    for sname, a, b, stiffness in suspensions:
        if stiffness == 0 and (a in bodies or b in bodies):
            hints.append(f"suspension {sname!r} ({a} - {b}) has zero stiffness")
    listed = ", ".join(repr(b) for b in bodies)
    noun = "body" if len(bodies) == 1 else "bodies"
    hint = ("; " + "; ".join(hints)) if hints else ""
    return (
        f"a mechanism: {noun} {listed} can move with the wheels held on the track (connected to nothing, "
        f"or only through suspensions of zero stiffness){hint}; only a wheel's spin may be free"
    )
