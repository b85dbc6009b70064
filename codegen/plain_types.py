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

PYTHON_KERNELS_FILE = "numpy_kernels.py"
"""Name of a model's generated NumPy module (``svbi.codegen.python_emit``) in its folder."""

GRAVITY = 9.81
"""g in m/s^2 (DESIGN.md section 2); the symbolic kernels substitute it exactly as 981/100."""


class TopologyError(ValueError):
    """A topology file or a parameter override is invalid. The message names file, key and problem."""

    def __init__(self, source: str, key: str, problem: str) -> None:
        self.source, self.key, self.problem = source, key, problem
        super().__init__(f"{source}: {key}: {problem}")


def builtin_topologies() -> list[str]:
    """Names of the topologies that ship with svbi."""
    folder = resources.files("svbi.codegen.vehicles")
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
    """C-safe spelling of a model name: ``pioneer-2d`` -> ``pioneer_2d``."""
    ident = re.sub(r"[^A-Za-z0-9_]", "_", name)
    if not ident or ident[0].isdigit():
        ident = "m_" + ident
    return ident
