"""Scenario files: the TOML contract of docs/scenario.md, validated with pydantic.

``load_scenario(path)`` reads a file, applies ``--set``-style overrides, validates every key and
returns a :class:`Scenario` with the defaults filled in. Unknown keys are errors. Every problem is
reported with the dotted path of the offending key and the file and line where it was written, all
problems at once::

    bad.toml:7: bridge.span_length: must be greater than 0 (got -32.0)

A time step too coarse for the vehicle is a :class:`ScenarioWarning`, not an error.
"""

from __future__ import annotations

import copy
import math
import os
import re
import tomllib
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import tomli_w
from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, ValidationError, model_validator

from ...codegen.input_files import (
    MAX_DATA_BYTES,
    MAX_TOML_BYTES,
    InputFileError,
    TextFileError,
    TOMLNestingError,
    decode_text,
    file_problem,
    loads_toml,
    read_bytes,
    toml_key_lines,
)
from ...codegen.plain_types import TopologyError
from ..excitation.irregularity import read_profile_cached
from ..model.bridge import Girder, Pier, Section
from ..model.modes import vehicle_modes
from ..model.train import topology, vehicle_model
from .kinds import vehicle_dimensions, wrong_kind
from .limits import creep_warnings, girder_problems, size_problems, vehicle_ref
from .plausibility import plausibility_warnings

METHODS = ("localized-dynamic", "coupled-dynamic", "coupled-classic")
BACKENDS = ("numpy", "casadi", "c")
IRREGULARITIES = ("none", "german-low", "german-high")
HSLM_TRAINS = tuple(f"A{i}" for i in range(1, 11))
KMH = 1.0 / 3.6

CONICITY_DEFAULT = 0.1
"""``contact.conicity`` of a 3D scenario whose vehicle carries no ``conicity`` parameter: within the
usual equivalent conicities of new wheel profiles on their rails (0.05 … 0.15)."""
FLANGE_CLEARANCE_DEFAULT = 0.005
"""``contact.flange_clearance`` (m) of a 3D scenario whose vehicle carries no ``flange_clearance``
parameter: half the play of a new wheelset in standard-gauge track, (1435 − (1360 + 2 × 32.5)) / 2 mm
(track gauge, back-to-back distance, flange thickness)."""

TIME_STEP_RESOLUTION = 20
"""Steps per period of the fastest vehicle mode below which a warning is given. Newmark's average
acceleration lengthens a period by about (omega dt)^2 / 12: at 20 steps per period that is 0.8 %."""


class ScenarioWarning(UserWarning):
    """A scenario that runs but whose results may be inaccurate (e.g. a coarse time step)."""


@dataclass(frozen=True)
class Problem:
    """One invalid key: its dotted path, what is wrong, and where it was written."""

    key: str
    message: str
    where: str = ""

    def __str__(self) -> str:
        parts = [self.where, self.key, self.message]
        return ": ".join(p for p in parts if p)


class ScenarioError(ValueError):
    """A scenario file (or override) is invalid. ``problems`` lists every offending key."""

    def __init__(self, problems: Sequence[Problem], source: str = "") -> None:
        self.problems = list(problems)
        self.source = source
        head = f"invalid scenario {source}" if source else "invalid scenario"
        super().__init__(head + ":\n" + "\n".join(f"  {p}" for p in self.problems))


# --------------------------------------------------------------------------------------------------
# schema

Positive = Annotated[float, Field(gt=0)]
NonNegative = Annotated[float, Field(ge=0)]


class _Table(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False, validate_default=True)


_SECTION_FIELDS = ("mass_per_length", "youngs_modulus", "area", "second_moment", "damping_ratio")
"""The section keys a girder or pier may give for itself (``[bridge]``'s otherwise)."""

SECTION_3D_FIELDS = (
    "lateral_second_moment",
    "torsion_constant",
    "poisson_ratio",
    "shear_modulus",
    "torsional_mass_per_length",
)
"""The section keys of a 3D scenario (docs/scenario.md, "3D scenarios"): ``[bridge]``, each girder
(``[bridge]``'s otherwise) and each pier."""

Poisson = Annotated[float, Field(ge=0, lt=0.5)]


class GirderSpec(_Table):
    """``[[bridge.girders]]``: one deck in the direction of travel, continuous over its interior
    supports. Section keys left out take the ``[bridge]`` defaults."""

    spans: Annotated[list[Positive], Field(min_length=1)]
    """Span lengths (m) in the direction of travel; one entry is a simply supported span."""
    fixed_support: Annotated[int, Field(ge=0)] = 0
    """Which of the girder's support lines (0 = its first) carries the fixed bearing."""
    mass_per_length: Positive | None = None
    youngs_modulus: Positive | None = None
    area: Positive | None = None
    second_moment: Positive | None = None
    damping_ratio: Annotated[float, Field(ge=0, lt=1)] | None = None
    elements_per_span: Annotated[int, Field(ge=1)] | None = None
    lateral_second_moment: Positive | None = None
    torsion_constant: Positive | None = None
    poisson_ratio: Poisson | None = None
    shear_modulus: Positive | None = None
    torsional_mass_per_length: Positive | None = None


class PierSpec(_Table):
    """``[[bridge.piers]]``: a pier column under one support line, fixed at its base, carrying the
    girders' bearings on that line at its top (rigid, or springs of the given stiffness)."""

    support: Annotated[int, Field(ge=0)]
    height: Positive
    mass_per_length: Positive
    youngs_modulus: Positive
    area: Positive
    second_moment: Positive
    damping_ratio: Annotated[float, Field(ge=0, lt=1)] | None = None
    """Rayleigh damping on the pier's first two sway modes; default ``[bridge] damping_ratio``."""
    bearing_stiffness_vertical: Positive | None = None
    bearing_stiffness_longitudinal: Positive | None = None
    bearing_stiffness_lateral: Positive | None = None
    """3D: the bearings' lateral springs (N/m); rigid when left out."""
    lateral_second_moment: Positive | None = None
    """3D: the second moment (m^4) for the pier's sway across the track; default ``second_moment``
    (which is the one for its sway along the track)."""
    torsion_constant: Positive | None = None
    """3D: St-Venant constant (m^4) of the pier's twist about its axis; default the polar moment
    ``second_moment + lateral_second_moment`` (exact for a circular section)."""
    poisson_ratio: Poisson | None = None
    shear_modulus: Positive | None = None
    torsional_mass_per_length: Positive | None = None


class BridgeSpec(_Table):
    """``[bridge]``: the section defaults and either the shorthand ``spans`` x ``span_length`` (a chain
    of identical simply supported spans) or the long form ``[[bridge.girders]]``."""

    spans: Annotated[int, Field(ge=1)] = 1
    span_length: Positive | None = None
    mass_per_length: Positive
    youngs_modulus: Positive
    area: Positive
    second_moment: Positive
    damping_ratio: Annotated[float, Field(ge=0, lt=1)] = 0.02
    elements_per_span: Annotated[int, Field(ge=1)] = 16
    rail_height: float = 0.0
    """The rail top above the deck's axis (m): its neutral axis in 2D, its shear centre in 3D."""
    track_form: Literal["ballasted", "direct"] = "ballasted"
    """EN 1990 A2.4.4.2.1 deck acceleration limit of ``svbi check``: 3.5 m/s² ballasted, 5 m/s² direct."""
    girders: list[GirderSpec] | None = None
    piers: list[PierSpec] | None = None
    lateral_second_moment: Positive | None = None
    """3D: second moment for lateral bending I_zz (m^4); required in a 3D scenario."""
    torsion_constant: Positive | None = None
    """3D: St-Venant torsion constant J (m^4); required in a 3D scenario."""
    poisson_ratio: Poisson | None = None
    """3D: Poisson's ratio of the shear modulus ``E / (2 (1 + nu))``; default 0.2."""
    shear_modulus: Positive | None = None
    """3D: the shear modulus G (Pa), in place of ``poisson_ratio``."""
    torsional_mass_per_length: Positive | None = None
    """3D: torsional mass moment of inertia per length (kg m); default ``mass_per_length (I_y +
    I_z) / A`` (docs/three-d.md)."""
    track_eccentricity: float | None = None
    """3D: lateral offset of the track centreline from the deck's shear centre (m, positive left);
    default 0."""

    @model_validator(mode="after")
    def _one_form(self) -> BridgeSpec:
        if self.girders is None:
            if self.span_length is None:
                raise ValueError("@bridge.span_length: required key is missing (or give [[bridge.girders]])")
            return self
        both = sorted({"spans", "span_length"} & self.model_fields_set)
        if both:
            raise ValueError(
                f"@bridge.{both[0]}: the shorthand cannot be combined with the long form [[bridge.girders]]"
            )
        self.spans = sum(len(g.spans) for g in self.girders)
        self.span_length = self.girders[0].spans[0]
        return self

    def long_form_problems(self) -> list[tuple[str, str]]:
        """(key, message) for each long-form input the mechanics cannot build: every span has
        ``elements_per_span`` elements (no per-girder override), one pier per support line inside
        the bridge, a fixed bearing on one of the girder's lines. Refused, never approximated."""
        out: list[tuple[str, str]] = []
        lines = self.spans + 1
        seen: dict[int, int] = {}
        for i, p in enumerate(self.piers or []):
            key = f"bridge.piers[{i}]"
            if p.support >= lines:
                out.append((f"{key}.support", f"support line {p.support} is not one of 0..{lines - 1}"))
            if p.support in seen:
                out.append((f"{key}.support", f"support line {p.support} already has pier {seen[p.support]}"))
            seen.setdefault(p.support, i)
        for i, g in enumerate(self.girders or []):
            key = f"bridge.girders[{i}]"
            if g.fixed_support > len(g.spans):
                out.append(
                    (
                        f"{key}.fixed_support",
                        f"{g.fixed_support} is not one of the girder's lines 0..{len(g.spans)}",
                    )
                )
            if g.elements_per_span is not None and g.elements_per_span != self.elements_per_span:
                out.append(
                    (
                        f"{key}.elements_per_span",
                        "every span has [bridge] elements_per_span elements; no per-girder value",
                    )
                )
        return out

    def layout(self) -> tuple[list[Any], list[Any]]:
        """The runtime's girders and piers (``svbi.runtime.model.bridge``) of the long form."""

        def section(g: Any) -> Section:
            def pick(name: str) -> float:
                value = getattr(g, name, None)
                return float(getattr(self, name) if value is None else value)

            return Section(*(pick(n) for n in _SECTION_FIELDS))

        girders = [
            Girder(tuple(float(x) for x in g.spans), section(g), g.fixed_support) for g in self.girders or []
        ]
        piers = [
            Pier(
                p.support,
                float(p.height),
                section(p),
                p.bearing_stiffness_vertical,
                p.bearing_stiffness_longitudinal,
            )
            for p in self.piers or []
        ]
        return girders, piers

    def line_positions(self) -> list[float]:
        """Position (m) of every support line: 0, then the end of each span."""
        lengths = (
            [x for g in self.girders for x in g.spans] if self.girders else [self.span_length] * self.spans
        )
        out = [0.0]
        for x in lengths:
            out.append(out[-1] + float(x))
        return out


class TrainSpec(_Table):
    """``[train]``: vehicle type, number of cars, speed and start position."""

    vehicle: Annotated[str, Field(min_length=1)] = "pioneer-2d"
    cars: Annotated[int, Field(ge=1)] = 1
    speed_kmh: NonNegative | None = None
    speed: NonNegative | None = None
    """0 is a train standing still (on the bridge or the approach) and needs ``solver.duration``."""
    start_position: float = 0.0
    acceleration: float = 0.0
    """m/s^2 along the track (negative: braking); the speed is ``v0 + a t``, and a braking train
    stops and then stands."""
    hslm: Literal[HSLM_TRAINS] | None = None  # type: ignore[valid-type]
    parameters: dict[str, float | list[float]] = Field(default_factory=dict)
    initial: Literal["auto", "static", "rigid-track"] = "auto"
    """The state at t = 0: "static" the whole train-bridge system in static equilibrium (the train
    resting on the deflected bridge), "rigid-track" the cars at rest on rigid level track and the
    bridge unloaded; "auto" is "static" when a wheel stands on the bridge at t = 0, else
    "rigid-track" (docs/scenario.md)."""

    @model_validator(mode="after")
    def _speed_given_once(self) -> TrainSpec:
        if (self.speed is None) == (self.speed_kmh is None):
            which = "both" if self.speed is not None else "neither"
            raise ValueError(f"give exactly one of train.speed (m/s) and train.speed_kmh ({which} given)")
        return self

    @property
    def speed_ms(self) -> float:
        """Speed in m/s, whichever key gave it."""
        return float(self.speed) if self.speed is not None else float(self.speed_kmh) * KMH


class TrackSpec(_Table):
    """``[track]``: rail irregularity: a built-in spectrum, or a measured profile file (x, r columns)."""

    irregularity: Annotated[str, Field(min_length=1)] = "none"
    seed: Annotated[int, Field(ge=0)] = 1
    wavelength_min: Positive = 0.5
    wavelength_max: Positive = 80.0

    @property
    def is_profile(self) -> bool:
        """A measured profile (a file path) rather than one of :data:`IRREGULARITIES`."""
        return self.irregularity not in IRREGULARITIES


RecordName = Annotated[str, Field(min_length=1)]


class EarthquakeSpec(_Table):
    """``[earthquake]``: ground motion at the supports and under the approach track.

    A component is ``"none"``, ``"synthetic"``, a record path, or a list of those with one entry per
    support line (abutments and piers, ``bridge.spans + 1`` entries in the direction of travel).
    """

    vertical: RecordName | list[RecordName] = "none"
    longitudinal: RecordName | list[RecordName] = "none"
    lateral: RecordName | list[RecordName] | None = None
    """3D: the transverse component (y, positive left of the train); ``"none"`` when left out."""
    scale: NonNegative = 1.0
    vertical_scale: NonNegative = 1.0
    longitudinal_scale: NonNegative = 1.0
    lateral_scale: NonNegative | None = None
    """3D: the lateral component's own factor; default 1."""
    target_pga: Positive | None = None
    arrival: float = 0.0
    apparent_velocity: Positive | None = None
    seed: Annotated[int, Field(ge=0)] = 1
    record_dt: Positive | None = None

    def sources(self, component: str) -> list[str]:
        """The record names of a component as a list (one entry when synchronous)."""
        value = getattr(self, component)
        if value is None:  # the lateral component left out
            return ["none"]
        return list(value) if isinstance(value, list) else [value]

    @property
    def components(self) -> tuple[str, ...]:
        """The components given: vertical and longitudinal, and lateral when it is given."""
        return ("vertical", "longitudinal") + (("lateral",) if self.lateral is not None else ())


class ContactSpec(_Table):
    """``[contact]``: the tangential (creep) wheel-rail contact, paper Section 2.4."""

    normal: Literal["unilateral", "bilateral"] = "unilateral"
    """Normal wheel-rail contact: a wheel may lift off and land again (docs/method.md section 12),
    or the paper's rigid, bilateral contact."""
    creep: bool = True
    friction: Positive = 0.3
    rail_head_radius: Positive = 0.3
    youngs_modulus: Positive = 2.1e11
    poisson_ratio: Annotated[float, Field(ge=0, le=0.5)] = 0.3
    conicity: Annotated[float, Field(gt=0, lt=1)] | None = None
    """3D: equivalent conicity of the coned wheel treads; default the vehicle's ``conicity``
    parameter, else :data:`CONICITY_DEFAULT`."""
    flange_clearance: Positive | None = None
    """3D: lateral play of a wheelset on each side before its flange touches the rail (m); default
    the vehicle's ``flange_clearance`` parameter, else :data:`FLANGE_CLEARANCE_DEFAULT`."""


class SolverSpec(_Table):
    """``[solver]``: method, backend, time step and constraint coefficients."""

    method: Literal[METHODS] = "localized-dynamic"  # type: ignore[valid-type]
    backend: Literal[BACKENDS] = "c"  # type: ignore[valid-type]
    time_step: Positive = 1.0e-4
    duration: Positive | None = None
    output_every: Annotated[int, Field(ge=1)] = 10
    constraint_kappa: NonNegative = 1.0
    constraint_zeta: NonNegative = 1.0
    contact_split: Annotated[float, Field(gt=0, lt=1)] = 0.5
    max_gap: Positive = 1.0
    """Divergence guard: a constraint violation above this (m) stops the run as diverged."""


class OutputSpec(_Table):
    """``[output]``."""

    force_filter_hz: Positive = 20.0


class Scenario(_Table):
    """A validated scenario (docs/scenario.md) with every default filled in."""

    title: str = ""
    bridge: BridgeSpec
    train: TrainSpec
    track: TrackSpec = Field(default_factory=TrackSpec)
    earthquake: EarthquakeSpec | None = None
    contact: ContactSpec = Field(default_factory=ContactSpec)
    solver: SolverSpec = Field(default_factory=SolverSpec)
    output: OutputSpec = Field(default_factory=OutputSpec)

    _source: str = PrivateAttr(default="")
    _base_dir: Path = PrivateAttr(default_factory=Path.cwd)
    _dimensions: int = PrivateAttr(default=2)

    @property
    def dimensions(self) -> int:
        """3 when ``train.vehicle`` is a 3D vehicle topology (a 3D scenario), else 2."""
        return self._dimensions

    @property
    def source(self) -> str:
        """File the scenario came from ("" for one built in Python)."""
        return self._source

    @property
    def base_dir(self) -> Path:
        """Folder that relative paths (vehicle topology, records) are resolved against."""
        return self._base_dir

    def resolve_path(self, value: str) -> Path:
        path = Path(value).expanduser()
        return path if path.is_absolute() else self._base_dir / path

    def to_dict(self) -> dict[str, Any]:
        out = self.model_dump(mode="json", exclude_none=True)
        if self.bridge.girders is not None:
            # the long form echoes as written: spans/span_length are derived from the girders
            out["bridge"].pop("spans", None)
            out["bridge"].pop("span_length", None)
        return out

    def to_toml(self) -> str:
        """Normalised TOML text: every key, defaults filled in (echoed into the results)."""
        return tomli_w.dumps(self.to_dict())


# --------------------------------------------------------------------------------------------------
# loading


def load_scenario(
    path: str | Path, overrides: Sequence[str] | Mapping[str, Any] | None = None, check: bool = True
) -> Scenario:
    """Read, override, validate a scenario file. Raises :class:`ScenarioError` naming file and line."""
    path = Path(path)
    try:  # a regular file of bounded size (never /dev/zero, a FIFO or a folder), UTF-8
        text = decode_text(read_bytes(path, MAX_TOML_BYTES), str(path))
    except TextFileError as exc:  # before InputFileError, of which it is one: it has the line
        raise ScenarioError([Problem("<file>", exc.problem, exc.where)], str(path)) from None
    except InputFileError as exc:
        raise ScenarioError([Problem("<file>", exc.problem, str(path))], str(path)) from None
    return loads_scenario(
        text, source=str(path), base_dir=path.resolve().parent, overrides=overrides, check=check
    )


def loads_scenario(
    text: str,
    source: str = "<string>",
    base_dir: str | Path | None = None,
    overrides: Sequence[str] | Mapping[str, Any] | None = None,
    check: bool = True,
) -> Scenario:
    """Validate scenario TOML text (see :func:`load_scenario`)."""
    try:
        data = loads_toml(text)
    except TOMLNestingError as exc:
        raise ScenarioError([Problem("<toml>", f"malformed TOML: {exc}", source)], source) from None
    except tomllib.TOMLDecodeError as exc:
        line = getattr(exc, "lineno", None) or _line_from_message(str(exc))
        where = f"{source}:{line}" if line else source
        msg = getattr(exc, "msg", None) or re.sub(r"\s*\(at line \d+, column \d+\)", "", str(exc))
        raise ScenarioError([Problem("<toml>", f"malformed TOML: {msg}", where)], source) from None
    kind = wrong_kind(data, "scenario", source)
    if kind:
        raise ScenarioError([Problem("", kind, source)], source)
    base = copy.deepcopy(data) if overrides else None
    overridden = apply_overrides(data, overrides or [])
    try:
        return validate_scenario(
            data, source=source, base_dir=base_dir, text=text, overridden=overridden, check=check
        )
    except ScenarioError as exc:
        if base is None:
            raise
        raise _blame_overrides(exc, base, overrides or [], source, base_dir, check) from None


def _blame_overrides(
    exc: ScenarioError,
    base: dict[str, Any],
    overrides: Sequence[str] | Mapping[str, Any],
    source: str,
    base_dir: str | Path | None,
    check: bool,
) -> ScenarioError:
    """The problems of a scenario with overrides, each placed where it comes from: a problem that the
    file alone does not have comes from the ``--set`` value(s) that bring it (each tried alone on the
    file), not from the file line of its key."""
    mapping = isinstance(overrides, Mapping)
    items: list[Any] = list(overrides.items()) if isinstance(overrides, Mapping) else list(overrides)
    specs = [f"{k}={v!r}" for k, v in items] if mapping else [str(i) for i in items]

    def problems_with(chosen: list[Any]) -> set[tuple[str, str]]:
        data = copy.deepcopy(base)
        try:
            apply_overrides(data, dict(chosen) if mapping else chosen)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                validate_scenario(data, source=source, base_dir=base_dir, check=check)
        except ScenarioError as e:
            return {(p.key, p.message) for p in e.problems}
        return set()

    in_file = problems_with([])
    alone = [problems_with([item]) for item in items]
    out = []
    for p in exc.problems:
        if p.where.startswith("--set") or (p.key, p.message) in in_file:
            out.append(p)
            continue
        culprits = [spec for spec, found in zip(specs, alone, strict=True) if (p.key, p.message) in found]
        where = " and ".join(f"--set {spec}" for spec in (culprits or specs))
        out.append(Problem(p.key, p.message, where))
    return ScenarioError(out, exc.source)


def validate_scenario(
    data: Mapping[str, Any],
    source: str = "<dict>",
    base_dir: str | Path | None = None,
    text: str = "",
    overridden: Mapping[str, str] | None = None,
    check: bool = True,
) -> Scenario:
    """Validate a scenario given as a (TOML-shaped) dictionary."""
    lines = toml_key_lines(text) if text else {}
    overridden = dict(overridden or {})

    def where(key: str) -> str:
        for k, spec in overridden.items():
            if key == k or key.startswith((k + ".", k + "[")) or k.startswith((key + ".", key + "[")):
                return f"--set {spec}"
        parts = key.split(".")
        while parts:
            # a list member (spans[0]) is written on its key's line
            line = lines.get(".".join(parts)) or lines.get(re.sub(r"\[\d+\]$", "", ".".join(parts)))
            if line:
                return f"{source}:{line}"
            parts.pop()
        return source

    try:
        scenario = Scenario.model_validate(dict(data))
    except ValidationError as exc:
        raise ScenarioError([_problem(err, where) for err in exc.errors()], source) from None
    scenario._source = source if source not in ("<dict>", "<string>") else ""
    scenario._base_dir = Path(base_dir) if base_dir is not None else Path.cwd()
    scenario._dimensions = vehicle_dimensions(scenario.train.vehicle, scenario._base_dir)
    if check:
        problems = list(_semantic_problems(scenario))
        if problems:
            raise ScenarioError([Problem(k, m, where(k)) for k, m in problems], source)
        for message in time_step_warnings(scenario) + creep_warnings(scenario):
            warnings.warn(f"{source}: {message}" if source else message, ScenarioWarning, stacklevel=3)
        for key, message in plausibility_warnings(scenario):
            place = where(key)
            warnings.warn(f"{place}: {message}" if place else message, ScenarioWarning, stacklevel=3)
    return scenario


def apply_overrides(data: dict[str, Any], overrides: Sequence[str] | Mapping[str, Any]) -> dict[str, str]:
    """Apply ``key.path=value`` overrides in place; values are parsed as TOML literals, and a value
    that is not a valid literal (``coupled-dynamic``) is taken as a string. Returns key -> spec."""
    items: Iterable[tuple[str, Any]]
    if isinstance(overrides, Mapping):
        items = [(k, v) for k, v in overrides.items()]
        specs = {k: f"{k}={v!r}" for k, v in items}
    else:
        parsed = []
        specs = {}
        for spec in overrides:
            if "=" not in spec:
                raise ScenarioError([Problem(spec, "expected key.path=value", f"--set {spec}")])
            key, raw = spec.split("=", 1)
            key = key.strip()
            parsed.append((key, parse_literal(raw.strip())))
            specs[key] = spec
        items = parsed
    for key, value in items:
        parts = key.split(".")
        if not key or any(not p for p in parts):
            raise ScenarioError([Problem(key, "empty key in override", f"--set {specs[key]}")])
        steps: list[str | int] = []
        for part in parts:
            m = _INDEXED.fullmatch(part)
            if not m:
                raise ScenarioError(
                    [
                        Problem(
                            key,
                            f"{part!r} is not a key or a key with list indices such as girders[0]",
                            f"--set {specs[key]}",
                        )
                    ]
                )
            steps.append(m.group(1))
            steps.extend(int(i) for i in re.findall(r"\[(\d+)\]", m.group(2)))
        _set_path(data, steps, value, f"--set {specs[key]}")
    return specs


_INDEXED = re.compile(r"([A-Za-z0-9_\-]+)((?:\[\d+\])*)")


def _set_path(data: dict[str, Any], steps: Sequence[str | int], value: Any, where: str) -> None:
    """Set ``value`` at ``steps`` (table keys and list indices) of ``data``: missing tables are
    created, a list entry must exist (``bridge.girders[1]`` of a file with two girders or more)."""
    node: Any = data
    for i, step in enumerate(steps):
        last = i == len(steps) - 1
        here = _dotted(steps[: i + 1])
        if isinstance(step, int):
            if not isinstance(node, list):
                raise ScenarioError([Problem(here, f"{_dotted(steps[:i])} is not a list", where)])
            if step >= len(node):
                entries = "1 entry (0)" if len(node) == 1 else f"{len(node)} entries (0 … {len(node) - 1})"
                count = f"has {entries}" if node else "is empty"
                message = f"{_dotted(steps[:i])} {count}; --set replaces list entries, it adds none"
                raise ScenarioError([Problem(here, message, where)])
            if last:
                node[step] = value
                return
            node = node[step]
            continue
        if not isinstance(node, dict):
            raise ScenarioError(
                [Problem(_dotted(steps[:i]), "is not a table; cannot set a key inside it", where)]
            )
        if last:
            node[step] = value
            return
        node = node.setdefault(step, {} if isinstance(steps[i + 1], str) else [])


def parse_literal(raw: str) -> Any:
    """A TOML literal (``1e-4``, ``true``, ``[1, 2]``, ``"x"``), or the raw text as a string."""
    try:
        return loads_toml(f"v = {raw}")["v"]
    except (tomllib.TOMLDecodeError, TOMLNestingError):
        return raw


# --------------------------------------------------------------------------------------------------
# semantic checks that need more than one key, or the vehicle topology


def _semantic_problems(s: Scenario) -> Iterable[tuple[str, str]]:

    t, sol, trk = s.train, s.solver, s.track
    bridge_problems = s.bridge.long_form_problems() + list(girder_problems(s.bridge))
    yield from bridge_problems
    if bridge_problems:
        return
    if s.dimensions == 2 and _vehicle_loads(s):  # else its dimensions are unknown: train.vehicle says why
        yield from _keys_3d_in_2d(s)
    if trk.wavelength_min >= trk.wavelength_max:
        yield (
            "track.wavelength_min",
            (f"must be smaller than track.wavelength_max ({trk.wavelength_min:g} >= {trk.wavelength_max:g})"),
        )
    if t.speed_ms == 0.0 and t.acceleration <= 0.0 and sol.duration is None:
        yield (
            "train.speed_kmh" if t.speed is None else "train.speed",
            "0 (a train standing still) needs solver.duration: the run has no crossing to end it",
        )
    if t.acceleration < 0.0 and t.speed_ms > 0.0 and sol.duration is None:
        stop = t.speed_ms**2 / (-2.0 * t.acceleration)
        way = s.bridge.line_positions()[-1] - t.start_position
        if stop < way:  # the leading axle stops before the bridge's end (the last axle even sooner)
            yield (
                "train.acceleration",
                f"braking at {-t.acceleration:g} m/s^2 the train stops after {stop:.4g} m, before it has "
                "crossed the bridge: give solver.duration",
            )
    if sol.duration is not None and sol.duration < sol.time_step:
        yield "solver.duration", f"shorter than one time step ({sol.duration:g} s < {sol.time_step:g} s)"
    if s.earthquake is not None:
        yield from _earthquake_problems(s)
    if s.track.is_profile:
        yield from _profile_problems(s)
    if s.dimensions == 3:
        yield from _three_d_problems(s)
        return
    try:
        topo = vehicle_topology(s)
    except TopologyError as exc:
        yield "train.vehicle", exc.problem if exc.key == "vehicle" else str(exc)
        return
    if t.hslm is not None:
        if topo.kind != "moving-load":
            yield "train.hslm", f"needs train.vehicle = 'moving-load' (got {t.vehicle!r})"
        if t.cars != 1:
            yield "train.cars", f"an HSLM train is one unit: cars must be 1 with train.hslm (got {t.cars})"
        clash = sorted(set(t.parameters) & {"axle_loads", "axle_offsets", "car_length"})
        if clash:
            yield f"train.parameters.{clash[0]}", "is set by train.hslm; remove it or remove train.hslm"
    try:
        values = topo.values(t.parameters, where="train.parameters")
    except TopologyError as exc:
        yield _parameter_key(topo, exc.key, t.parameters), exc.problem
        return
    yield from size_problems(s, values)
    if topo.kind == "moving-load":
        loads = values.get("axle_loads", ())
        if any(not (float(p) > 0) for p in loads):
            yield "train.parameters.axle_loads", "axle loads must be positive (N, downward)"
        return
    yield from _vehicle_problems(s, values)


def _vehicle_loads(s: Scenario) -> bool:
    """Whether the vehicle of a 2D scenario loads (a topology file that cannot be read, or whose
    ``dimensions`` is neither 2 nor 3, is one problem of ``train.vehicle``, below)."""
    try:
        vehicle_topology(s)
    except TopologyError:
        return False
    return True


def _keys_3d_in_2d(s: Scenario) -> Iterable[tuple[str, str]]:
    """A 3D key in a 2D scenario: refused, never ignored."""
    why = (
        f"a key of 3D scenarios, but train.vehicle {s.train.vehicle!r} is a 2D vehicle (3D keys need a "
        "3D vehicle: manchester-3d, crh380a-3d or a topology file with dimensions = 3; docs/three-d.md)"
    )
    b = s.bridge
    tables: list[tuple[str, BaseModel, tuple[str, ...]]] = [
        ("bridge", b, (*SECTION_3D_FIELDS, "track_eccentricity")),
        *((f"bridge.girders[{i}]", g, SECTION_3D_FIELDS) for i, g in enumerate(b.girders or [])),
        *(
            (f"bridge.piers[{i}]", p, (*SECTION_3D_FIELDS, "bearing_stiffness_lateral"))
            for i, p in enumerate(b.piers or [])
        ),
        ("contact", s.contact, ("conicity", "flange_clearance")),
    ]
    for prefix, table, names in tables:
        for name in names:
            if getattr(table, name) is not None:
                yield f"{prefix}.{name}", why
    eq = s.earthquake
    if eq is not None:
        if eq.lateral is not None and eq.sources("lateral") != ["none"]:
            yield (
                "earthquake.lateral",
                f"the transverse ground motion acts on 3D scenarios only: train.vehicle {s.train.vehicle!r} "
                "is a 2D vehicle, whose model has no lateral motion (docs/three-d.md)",
            )
        if eq.lateral_scale is not None:
            yield "earthquake.lateral_scale", why


def _three_d_problems(s: Scenario) -> Iterable[tuple[str, str]]:
    """The checks of a 3D scenario: its vehicle topology and parameters, the 3D section keys."""
    from ..model.system3d import vehicle_parameters3d  # a built-in vehicle's generated DATA

    t, b = s.train, s.bridge
    if t.hslm is not None:
        yield "train.hslm", f"an HSLM train is a 2D moving load; train.vehicle {t.vehicle!r} is a 3D vehicle"
    yield from not_in_3d(s)
    try:
        topo = vehicle_parameters3d(vehicle_ref(s))
    except TopologyError as exc:
        yield "train.vehicle", exc.problem if exc.key == "vehicle" else str(exc)
        return
    parameters_ok = True
    for name, value in t.parameters.items():
        if name not in topo.parameters:
            parameters_ok = False
            yield (
                f"train.parameters.{name}",
                f"{topo.name} has no parameter {name!r} (its parameters: "
                f"{', '.join(sorted(topo.parameters))})",
            )
            continue
        values = value if isinstance(value, list) else [value]
        if isinstance(value, list) != isinstance(topo.parameters[name].value, tuple):
            parameters_ok = False
            yield (
                f"train.parameters.{name}",
                "must be a list" if not isinstance(value, list) else "must be a number",
            )
        elif not all(math.isfinite(float(v)) for v in values):
            parameters_ok = False
            yield f"train.parameters.{name}", f"must be finite (got {value!r})"
        elif not topo.parameters[name].signed and not all(float(v) >= 0 for v in values):
            parameters_ok = False
            yield f"train.parameters.{name}", f"must not be negative (got {value!r})"
    if parameters_ok:
        yield from _vehicle3d_problems(s)
    if t.speed_ms == 0.0 and s.contact.creep:
        yield (
            "train.speed_kmh" if t.speed is None else "train.speed",
            "0 with contact.creep: the creepages are relative to the rolling speed; give a speed, or "
            "contact.creep = false for a train standing still",
        )
    size = list(size_problems(s, {}))
    yield from size
    why = f"required in a 3D scenario (train.vehicle {t.vehicle!r} is a 3D vehicle)"
    what = {
        "lateral_second_moment": "the second moment I_zz for lateral bending (m^4)",
        "torsion_constant": "the St-Venant torsion constant J (m^4)",
    }
    for name, label in what.items():
        if getattr(b, name) is not None:
            continue
        missing = [i for i, g in enumerate(b.girders or [None]) if g is None or getattr(g, name) is None]
        if missing:
            key = f"bridge.{name}"
            yield key, f"{why}: {label}, of every span (or of each of [[bridge.girders]])"
    tables: list[tuple[str, BaseModel]] = [
        ("bridge", b),
        *((f"bridge.girders[{i}]", g) for i, g in enumerate(b.girders or [])),
        *((f"bridge.piers[{i}]", p) for i, p in enumerate(b.piers or [])),
    ]
    for prefix, table in tables:
        if table.poisson_ratio is not None and table.shear_modulus is not None:
            yield (
                f"{prefix}.shear_modulus",
                f"give {prefix}.poisson_ratio or {prefix}.shear_modulus, not both (G = E / (2 (1 + nu)))",
            )


def not_in_3d(s: Scenario) -> Iterable[tuple[str, str]]:
    """(key, message) for what a 3D scenario asks that the 3D step cannot do: refused with the
    scenario (naming the key's line) and, for a scenario built without the checks, by the run."""
    if s.train.acceleration != 0.0:
        yield "train.acceleration", "the 3D step runs trains at constant speed: remove it (or set 0)"
    if s.train.initial == "rigid-track":
        yield (
            "train.initial",
            "'rigid-track': a 3D run starts from the static state on the deck: use 'auto' or 'static'",
        )


def _vehicle3d_problems(s: Scenario) -> Iterable[tuple[str, str]]:
    """The 3D vehicle with the scenario's parameters: every body's mass and inertias positive (a
    zero makes the mass matrix singular). The cars' overlap, as the sizes of the run, are
    ``limits.size_problems``'."""
    from ..model.system3d import vehicle3d  # a built-in vehicle's generated module; a file's, derived

    t = s.train
    numbers = {k: float(v) for k, v in t.parameters.items() if not isinstance(v, list)}
    try:
        vehicle = vehicle3d(vehicle_ref(s), numbers)
    except (TopologyError, ValueError) as exc:
        yield "train.vehicle", str(exc)
        return
    for dof, m in zip(vehicle.dof_names, vehicle.M.diagonal(), strict=True):
        if not m > 0.0:
            zero = [k for k, v in numbers.items() if v == 0.0]
            key = f"train.parameters.{zero[0]}" if zero else "train.vehicle"
            yield key, f"the mass or inertia of {dof} is {m:g}: every body's mass and inertias must be > 0"
            return


def _profile_problems(s: Scenario) -> Iterable[tuple[str, str]]:
    """A measured profile must be an existing, well-formed file (its lines are checked on reading);
    whether it covers the wheels' path is checked with the run's extent (``limits.size_problems``)."""
    path = s.resolve_path(s.track.irregularity)
    if not os.path.lexists(path):
        yield (
            "track.irregularity",
            f"not {', '.join(repr(k) for k in IRREGULARITIES)} or an existing profile file: {path}",
        )
        return
    problem = file_problem(path, MAX_DATA_BYTES)  # a FIFO, a device, a folder, too large
    if problem is not None:
        yield "track.irregularity", f"{path}: {problem}"
        return
    try:
        read_profile_cached(path)
    except ValueError as exc:
        yield "track.irregularity", str(exc)


def _earthquake_problems(s: Scenario) -> Iterable[tuple[str, str]]:
    eq = s.earthquake
    assert eq is not None
    lines = s.bridge.spans + 1
    for comp in eq.components:
        value = getattr(eq, comp)
        per_support = isinstance(value, list)
        if per_support and len(value) != lines:
            yield (
                f"earthquake.{comp}",
                f"one record per support needs bridge.spans + 1 = {lines} entries (abutments and "
                f"piers, in the direction of travel); got {len(value)}",
            )
        if per_support and eq.apparent_velocity is not None and comp == _first_list(eq):
            yield (
                "earthquake.apparent_velocity",
                f"cannot be combined with one record per support (earthquake.{comp} is a list); "
                "give one or the other",
            )
        for k, name in enumerate(eq.sources(comp)):
            if name in ("none", "synthetic"):
                continue
            key = f"earthquake.{comp}[{k}]" if per_support else f"earthquake.{comp}"
            path = s.resolve_path(name)
            if not os.path.lexists(path):
                yield key, f"not 'none', 'synthetic' or an existing record file: {path}"
            elif (problem := file_problem(path, MAX_DATA_BYTES)) is not None:
                yield key, f"{path}: {problem}"  # a FIFO, a device, a folder, too large
    if eq.arrival < 0:
        yield (
            "earthquake.arrival",
            f"must be >= 0 (got {eq.arrival:g} s): a negative arrival would start the run in the "
            "middle of the record, and the train starts in static equilibrium at t = 0",
        )
    elif s.solver.duration is not None and eq.arrival >= s.solver.duration:
        names = ", ".join(n for c in eq.components for n in eq.sources(c) if n != "none")
        yield (
            "earthquake.arrival",
            f"the record ({names}) would start at {eq.arrival:g} s, not before the end of the run "
            f"(solver.duration = {s.solver.duration:g} s): the earthquake would never act",
        )


def _first_list(eq: EarthquakeSpec) -> str:
    return next(c for c in eq.components if isinstance(getattr(eq, c), list))


def _parameter_key(topo: Any, key: str, overrides: Mapping[str, Any]) -> str:
    """Dotted key of the parameter behind a topology error such as ``bodies[0].mass``."""
    if key.startswith("train.parameters"):
        return key
    m = re.match(r"(bodies|wheels)\[(\d+)\]\.(\w+)", key)
    if m:
        items = topo.bodies if m.group(1) == "bodies" else topo.wheels
        expr = getattr(items[int(m.group(2))], m.group(3), None)
        names = sorted(str(sym) for sym in getattr(expr, "free_symbols", ()))
        given = [n for n in names if n in overrides] or names
        if given:
            return f"train.parameters.{given[0]}"
    if key in topo.parameters:
        return f"train.parameters.{key}"
    return f"train.parameters ({key})"


def _vehicle_problems(s: Scenario, values: dict[str, Any]) -> Iterable[tuple[str, str]]:

    model = vehicle_model(vehicle_ref(s))
    try:
        vehicle = model.numeric(values)
    except TopologyError as exc:  # a mechanism: of the topology itself, or made by the overrides
        try:
            model.numeric({})
            key = "train.parameters"
        except TopologyError:
            key = "train.vehicle"
        yield key, f"{model.name}: {exc.problem}"
        return
    if vehicle.nwheels and not (vehicle.wheel_masses > 0).all():
        yield "train.parameters", "every wheel needs a positive mass (the contact constraint carries it)"
    if not math.isfinite(float(abs(vehicle.M).sum())):
        yield "train.parameters", "the vehicle mass matrix is not finite"


def vehicle_topology(s: Scenario):  # noqa: ANN201 - Topology, imported lazily
    return topology(vehicle_ref(s))


def time_step_warnings(s: Scenario) -> list[str]:
    """Warn when the time step does not resolve the fastest vehicle mode on rigid track (2D
    vehicles; the 3D run does not check its time step yet)."""
    if s.dimensions == 3:
        return []
    topo = vehicle_topology(s)
    if topo.kind == "moving-load":
        return []
    vehicle = vehicle_model(vehicle_ref(s)).numeric(topo.values(s.train.parameters))
    freqs = vehicle_modes(vehicle).frequencies_hz
    if not len(freqs):
        return []
    f_max = float(freqs.max())
    limit = 1.0 / (TIME_STEP_RESOLUTION * f_max)
    if s.solver.time_step > limit:
        steps = 1.0 / (f_max * s.solver.time_step)
        err = (2 * math.pi / steps) ** 2 / 12 * 100
        return [
            f"solver.time_step = {s.solver.time_step:g} s resolves the fastest vehicle mode "
            f"({f_max:.3g} Hz, period {1 / f_max:.3g} s) with only {steps:.1f} steps per period "
            f"(period error about {err:.2g} %); use time_step <= {limit:.3g} s "
            f"({TIME_STEP_RESOLUTION} steps per period)"
        ]
    return []


# --------------------------------------------------------------------------------------------------
# error reporting helpers

_ALLOWED_BY_TABLE: dict[str, type[BaseModel]] = {
    "": Scenario,
    "bridge": BridgeSpec,
    "bridge.girders": GirderSpec,
    "bridge.piers": PierSpec,
    "train": TrainSpec,
    "track": TrackSpec,
    "earthquake": EarthquakeSpec,
    "contact": ContactSpec,
    "solver": SolverSpec,
    "output": OutputSpec,
}


def _dotted(loc: Sequence[Any]) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += f".{part}" if out else str(part)
    return out


def _problem(err: Mapping[str, Any], where: Any) -> Problem:
    loc = [p for p in err.get("loc", ()) if p not in ("float", "int", "list[float]", "function-after")]
    # drop pydantic's union-branch labels such as 'constrained-float' from the location
    loc = [
        p for p in loc if not (isinstance(p, str) and ("[" in p or p.startswith(("constrained", "literal"))))
    ]
    key = _dotted(loc) or "<root>"
    kind = err.get("type", "")
    value = err.get("input")
    if kind == "extra_forbidden":
        table = _dotted(loc[:-1])
        model = _ALLOWED_BY_TABLE.get(re.sub(r"\[\d+\]", "", table))
        allowed = f" (allowed: {', '.join(model.model_fields)})" if model else ""
        message = f"unknown key{allowed}"
    elif kind == "missing":
        message = "required key is missing"
    elif kind in ("model_type", "dict_type"):
        message = f"must be a table ([{key}] or {key}.<key> = ...), got {value!r}"
    elif kind == "value_error":
        message = str(err.get("ctx", {}).get("error", err.get("msg", "")))
        if message.startswith("@"):
            # a check across keys names the key it is about: "@bridge.span_length: ..."
            key, message = message[1:].split(": ", 1)
    else:
        message = err.get("msg", "invalid").replace("Input should be", "must be")
        if value is not None and not isinstance(value, dict):
            message += f" (got {value!r})"
    return Problem(key, message, where(key))


def _line_from_message(message: str) -> int | None:
    m = re.search(r"line (\d+)", message)
    return int(m.group(1)) if m else None


def key_lines(text: str) -> dict[str, int]:
    """Line number of every table header and key of TOML text, by dotted path (for other files'
    error messages, e.g. the study files of ``svbi sweep``)."""
    return toml_key_lines(text)
