"""3D vehicle topologies: the TOML format of :mod:`svbi.codegen.topology` with lateral motion.

A 3D topology file says ``dimensions = 3`` and keeps every rule of the 2D format (parameters with
value, unit, description, ``assumed``; expressions of parameters; unique names), with these keys
(docs/three-d.md)::

    dimensions = 3

    [[bodies]]
    name = "carbody"
    dofs = ["y", "z", "phi", "theta", "psi"]   # any non-empty subset, in any order
    mass = "carbody_mass"
    roll_inertia = "..."           # required with "phi"   (about the longitudinal axis)
    pitch_inertia = "..."          # required with "theta" (about the lateral axis)
    yaw_inertia = "..."            # required with "psi"   (about the vertical axis)
    position = "..."               # centre of mass, distance behind the car's leading axle
    height = "..."                 # centre of mass above the rail top

    [[suspensions]]                # three springs and three dashpots along x, y, z at one point
    name = "secondary_front"
    body_a = "carbody"             # upper body
    body_b = "bogie_front"
    position = "..."               # the point: distance behind the car's leading axle,
    lateral = "..."                # lateral coordinate (positive left),
    height = "..."                 # height above the rail top
    sides = 2                      # 2: a pair at +lateral and -lateral (named <name>_left/_right)
    stiffness = ["kx", "ky", "kz"] # per unit; damping likewise; either may be left out
    damping = ["cx", "cy", "cz"]

    [[rotational_springs]]         # a torsion spring between the rotations of two bodies
    name = "yaw_front"
    body_a = "carbody"
    body_b = "bogie_front"
    axis = "yaw"                   # "roll", "pitch" or "yaw"
    stiffness = "..."
    damping = "..."                # optional

    [[bump_stops]]                 # piecewise-linear stop, data only (not in the linear model)
    name = "lateral_front"
    body_a = "carbody"
    body_b = "bogie_front"
    direction = "y"
    displacements = "bump_stop_displacements"   # list parameters, same length, symmetric law
    forces = "bump_stop_forces"

    [[wheels]]                     # a contact point on the rail top
    name = "wheel_1_left"
    body = "wheelset_1"
    position = "0"
    lateral = "contact_half_gauge" # positive left
    radius = "wheel_radius"        # the body reference lies this far above the contact point

Axes: ``x`` forward (direction of travel), ``y`` left, ``z`` up (right-handed); positions are measured
*backwards* along the car, as in 2D, so a point at position ``p`` of a body whose reference is at
``p_b`` lies ``dx = -(p - p_b)`` ahead of it. Roll ``phi`` is a rotation about ``x`` (right hand:
positive lifts the left side), pitch ``theta`` lifts the front end (as in 2D: a rotation about
``-y``), yaw ``psi`` is a rotation about ``z`` (right hand: positive turns the nose left).
"""

from __future__ import annotations

import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import sympy as sp

from svbi.codegen.input_files import MAX_TOML_BYTES, InputFileError, TOMLNestingError, loads_toml, read_text
from svbi.codegen.plain_types import TopologyError, builtin_topologies_3d
from svbi.codegen.topology import (
    Parameter,
    only_keys,
    parse_expr,
    parse_parameters,
    require_name,
    require_str,
    table_list,
)

DOF_KINDS_3D = ("y", "z", "phi", "theta", "psi")
"""Body DOFs, in the order they take in the DOF vector: lateral, vertical, roll, pitch, yaw."""
INERTIA_KEYS = {"phi": "roll_inertia", "theta": "pitch_inertia", "psi": "yaw_inertia"}
AXES = {"roll": "phi", "pitch": "theta", "yaw": "psi"}
PACKAGE = "svbi.codegen.vehicles3d"
"""Where the built-in 3D topologies live (apart from the 2D ones, which runs can take)."""


@dataclass(frozen=True)
class Body3D:
    name: str
    dofs: tuple[str, ...]
    mass: sp.Expr
    inertias: dict[str, sp.Expr]
    """Inertia about the axis of each rotation DOF, keyed ``phi``, ``theta``, ``psi``."""
    position: sp.Expr
    height: sp.Expr


@dataclass(frozen=True)
class Suspension3D:
    name: str
    body_a: str
    body_b: str
    position: sp.Expr
    lateral: sp.Expr
    height: sp.Expr
    stiffness: tuple[sp.Expr, sp.Expr, sp.Expr]
    damping: tuple[sp.Expr, sp.Expr, sp.Expr]


@dataclass(frozen=True)
class RotationalSpring:
    name: str
    body_a: str
    body_b: str
    axis: str
    stiffness: sp.Expr
    damping: sp.Expr


@dataclass(frozen=True)
class BumpStop:
    """A piecewise-linear stop, force as a symmetric function of the relative displacement."""

    name: str
    body_a: str
    body_b: str
    direction: str
    displacements: str
    forces: str


@dataclass(frozen=True)
class Wheel3D:
    name: str
    body: str
    position: sp.Expr
    lateral: sp.Expr
    radius: sp.Expr


@dataclass(frozen=True)
class Topology3D:
    """A validated 3D vehicle topology."""

    name: str
    description: str
    source: str
    path: str
    parameters: dict[str, Parameter]
    bodies: tuple[Body3D, ...]
    suspensions: tuple[Suspension3D, ...]
    rotational_springs: tuple[RotationalSpring, ...]
    bump_stops: tuple[BumpStop, ...]
    wheels: tuple[Wheel3D, ...]
    text: str = field(default="", repr=False)

    def defaults(self) -> dict[str, float | tuple[float, ...]]:
        """Default value of every parameter, by name."""
        return {name: p.value for name, p in self.parameters.items()}

    @property
    def symbols(self) -> list[sp.Symbol]:
        """Scalar parameter symbols, sorted by name."""
        return [p.symbol for name, p in sorted(self.parameters.items()) if not isinstance(p.value, tuple)]

    def bump_stop_table(self, stop: BumpStop) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """The default ``(displacements, forces)`` of a bump stop."""
        d = self.parameters[stop.displacements].value
        f = self.parameters[stop.forces].value
        assert isinstance(d, tuple) and isinstance(f, tuple)
        return d, f


def load_topology3d(name_or_path: str | Path) -> Topology3D:
    """Load a built-in 3D topology by name, or a 3D topology file by path."""
    candidate = str(name_or_path)
    if candidate in builtin_topologies_3d():
        ref = resources.files(PACKAGE).joinpath(f"{candidate}.toml")
        return parse_topology3d(ref.read_text(encoding="utf-8"), f"<built-in {candidate}>")
    path = Path(candidate)
    if not os.path.lexists(path):
        known = ", ".join(builtin_topologies_3d())
        raise TopologyError(candidate, "vehicle", f"not a built-in 3D vehicle ({known}) and no such file")
    try:  # a regular file of bounded size: never /dev/zero, a FIFO or a folder
        text = read_text(path, MAX_TOML_BYTES)
    except InputFileError as exc:
        raise TopologyError(str(path), "file", exc.problem) from None
    return parse_topology3d(text, str(path))


_TOP_KEYS = {
    "name",
    "kind",
    "dimensions",
    "description",
    "source",
    "parameters",
    "bodies",
    "suspensions",
    "rotational_springs",
    "bump_stops",
    "wheels",
}


def parse_topology3d(text: str, source: str = "<string>") -> Topology3D:
    """Parse and validate the TOML text of a 3D topology."""
    try:
        data = loads_toml(text)
    except (tomllib.TOMLDecodeError, TOMLNestingError) as exc:
        raise TopologyError(source, "toml", f"malformed TOML: {exc}") from None
    only_keys(source, "", data, _TOP_KEYS)
    if data.get("dimensions") != 3:
        raise TopologyError(
            source, "dimensions", f"must be 3 for a 3D topology, got {data.get('dimensions')!r}"
        )
    if data.get("kind", "rigid-body") != "rigid-body":
        raise TopologyError(source, "kind", "a 3D topology is a rigid-body vehicle")
    name = require_str(source, "name", data.get("name"))
    params = parse_parameters(source, data.get("parameters"))
    symbols = {p.name: p.symbol for p in params.values()}

    def expr(key: str, raw: Any) -> sp.Expr:
        return parse_expr(source, key, raw, symbols, params)

    bodies = _parse_bodies(source, data, expr)
    body_names = [b.name for b in bodies]
    dof_names = {f"{k}{dot}_{b}" for b in body_names for k in DOF_KINDS_3D for dot in ("", "dot")}
    for pname in params:
        if pname in dof_names:
            raise TopologyError(
                source, f"parameters.{pname}", f"{pname!r} is the name of a DOF or velocity of a body"
            )

    def pair(key: str, raw: Mapping[str, Any], label: str) -> tuple[str, str]:
        a = require_str(source, f"{key}.body_a", raw.get("body_a"))
        b = require_str(source, f"{key}.body_b", raw.get("body_b"))
        for side, body in (("body_a", a), ("body_b", b)):
            if body not in body_names:
                raise TopologyError(source, f"{key}.{side}", f"unknown body {body!r}")
        if a == b:
            raise TopologyError(source, f"{key}.body_b", f"{label} joins body {a!r} to itself")
        return a, b

    suspensions: list[Suspension3D] = []
    names: set[str] = set()
    for i, raw in enumerate(table_list(source, "suspensions", data.get("suspensions", []))):
        key = f"suspensions[{i}]"
        allowed = {
            "name",
            "body_a",
            "body_b",
            "position",
            "lateral",
            "height",
            "sides",
            "stiffness",
            "damping",
        }
        only_keys(source, key, raw, allowed)
        sname = require_name(source, f"{key}.name", raw.get("name"))
        a, b = pair(key, raw, f"suspension {sname!r}")
        if "stiffness" not in raw and "damping" not in raw:
            raise TopologyError(source, key, f"suspension {sname!r} has neither stiffness nor damping")
        triples = {}
        for role in ("stiffness", "damping"):
            values = raw.get(role, ["0", "0", "0"])
            if not isinstance(values, list) or len(values) != 3:
                raise TopologyError(source, f"{key}.{role}", "must be a list of three expressions (x, y, z)")
            triples[role] = tuple(expr(f"{key}.{role}[{j}]", v) for j, v in enumerate(values))
        sides = raw.get("sides", 1)
        if sides not in (1, 2):
            raise TopologyError(source, f"{key}.sides", f"must be 1 or 2, got {sides!r}")
        lateral = expr(f"{key}.lateral", raw.get("lateral", "0"))
        points = (
            [(sname, lateral)] if sides == 1 else [(f"{sname}_left", lateral), (f"{sname}_right", -lateral)]
        )
        for unit, y in points:
            if unit in names:
                raise TopologyError(source, f"{key}.name", f"duplicate suspension name {unit!r}")
            names.add(unit)
            suspensions.append(
                Suspension3D(
                    unit,
                    a,
                    b,
                    expr(f"{key}.position", raw.get("position", "0")),
                    y,
                    expr(f"{key}.height", raw.get("height", "0")),
                    triples["stiffness"],  # type: ignore[arg-type]
                    triples["damping"],  # type: ignore[arg-type]
                )
            )

    rotational: list[RotationalSpring] = []
    for i, raw in enumerate(table_list(source, "rotational_springs", data.get("rotational_springs", []))):
        key = f"rotational_springs[{i}]"
        only_keys(source, key, raw, {"name", "body_a", "body_b", "axis", "stiffness", "damping"})
        rname = require_name(source, f"{key}.name", raw.get("name"))
        if any(r.name == rname for r in rotational):
            raise TopologyError(source, f"{key}.name", f"duplicate rotational spring name {rname!r}")
        a, b = pair(key, raw, f"rotational spring {rname!r}")
        axis = raw.get("axis")
        if axis not in AXES:
            raise TopologyError(source, f"{key}.axis", f"must be one of {tuple(AXES)}, got {axis!r}")
        if "stiffness" not in raw and "damping" not in raw:
            raise TopologyError(source, key, f"rotational spring {rname!r} has neither stiffness nor damping")
        rotational.append(
            RotationalSpring(
                rname,
                a,
                b,
                AXES[axis],
                expr(f"{key}.stiffness", raw.get("stiffness", "0")),
                expr(f"{key}.damping", raw.get("damping", "0")),
            )
        )

    stops: list[BumpStop] = []
    for i, raw in enumerate(table_list(source, "bump_stops", data.get("bump_stops", []))):
        key = f"bump_stops[{i}]"
        only_keys(source, key, raw, {"name", "body_a", "body_b", "direction", "displacements", "forces"})
        bname = require_name(source, f"{key}.name", raw.get("name"))
        if any(s.name == bname for s in stops):
            raise TopologyError(source, f"{key}.name", f"duplicate bump stop name {bname!r}")
        a, b = pair(key, raw, f"bump stop {bname!r}")
        direction = raw.get("direction")
        if direction not in ("x", "y", "z"):
            raise TopologyError(source, f"{key}.direction", f"must be 'x', 'y' or 'z', got {direction!r}")
        tables = []
        for role in ("displacements", "forces"):
            pname = require_str(source, f"{key}.{role}", raw.get(role))
            if pname not in params or not isinstance(params[pname].value, tuple):
                raise TopologyError(source, f"{key}.{role}", f"{pname!r} is not a list parameter")
            tables.append(params[pname].value)
        d, f = tables
        if len(d) != len(f) or len(d) < 2:
            raise TopologyError(source, key, "displacements and forces need the same length, at least 2")
        if any(d2 <= d1 for d1, d2 in zip(d, d[1:], strict=False)):
            raise TopologyError(source, f"{key}.displacements", "must increase strictly")
        if any(f2 < f1 for f1, f2 in zip(f, f[1:], strict=False)):
            raise TopologyError(source, f"{key}.forces", "must not decrease")
        stops.append(BumpStop(bname, a, b, direction, raw["displacements"], raw["forces"]))

    wheels: list[Wheel3D] = []
    for i, raw in enumerate(table_list(source, "wheels", data.get("wheels", []))):
        key = f"wheels[{i}]"
        only_keys(source, key, raw, {"name", "body", "position", "lateral", "radius"})
        wname = require_name(source, f"{key}.name", raw.get("name"))
        if any(w.name == wname for w in wheels):
            raise TopologyError(source, f"{key}.name", f"duplicate wheel name {wname!r}")
        body = require_str(source, f"{key}.body", raw.get("body"))
        if body not in body_names:
            raise TopologyError(source, f"{key}.body", f"unknown body {body!r}")
        wheels.append(
            Wheel3D(
                wname,
                body,
                expr(f"{key}.position", raw.get("position", "0")),
                expr(f"{key}.lateral", raw.get("lateral", "0")),
                expr(f"{key}.radius", raw.get("radius", "0")),
            )
        )
    if not wheels:
        raise TopologyError(source, "wheels", "a rigid-body vehicle needs at least one wheel")
    if "car_length" not in params:
        raise TopologyError(source, "parameters.car_length", "missing (needed to couple cars into trains)")
    topo = Topology3D(
        name,
        str(data.get("description", "")),
        str(data.get("source", "")),
        source,
        params,
        tuple(bodies),
        tuple(suspensions),
        tuple(rotational),
        tuple(stops),
        tuple(wheels),
        text,
    )
    _check_positive(topo)
    return topo


def _parse_bodies(source: str, data: Mapping[str, Any], expr: Any) -> list[Body3D]:
    bodies: list[Body3D] = []
    allowed = {"name", "dofs", "mass", "position", "height", *INERTIA_KEYS.values()}
    for i, raw in enumerate(table_list(source, "bodies", data.get("bodies", []))):
        key = f"bodies[{i}]"
        only_keys(source, key, raw, allowed)
        bname = require_name(source, f"{key}.name", raw.get("name"))
        if any(b.name == bname for b in bodies):
            raise TopologyError(source, f"{key}.name", f"duplicate body name {bname!r}")
        dofs = raw.get("dofs")
        if not isinstance(dofs, list) or not dofs or any(d not in DOF_KINDS_3D for d in dofs):
            raise TopologyError(source, f"{key}.dofs", f"must be a non-empty list of {DOF_KINDS_3D}")
        if len(set(dofs)) != len(dofs):
            raise TopologyError(source, f"{key}.dofs", "repeated DOF")
        if "mass" not in raw:
            raise TopologyError(source, f"{key}.mass", f"body {bname!r} has no mass")
        inertias = {}
        for dof, ikey in INERTIA_KEYS.items():
            if dof in dofs:
                if ikey not in raw:
                    raise TopologyError(
                        source, f"{key}.{ikey}", f"body {bname!r} has DOF {dof!r} but no {ikey}"
                    )
                inertias[dof] = expr(f"{key}.{ikey}", raw[ikey])
        bodies.append(
            Body3D(
                bname,
                tuple(d for d in DOF_KINDS_3D if d in dofs),
                expr(f"{key}.mass", raw["mass"]),
                inertias,
                expr(f"{key}.position", raw.get("position", "0")),
                expr(f"{key}.height", raw.get("height", "0")),
            )
        )
    if not bodies:
        raise TopologyError(source, "bodies", "a rigid-body vehicle needs at least one body")
    return bodies


def _check_positive(topo: Topology3D) -> None:
    subs = {p.symbol: p.value for p in topo.parameters.values() if not isinstance(p.value, tuple)}
    for i, body in enumerate(topo.bodies):
        roles = [("mass", body.mass), *((INERTIA_KEYS[d], e) for d, e in body.inertias.items())]
        for role, e in roles:
            if not float(e.subs(subs)) > 0:
                raise TopologyError(
                    topo.path, f"bodies[{i}].{role}", f"{role} of body {body.name!r} must be positive"
                )
    for i, wheel in enumerate(topo.wheels):
        if float(wheel.radius.subs(subs)) < 0:
            raise TopologyError(topo.path, f"wheels[{i}].radius", "radius must not be negative")
