"""A vehicle as its generated kernels: parameter validation and numeric matrices, without SymPy.

:class:`GeneratedVehicle` offers what the symbolic ``svbi.codegen.vehicle.VehicleModel`` offered a
run (``topology.values``, ``numeric``), plus the vehicle constraint masses of Eq. (27), all from
the vehicle's generated module (``svbi.codegen.python_emit``): every matrix is a generated function
of the topology's parameter vector.
"""

from __future__ import annotations

import types
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...codegen.plain_types import (
    NumericVehicle,
    TopologyError,
    check_value,
    mechanism_problem,
    validate_split,
)
from .kernels import load


@dataclass(frozen=True)
class ParameterInfo:
    """A named model parameter with its default value (a number or a tuple of numbers)."""

    name: str
    value: float | tuple[float, ...]
    unit: str = ""
    description: str = ""
    assumed: bool = False
    signed: bool = False


@dataclass(frozen=True)
class Uses:
    """The parameters an expression of the topology depends on (error messages name them)."""

    free_symbols: tuple[str, ...]


class VehicleTopology:
    """The plain data of a topology (names, defaults, units) and the validation of parameter sets,
    with the same keys and messages as ``svbi.codegen.topology.Topology.values``."""

    def __init__(self, module: types.ModuleType) -> None:
        data = module.DATA
        self._module = module
        self.name: str = data["name"]
        self.kind: str = data["kind"]
        self.description: str = data["description"]
        self.parameters = {p[0]: ParameterInfo(*p) for p in data["parameters"]}
        self.parameter_vector: tuple[str, ...] = data["parameter_vector"]
        self.roles: tuple[tuple[str, str, str, tuple[str, ...]], ...] = data.get("roles", ())
        bodies: dict[int, dict[str, Uses]] = {i: {} for i in range(len(data["body_names"]))}
        wheels: dict[int, dict[str, Uses]] = {i: {} for i in range(len(data["wheel_names"]))}
        for key, _, _, names in self.roles:
            group, index, role = key.replace("[", ".").replace("]", "").split(".")
            (bodies if group == "bodies" else wheels)[int(index)][role] = Uses(names)
        self.bodies = tuple(
            types.SimpleNamespace(name=n, **bodies[i]) for i, n in enumerate(data["body_names"])
        )
        self.wheels = tuple(
            types.SimpleNamespace(name=n, **wheels[i]) for i, n in enumerate(data["wheel_names"])
        )

    def defaults(self) -> dict[str, float | tuple[float, ...]]:
        """Default value of every parameter, by name."""
        return {name: p.value for name, p in self.parameters.items()}

    def vector(self, values: Mapping[str, Any]) -> np.ndarray:
        """The parameter vector of the generated kernels (scalar parameters, sorted by name)."""
        return np.array([float(values[n]) for n in self.parameter_vector], dtype=np.float64)

    def values(
        self, overrides: Mapping[str, Any] | None = None, where: str = "train.parameters"
    ) -> dict[str, float | tuple[float, ...]]:
        """Defaults with ``overrides`` applied, validated; errors name ``where.<parameter>``."""
        values = self.defaults()
        for name, raw in (overrides or {}).items():
            if name not in self.parameters:
                known = ", ".join(sorted(self.parameters))
                raise TopologyError(self.name, f"{where}.{name}", f"unknown parameter (known: {known})")
            param = self.parameters[name]
            values[name] = check_value(self.name, f"{where}.{name}", raw, param.signed, param.value)
        self._check_roles(values, where)
        return values

    def _check_roles(self, values: Mapping[str, Any], where: str) -> None:
        """Masses and inertias positive, wheel radii not negative (``topology._check_positive_roles``)."""
        if self.roles:
            evaluated = np.atleast_1d(self._module.roles(self.vector(values)))
            for (key, check, message, _), value in zip(self.roles, evaluated, strict=False):
                ok = value > 0 if check == "positive" else value >= 0
                if not ok:
                    raise TopologyError(where, key, message)
        if "car_length" in values and not float(values["car_length"]) > 0:
            raise TopologyError(where, "car_length", "must be positive")
        if self.kind == "moving-load":
            loads, offsets = values["axle_loads"], values["axle_offsets"]
            if not isinstance(loads, tuple) or not isinstance(offsets, tuple) or len(loads) != len(offsets):
                raise TopologyError(
                    where, "axle_loads", "axle_loads and axle_offsets must be lists of equal length"
                )


def _shaped(value: Any, shape: tuple[int, ...]) -> np.ndarray:
    """A kernel output as an array of ``shape`` (1x1 outputs come back as scalars)."""
    return np.asarray(value, dtype=np.float64).reshape(shape)


class GeneratedVehicle:
    """A vehicle type: its topology data and its matrices from the generated kernels."""

    def __init__(self, module: types.ModuleType) -> None:
        self.module = module
        self.topology = VehicleTopology(module)
        self.dof_names: tuple[str, ...] = module.DATA.get("dof_names", ())

    @property
    def name(self) -> str:
        return self.topology.name

    @property
    def kind(self) -> str:
        return self.topology.kind

    @property
    def has_dynamics(self) -> bool:
        return self.kind == "rigid-body" and bool(self.dof_names)

    def numeric(self, values: Mapping[str, Any] | None = None) -> NumericVehicle:
        """The vehicle at ``values`` (defaults filled in, validated), g = 9.81 m/s^2."""
        vals = self.topology.values(values)
        n, nw = len(self.dof_names), len(self.topology.wheels)
        data = self.module.DATA
        common = {
            "name": self.name,
            "kind": self.kind,
            "dof_names": self.dof_names,
            "car_length": float(vals["car_length"]),
            "carbody_z": data["carbody_z"],
            "carbody_theta": data["carbody_theta"],
            "axle_loads": np.array(vals.get("axle_loads", ()), dtype=float),
            "axle_offsets": np.array(vals.get("axle_offsets", ()), dtype=float),
        }
        if not self.has_dynamics:
            empty = np.zeros((0, 0))
            return NumericVehicle(
                M=empty,
                C=empty,
                K=empty,
                F_gravity=np.zeros(0),
                W_N=np.zeros((0, nw)),
                W_T=np.zeros((0, nw)),
                wheel_offsets=np.zeros(nw),
                wheel_masses=np.zeros(nw),
                wheel_radii=np.zeros(nw),
                **common,
            )
        m, p = self.module, self.topology.vector(vals)
        w_n, w_t = m.contact_directions(p)
        offsets, radii, masses = m.wheel_geometry(p)
        numeric = NumericVehicle(
            M=_shaped(m.mass_matrix(p), (n, n)),
            C=_shaped(m.damping_matrix(p), (n, n)),
            K=_shaped(m.stiffness_matrix(p), (n, n)),
            F_gravity=_shaped(m.gravity_load(p), (n,)),
            W_N=_shaped(w_n, (n, nw)),
            W_T=_shaped(w_t, (n, nw)),
            wheel_offsets=_shaped(offsets, (nw,)),
            wheel_masses=_shaped(masses, (nw,)),
            wheel_radii=_shaped(radii, (nw,)),
            **common,
        )
        # a mechanism has no static start (docs/design.md section 2): refuse it here, naming the bodies
        problem = mechanism_problem(numeric, tuple(w.name for w in self.topology.wheels))
        if problem:
            raise TopologyError(self.name, "bodies", problem)
        return numeric

    def constraint_masses(self, values: Mapping[str, Any] | None, split: float) -> np.ndarray:
        """Eq. (27): ``m_N^V`` of each wheel-aux constraint, with the active vehicle mass."""
        validate_split(split)
        p = self.topology.vector(self.topology.values(values))
        _, m_bar = self.module.vehicle_constraint(p, split)
        return _shaped(m_bar, (len(self.topology.wheels),))


def vehicle(name_or_path: str) -> GeneratedVehicle:
    """The vehicle of a built-in name or a topology file (generated once into the cache)."""
    return GeneratedVehicle(load(str(name_or_path)))
