"""Declarative vehicle topologies: TOML files with bodies, suspensions, wheels and parameters.

A topology describes *mechanics*, not numbers: every mass, stiffness or length is a named parameter
(a SymPy symbol downstream), with a default value, a unit and a source. The built-in topologies ship
as TOML files in ``svbi/codegen/vehicles/``; a user's own file goes through exactly the same loader.

Format (see ``vehicles/pioneer-2d.toml`` for a complete example)::

    name = "two-axle-wagon"
    kind = "rigid-body"            # or "moving-load"
    description = "..."
    source = "..."

    [parameters.body_mass]         # one table per parameter
    value = 20000.0
    unit = "kg"
    description = "..."
    assumed = false                # true when the source gives no value

    [[bodies]]                     # the first body is the car body (reported in the results)
    name = "carbody"
    dofs = ["z", "theta"]          # vertical translation (up) and pitch (front end up)
    mass = "body_mass"             # an expression of parameters
    inertia = "body_pitch_inertia" # required with a "theta" DOF
    position = "axle_spacing / 2"  # reference point, distance behind the car's leading axle

    [[suspensions]]                # a vertical spring and a dashpot in parallel
    name = "front"
    body_a = "carbody"             # upper body
    offset_a = "-axle_spacing / 2" # attachment point relative to the body reference, + backwards
    body_b = "axle_1"
    offset_b = "0"
    stiffness = "k"
    damping = "c"

    [[wheels]]
    name = "wheel_1"
    body = "axle_1"
    position = "0"                 # distance behind the car's leading axle
    radius = "wheel_radius"        # optional; the contact point lies this far below the body

Names of bodies, suspensions and wheels are unique within their kind; parameter names must not be
one of the reserved symbols of the derivation (``a A E g h I le mu t v xi``) nor the name of a DOF
(``z_<body>``, ``theta_<body>``, and ``zdot_``, ``thetadot_`` for velocities). With the wheels held on
rigid track every body must be restrained, except wheel spins (``plain_types.mechanism_problem``);
a wheel on a body without ``theta`` sits at the body's reference point.

Positions are measured *backwards* from the car's leading axle. A point at position ``p`` of a body
with reference position ``p_b`` moves vertically by ``z - (p - p_b) * theta``: with pitch positive when
the front end rises, points ahead of the reference (smaller ``p``) go up.
"""

from __future__ import annotations

import os
import re
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import sympy as sp

from svbi.codegen.input_files import MAX_TOML_BYTES, InputFileError, TOMLNestingError, loads_toml, read_text
from svbi.codegen.plain_types import TopologyError, builtin_topologies, check_value

DOF_KINDS = ("z", "theta")
KINDS = ("rigid-body", "moving-load")
_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
_RESERVED = {"g", "t", "xi", "le", "E", "A", "I", "mu", "h", "v", "a"}
"""Symbols of the derivation (gravity, time, element coordinate and length, section properties, rail
height, speed, aux-point split): a parameter of the same name would be confused with them."""


@dataclass(frozen=True)
class Parameter:
    """A named model parameter with its default value (a number or a list of numbers)."""

    name: str
    value: float | tuple[float, ...]
    unit: str = ""
    description: str = ""
    assumed: bool = False
    signed: bool = False

    @property
    def symbol(self) -> sp.Symbol:
        return sp.Symbol(self.name, real=True) if self.signed else sp.Symbol(self.name, nonnegative=True)


@dataclass(frozen=True)
class Body:
    name: str
    dofs: tuple[str, ...]
    mass: sp.Expr
    inertia: sp.Expr | None
    position: sp.Expr


@dataclass(frozen=True)
class Suspension:
    name: str
    body_a: str
    offset_a: sp.Expr
    body_b: str
    offset_b: sp.Expr
    stiffness: sp.Expr
    damping: sp.Expr


@dataclass(frozen=True)
class Wheel:
    name: str
    body: str
    position: sp.Expr
    radius: sp.Expr


@dataclass(frozen=True)
class Topology:
    """A validated vehicle topology. Expressions are SymPy expressions of the parameter symbols."""

    name: str
    kind: str
    description: str
    source: str
    path: str
    parameters: dict[str, Parameter]
    bodies: tuple[Body, ...] = ()
    suspensions: tuple[Suspension, ...] = ()
    wheels: tuple[Wheel, ...] = ()
    text: str = field(default="", repr=False)

    def defaults(self) -> dict[str, float | tuple[float, ...]]:
        """Default value of every parameter, by name."""
        return {name: p.value for name, p in self.parameters.items()}

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
        _check_positive_roles(self, values, where)
        return values

    @property
    def symbols(self) -> list[sp.Symbol]:
        """Scalar parameter symbols, sorted by name (the order of kernel parameter vectors)."""
        return [p.symbol for name, p in sorted(self.parameters.items()) if not isinstance(p.value, tuple)]


def load_topology(name_or_path: str | Path) -> Topology:
    """Load a built-in topology by name, or a user's topology file by path."""
    text: str
    source: str
    candidate = str(name_or_path)
    if candidate in builtin_topologies():
        ref = resources.files("svbi.codegen.vehicles").joinpath(f"{candidate}.toml")
        text, source = ref.read_text(encoding="utf-8"), f"<built-in {candidate}>"
    else:
        path = Path(candidate)
        if not os.path.lexists(path):
            known = ", ".join(builtin_topologies())
            raise TopologyError(candidate, "vehicle", f"not a built-in vehicle ({known}) and no such file")
        try:  # a regular file of bounded size: never /dev/zero, a FIFO or a folder
            text, source = read_text(path, MAX_TOML_BYTES), str(path)
        except InputFileError as exc:
            raise TopologyError(str(path), "file", exc.problem) from None
    return parse_topology(text, source)


def parse_topology(text: str, source: str = "<string>") -> Topology:
    """Parse and validate the TOML text of a topology."""
    try:
        data = loads_toml(text)
    except (tomllib.TOMLDecodeError, TOMLNestingError) as exc:
        raise TopologyError(source, "toml", f"malformed TOML: {exc}") from None
    dimensions = data.get("dimensions", 2) if isinstance(data, dict) else 2
    if dimensions == 3 and not isinstance(dimensions, bool):
        raise TopologyError(
            source,
            "dimensions",
            "a 3D topology (svbi.codegen.topology3d, docs/three-d.md): this loader takes 2D topologies; "
            "a scenario runs it as its train.vehicle",
        )
    if dimensions != 2 or isinstance(dimensions, bool):
        raise TopologyError(source, "dimensions", f"must be 2 or 3 (got {dimensions!r})")
    data.pop("dimensions", None)
    _only_keys(
        source,
        "",
        data,
        {"name", "kind", "description", "source", "parameters", "bodies", "suspensions", "wheels"},
    )
    name = _require_str(source, "name", data.get("name"))
    kind = data.get("kind", "rigid-body")
    if kind not in KINDS:
        raise TopologyError(source, "kind", f"must be one of {KINDS}, got {kind!r}")

    params = _parse_parameters(source, data.get("parameters"))
    symbols = {p.name: p.symbol for p in params.values()}

    def expr(key: str, raw: Any) -> sp.Expr:
        return _parse_expr(source, key, raw, symbols, params)

    bodies: list[Body] = []
    for i, raw in enumerate(_table_list(source, "bodies", data.get("bodies", []))):
        key = f"bodies[{i}]"
        _only_keys(source, key, raw, {"name", "dofs", "mass", "inertia", "position"})
        bname = _require_name(source, f"{key}.name", raw.get("name"))
        if any(b.name == bname for b in bodies):
            raise TopologyError(source, f"{key}.name", f"duplicate body name {bname!r}")
        dofs = raw.get("dofs")
        if not isinstance(dofs, list) or not dofs or any(d not in DOF_KINDS for d in dofs):
            raise TopologyError(source, f"{key}.dofs", f"must be a non-empty list of {DOF_KINDS}")
        if len(set(dofs)) != len(dofs):
            raise TopologyError(source, f"{key}.dofs", "repeated DOF")
        if "mass" not in raw:
            raise TopologyError(source, f"{key}.mass", f"body {bname!r} has no mass")
        inertia = None
        if "theta" in dofs:
            if "inertia" not in raw:
                raise TopologyError(source, f"{key}.inertia", f"body {bname!r} rotates but has no inertia")
            inertia = expr(f"{key}.inertia", raw["inertia"])
        bodies.append(
            Body(
                bname,
                tuple(d for d in DOF_KINDS if d in dofs),
                expr(f"{key}.mass", raw["mass"]),
                inertia,
                expr(f"{key}.position", raw.get("position", "0")),
            )
        )
    body_names = {b.name for b in bodies}
    dof_names = {f"{kind}_{b.name}" for b in bodies for kind in ("z", "theta", "zdot", "thetadot")}
    for pname in params:
        if pname in dof_names:
            # the derivation names DOFs and velocities so: the printed matrices would be ambiguous
            raise TopologyError(
                source, f"parameters.{pname}", f"{pname!r} is the name of a DOF or velocity of a body"
            )

    suspensions: list[Suspension] = []
    for i, raw in enumerate(_table_list(source, "suspensions", data.get("suspensions", []))):
        key = f"suspensions[{i}]"
        _only_keys(
            source, key, raw, {"name", "body_a", "offset_a", "body_b", "offset_b", "stiffness", "damping"}
        )
        sname = _require_name(source, f"{key}.name", raw.get("name"))
        if any(x.name == sname for x in suspensions):
            raise TopologyError(source, f"{key}.name", f"duplicate suspension name {sname!r}")
        a = _require_str(source, f"{key}.body_a", raw.get("body_a"))
        b = _require_str(source, f"{key}.body_b", raw.get("body_b"))
        for side, body in (("body_a", a), ("body_b", b)):
            if body not in body_names:
                raise TopologyError(source, f"{key}.{side}", f"unknown body {body!r}")
        if a == b:
            raise TopologyError(source, f"{key}.body_b", f"suspension {sname!r} joins body {a!r} to itself")
        if "stiffness" not in raw and "damping" not in raw:
            raise TopologyError(source, key, f"suspension {sname!r} has neither stiffness nor damping")
        suspensions.append(
            Suspension(
                sname,
                a,
                expr(f"{key}.offset_a", raw.get("offset_a", "0")),
                b,
                expr(f"{key}.offset_b", raw.get("offset_b", "0")),
                expr(f"{key}.stiffness", raw.get("stiffness", "0")),
                expr(f"{key}.damping", raw.get("damping", "0")),
            )
        )

    wheels: list[Wheel] = []
    for i, raw in enumerate(_table_list(source, "wheels", data.get("wheels", []))):
        key = f"wheels[{i}]"
        _only_keys(source, key, raw, {"name", "body", "position", "radius"})
        wname = _require_name(source, f"{key}.name", raw.get("name"))
        if any(x.name == wname for x in wheels):
            raise TopologyError(source, f"{key}.name", f"duplicate wheel name {wname!r}")
        body = _require_str(source, f"{key}.body", raw.get("body"))
        if body not in body_names:
            raise TopologyError(source, f"{key}.body", f"unknown body {body!r}")
        if "z" not in next(b for b in bodies if b.name == body).dofs:
            raise TopologyError(source, f"{key}.body", f"wheel body {body!r} needs a 'z' DOF")
        wheel = Wheel(
            wname,
            body,
            expr(f"{key}.position", raw.get("position", "0")),
            expr(f"{key}.radius", raw.get("radius", "0")),
        )
        owner = next(b for b in bodies if b.name == body)
        if "theta" not in owner.dofs and sp.simplify(wheel.position - owner.position) != 0:
            # without a rotation the body cannot carry a contact point away from its reference
            raise TopologyError(
                source,
                f"{key}.position",
                f"wheel {wname!r} at {wheel.position} differs from the reference point of body {body!r} "
                f"({owner.position}), which has no 'theta' DOF",
            )
        wheels.append(wheel)

    if kind == "rigid-body":
        if not bodies:
            raise TopologyError(source, "bodies", "a rigid-body vehicle needs at least one body")
        if not wheels:
            raise TopologyError(source, "wheels", "a rigid-body vehicle needs at least one wheel")
        if "car_length" not in params:
            raise TopologyError(
                source, "parameters.car_length", "missing (needed to couple cars into trains)"
            )
    else:
        if bodies or suspensions or wheels:
            raise TopologyError(source, "kind", "a moving-load vehicle has no bodies, suspensions or wheels")
        for needed in ("axle_loads", "axle_offsets", "car_length"):
            if needed not in params:
                raise TopologyError(source, f"parameters.{needed}", "missing for a moving-load vehicle")
    topo = Topology(
        name,
        kind,
        str(data.get("description", "")),
        str(data.get("source", "")),
        source,
        params,
        tuple(bodies),
        tuple(suspensions),
        tuple(wheels),
        text,
    )
    _check_positive_roles(topo, topo.defaults(), source)
    return topo


# --------------------------------------------------------------------------------------------------
# validation helpers


def _only_keys(source: str, key: str, raw: Any, allowed: set[str]) -> None:
    if not isinstance(raw, dict):
        raise TopologyError(source, key or "<root>", "must be a table")
    for k in raw:
        if k not in allowed:
            where = f"{key}.{k}" if key else k
            raise TopologyError(source, where, f"unknown key (allowed: {', '.join(sorted(allowed))})")


def _require_str(source: str, key: str, raw: Any) -> str:
    if not isinstance(raw, str) or not raw:
        raise TopologyError(source, key, "missing or not a string")
    return raw


def _require_name(source: str, key: str, raw: Any) -> str:
    name = _require_str(source, key, raw)
    if not _NAME.match(name):
        raise TopologyError(source, key, f"{name!r} is not a valid name (letters, digits, _)")
    return name


def _table_list(source: str, key: str, raw: Any) -> list[dict[str, Any]]:
    if not isinstance(raw, list):
        raise TopologyError(source, key, "must be an array of tables ([[...]])")
    return raw


def _parse_parameters(source: str, raw: Any) -> dict[str, Parameter]:
    if not isinstance(raw, dict) or not raw:
        raise TopologyError(source, "parameters", "missing or empty")
    params: dict[str, Parameter] = {}
    for name, spec in raw.items():
        key = f"parameters.{name}"
        if not _NAME.match(name):
            raise TopologyError(source, key, f"{name!r} is not a valid name (letters, digits, _)")
        if name in _RESERVED:
            reserved = " ".join(sorted(_RESERVED, key=lambda n: (n.lower(), n.isupper())))
            raise TopologyError(source, key, f"{name!r} is a reserved name (reserved: {reserved})")
        _only_keys(source, key, spec, {"value", "unit", "description", "assumed", "signed", "source"})
        if "value" not in spec:
            raise TopologyError(source, f"{key}.value", "missing")
        signed = bool(spec.get("signed", False))
        value = check_value(source, f"{key}.value", spec["value"], signed, None)
        params[name] = Parameter(
            name,
            value,
            str(spec.get("unit", "")),
            str(spec.get("description", "")),
            bool(spec.get("assumed", False)),
            signed,
        )
    return params


_NUMBER = re.compile(r"(?<![A-Za-z0-9_.])(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")
"""A number literal, in plain or scientific notation, that is not part of a name (``k1e5``)."""
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def _parse_expr(
    source: str, key: str, raw: Any, symbols: dict[str, sp.Symbol], params: dict[str, Parameter]
) -> sp.Expr:
    if isinstance(raw, bool) or not isinstance(raw, str | int | float):
        raise TopologyError(source, key, f"must be an expression string or a number, got {raw!r}")
    if isinstance(raw, int | float):
        return sp.nsimplify(raw)
    names = set(_NAME.findall(_NUMBER.sub(" ", raw)))  # 1.0e6 is a number, not 1.0 and a name e6
    unknown = sorted(n for n in names if n not in symbols)
    if unknown:
        raise TopologyError(source, key, f"unknown parameter(s) {', '.join(unknown)} in {raw!r}")
    listy = sorted(n for n in names if isinstance(params[n].value, tuple))
    if listy:
        raise TopologyError(source, key, f"list parameter(s) {', '.join(listy)} cannot enter an expression")
    try:
        return sp.sympify(raw, locals=symbols, rational=True)
    except (sp.SympifyError, SyntaxError, TypeError):  # SymPy's message: lines of its parser's internals
        raise TopologyError(
            source, key, f"cannot parse expression {raw!r}: not an arithmetic expression of the parameters"
        ) from None


def _check_positive_roles(topo: Topology, values: Mapping[str, Any], where: str) -> None:
    """Masses and inertias must evaluate to positive numbers, positions of wheels must be ordered."""
    subs = {p.symbol: values[n] for n, p in topo.parameters.items() if not isinstance(values[n], tuple)}
    for i, body in enumerate(topo.bodies):
        for role, e in (("mass", body.mass), ("inertia", body.inertia)):
            if e is not None and not float(e.subs(subs)) > 0:
                raise TopologyError(
                    where, f"bodies[{i}].{role}", f"{role} of body {body.name!r} must be positive"
                )
    for i, wheel in enumerate(topo.wheels):
        if float(wheel.radius.subs(subs)) < 0:
            raise TopologyError(where, f"wheels[{i}].radius", "radius must not be negative")
    if "car_length" in values and not float(values["car_length"]) > 0:
        raise TopologyError(where, "car_length", "must be positive")
    if topo.kind == "moving-load":
        loads, offsets = values["axle_loads"], values["axle_offsets"]
        if not isinstance(loads, tuple) or not isinstance(offsets, tuple) or len(loads) != len(offsets):
            raise TopologyError(
                where, "axle_loads", "axle_loads and axle_offsets must be lists of equal length"
            )


# The validation helpers that the 3D format (``svbi.codegen.topology3d``) shares with this one.
only_keys = _only_keys
require_str = _require_str
require_name = _require_name
table_list = _table_list
parse_parameters = _parse_parameters
parse_expr = _parse_expr
