"""`svbi derive` and `svbi modes`: inspect a vehicle topology and its constraint coefficients."""

from __future__ import annotations

import json
import math
import os
import tomllib
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

import typer

from ...codegen.input_files import MAX_TOML_BYTES, InputFileError, TOMLNestingError, loads_toml, read_text
from ...codegen.plain_types import TopologyError, spin_dofs
from ...examples import paper_section_keys
from ..model.hslm import hslm_axles
from ..model.modes import span_modes, vehicle_modes
from ..scenario.build import bridge_from_scenario, distinct_spans_3d
from ..scenario.kinds import wrong_kind
from ..scenario.schema import Scenario, ScenarioError, load_scenario, vehicle_ref

if TYPE_CHECKING:
    from ...codegen.vehicle import VehicleModel

# SymPy and the symbolic core load inside the commands that use them: registering the commands
# (every `svbi` invocation, `svbi run` included) must not import SymPy.

BRIDGE_KEYS = {
    "span_length": 32.0,
    **paper_section_keys(),
    "elements_per_span": 16,
}

MIN_FREQUENCY_HZ = 1.0e-4
"""Span and bridge frequencies below this (a period of 2.8 hours; printed as 0.0000 Hz) are no
bridge's: `svbi modes` refuses them (stiffness over mass out of range, or a unit slip)."""


class Format(StrEnum):
    text = "text"
    latex = "latex"
    json = "json"


def derivation(model: VehicleModel) -> dict[str, Any]:
    """Everything `svbi derive` prints, as SymPy objects keyed as in the JSON output."""
    import sympy as sp

    # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
    from ...codegen import constraints

    out: dict[str, Any] = {
        "model": model.name,
        "kind": model.kind,
        "dofs": [q.name for q in model.dofs],
        "parameters": [p.name for p in model.parameters],
    }
    if model.kind == "moving-load":
        return out
    nw = model.contact_normal.shape[1]
    aux = model.aux_masses()
    active = model.active_mass_matrix()
    b_cols, masses = [], []
    for i in range(nw):
        e_col = sp.zeros(nw, 1)
        e_col[i, 0] = 1
        b = constraints.b_vehicle(model.contact_normal[:, i], e_col)
        b_cols.append(b)
        masses.append(constraints.mass_vehicle_constraint(b, active, aux))
    m_g = sp.Symbol("m_g", positive=True)
    out.update(
        {
            "mass_matrix": model.mass_matrix,
            "damping_matrix": model.damping_matrix,
            "stiffness_matrix": model.stiffness_matrix,
            "gravity_load": model.gravity_load,
            "contact_normal": model.contact_normal,
            "contact_tangential": model.contact_tangential,
            "active_mass_matrix": active,
            "aux_masses": aux,
            "b_vectors": sp.Matrix.hstack(*b_cols),
            "constraint_masses": sp.diag(*masses),
            "bridge_b_vector": constraints.b_bridge(),
            "bridge_constraint_mass": sp.Matrix([[constraints.mass_bridge_constraint(m_g)]]),
            "support_b_vectors": sp.Matrix.hstack(constraints.b_support(0), constraints.b_support(1)),
            "support_constraint_masses": sp.diag(
                constraints.mass_support_constraint(0), constraints.mass_support_constraint(1)
            ),
        }
    )
    return out


def _to_json(value: Any) -> Any:
    import sympy as sp

    if isinstance(value, sp.MatrixBase):
        return [[str(e) for e in value.row(i)] for i in range(value.rows)]
    return value


def _notes() -> str:
    # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
    from ...codegen import beam
    from ...codegen.vehicle import a_split

    return (
        f"Symbols: {a_split} = aux-point mass split, g = gravity, m_g = aux point mass, "
        f"{beam.xi} = position in the element (0..1), {beam.le} = element length, "
        f"{beam.mu} = mass per length.\n"
        "b_vectors act on [u^V; u^g] (Eq. 25); bridge_b_vector on [u^g; u_e] with element DOFs "
        "[u1, w1, theta1, u2, w2, theta2] (Eq. 29); support_b_vectors on the element DOFs (Eq. 33)."
    )


def derive(
    model: str = typer.Argument(..., help="Built-in vehicle name or path to a topology TOML file."),
    fmt: Format = typer.Option(Format.text, "--format", "-f", help="text, latex or json."),
) -> None:
    """Print the DOFs, matrices, contact directions, b-vectors and constraint masses of a vehicle."""
    import sympy as sp

    vehicle = _load(model)
    data = derivation(vehicle)
    if fmt is Format.json:
        typer.echo(json.dumps({k: _to_json(v) for k, v in data.items()}, indent=1))
        return
    if fmt is Format.latex:
        typer.echo(latex_document(data, _notes() if vehicle.kind != "moving-load" else ""))
        return
    for key, value in data.items():
        if isinstance(value, sp.MatrixBase):
            rows = "\n".join("  [" + ", ".join(str(e) for e in value.row(i)) + "]" for i in range(value.rows))
            typer.echo(f"\n{key}:\n{rows}")
        else:
            typer.echo(f"{key}: {value}")
    if vehicle.kind != "moving-load":
        typer.echo("\n" + _notes())


_TEX_SPECIAL = {
    "\\": r"\textbackslash{}",
    "{": r"\{",
    "}": r"\}",
    "_": r"\_",
    "^": r"\^{}",
    "&": r"\&",
    "%": r"\%",
    "$": r"\$",
    "#": r"\#",
    "~": r"\~{}",
}


def tex_text(text: str) -> str:
    """Plain text with LaTeX's special characters escaped."""
    return "".join(_TEX_SPECIAL.get(c, c) for c in str(text))


def latex_document(data: dict[str, Any], notes: str = "") -> str:
    r"""`svbi derive --format latex`: a standalone LaTeX document (article, amsmath).

    Every symbol prints under its full name in italics (``\mathit{carbody\_mass}``): SymPy's own
    rule would cut ``carbody_pitch_inertia`` into the subscript ``carbody_{pitch inertia}``. Words
    stay outside math; each matrix is display math."""
    import sympy as sp

    matrices = {k: v for k, v in data.items() if isinstance(v, sp.MatrixBase)}
    symbols = set().union(*(m.free_symbols for m in matrices.values())) if matrices else set()
    names = {sym: r"\mathit{" + tex_text(sym.name) + "}" for sym in symbols}
    cols = max((m.cols for m in matrices.values()), default=1)
    lines = [
        f"% svbi derive {tex_text(data['model'])} --format latex: compile with pdflatex",
        r"\documentclass{article}",
        r"\usepackage{amsmath}",
        r"\usepackage[landscape,margin=1cm]{geometry}",
        # amsmath's matrix takes at most MaxMatrixCols columns (10 by default)
        rf"\setcounter{{MaxMatrixCols}}{{{max(cols, 10)}}}",
        r"\begin{document}",
        rf"\section*{{Vehicle \texttt{{{tex_text(data['model'])}}} ({tex_text(data['kind'])})}}",
    ]
    for key, value in data.items():
        if key in ("model", "kind"):
            continue
        if isinstance(value, sp.MatrixBase):
            body = (
                sp.latex(value, symbol_names=names, mat_delim="[") if value.rows and value.cols else r"[\,]"
            )
            lines += [rf"\paragraph{{{tex_text(key)}}}", r"\[", body, r"\]"]
        elif isinstance(value, list | tuple):
            items = ", ".join(rf"$\mathit{{{tex_text(v)}}}$" for v in value) or "none"
            lines += [rf"\paragraph{{{tex_text(key)}}} {items}"]
        else:
            lines += [rf"\paragraph{{{tex_text(key)}}} {tex_text(value)}"]
    if notes:
        lines += [r"\paragraph{Notes}", tex_text(notes).replace("\n", "\n\n")]
    lines.append(r"\end{document}")
    return "\n".join(lines)


def modes(
    model: str = typer.Argument(
        ..., help="Built-in vehicle name, path to a topology TOML file, or a scenario file."
    ),
    set_: list[str] = typer.Option(
        [],
        "--set",
        help="name=value: a vehicle parameter, or a bridge key (span_length, mass_per_length, "
        "youngs_modulus, area, second_moment, elements_per_span) to also print span frequencies. "
        "With a scenario file: a scenario key (train.parameters.stiffness=..., bridge.span_length=...).",
    ),
    as_json: bool = typer.Option(False, "--json", help="Print JSON (key frequencies_hz)."),
    count: int = typer.Option(5, help="Number of span modes to print."),
) -> None:
    """Print the vehicle's natural frequencies on rigid track (Hz, ascending), and span frequencies.

    Given a scenario file, its vehicle (with ``train.parameters``) and its bridge's spans; a 3D
    scenario adds the span's lateral and torsional frequencies (docs/scenario.md, "3D scenarios")."""
    import numpy as np

    model_path = model + "".join(f" --set {item}" for item in set_)
    sc = _scenario_file(model, set_)
    if sc is not None and sc.dimensions == 3:
        _modes_3d(sc, model_path, as_json, count)
        return
    scenario = _scenario_modes(sc) if sc is not None else None
    spans = ""
    if scenario is not None:
        model, overrides, bridge, count_spans = scenario
        spans = f" (each of the {count_spans} simply supported spans of the scenario)"
    else:
        overrides, bridge = _parse_sets(set_)
    vehicle = _load(model)
    try:
        numeric = vehicle.numeric(overrides)
    except TopologyError as exc:
        if exc.key.startswith("train.parameters"):  # names the parameter already
            _fail(f"{exc.key.removeprefix('train.parameters.')}: {exc.problem}")
        # the topology is fine on its own (checked on loading): the values given make the problem
        given = ", ".join(f"{k}={v}" for k, v in overrides.items())
        _fail(f"{given}: {vehicle.name}: {exc.problem}")
    out: dict[str, Any] = {"model": vehicle.name}
    if vehicle.kind == "moving-load":
        out.update(frequencies_hz=[], rigid_modes=0)
    else:
        vm = vehicle_modes(numeric)
        out.update(frequencies_hz=[float(f) for f in vm.frequencies_hz], rigid_modes=vm.rigid_modes)
    whole = bridge.pop("whole", None) if bridge else None
    if whole is not None:
        out["bridge_frequencies_hz"] = [float(f) for f in whole.natural_frequencies(count)]
        if not all(f >= MIN_FREQUENCY_HZ for f in out["bridge_frequencies_hz"]):  # NaN or 0 Hz
            _fail_file(
                f"{model_path}: bridge: the bridge's lowest frequencies are "
                f"{', '.join(f'{f:g}' for f in out['bridge_frequencies_hz'])} Hz: not a bridge that "
                "stands (sections out of range: a unit slip?)"
            )
    if bridge:
        b = {**BRIDGE_KEYS, **bridge}
        if b["elements_per_span"] != int(b["elements_per_span"]) or b["elements_per_span"] > 10_000:
            _fail("elements_per_span: must be a whole number up to 10000")
        try:
            with np.errstate(all="ignore"):
                fb, fa = span_modes(
                    b["span_length"],
                    int(b["elements_per_span"]),
                    b["youngs_modulus"],
                    b["area"],
                    b["second_moment"],
                    b["mass_per_length"],
                )
            finite = bool(np.isfinite(fb).all() and np.isfinite(fa).all())
            # a degenerate span: frequencies at 0 Hz, below what the eigensolver resolves
            positive = finite and bool(
                (fb[:count] >= MIN_FREQUENCY_HZ).all() and (fa[:count] >= MIN_FREQUENCY_HZ).all()
            )
        except (ValueError, np.linalg.LinAlgError):  # scipy's eigh on overflowing matrices
            finite = positive = False
        if not positive:
            given = ", ".join(f"{k}={v:g}" for k, v in bridge.items())
            what = (
                "not finite numbers"
                if not finite
                else f"below {MIN_FREQUENCY_HZ:g} Hz, printed as 0 Hz (a degenerate span)"
            )
            message = (
                f"the span's frequencies are {what} with these values (stiffness over "
                "mass_per_length out of range: a unit slip?)"
            )
            if scenario is not None:
                _fail_file(
                    f"{model_path}: bridge.span_length, mass_per_length, youngs_modulus, area, "
                    f"second_moment: {message}"
                )
            _fail(f"{given}: {message}")
        out["bridge"] = b
        out["span_frequencies_hz"] = [float(f) for f in fb[:count]]
        out["span_axial_frequencies_hz"] = [float(f) for f in fa[:count]]
    if as_json:
        typer.echo(json.dumps(out, indent=1))
        return
    typer.echo(f"{vehicle.name}: natural frequencies on rigid track (Hz)")
    for i, f in enumerate(out["frequencies_hz"], 1):
        typer.echo(f"  mode {i:2d}: {f:10.4f}")
    if out["rigid_modes"]:
        # load-time checks refuse every other free motion (plain_types.mechanism_problem)
        spin = spin_dofs(numeric)
        spins = ", ".join(numeric.dof_names[i].partition("_")[2] for i in spin)
        if out["rigid_modes"] == len(spin):
            typer.echo(f"  plus {out['rigid_modes']} rigid (0 Hz) mode(s): free wheel spin of {spins}")
        else:  # the load-time check found only the spins free: the rest are numerically zero
            typer.echo(
                f"  plus {out['rigid_modes']} mode(s) at 0 Hz: {len(spin)} free wheel spin(s)"
                + (f" of {spins}" if spins else "")
                + "; the others are too slow to resolve against the fastest mode "
                "(parameter values many orders of magnitude apart?)"
            )
    if whole is not None:
        typer.echo(
            f"bridge ({whole.spans} spans, {len(whole.piers)} piers, continuous girders and piers "
            "included, supports held): lowest natural frequencies (Hz)"
        )
        for i, f in enumerate(out["bridge_frequencies_hz"], 1):
            typer.echo(f"  mode {i:2d}: {f:10.4f}")
    if bridge:
        typer.echo(f"span{spans}: vertical bending frequencies (Hz)")
        for i, f in enumerate(out["span_frequencies_hz"], 1):
            typer.echo(f"  mode {i:2d}: {f:10.4f}")
        typer.echo(
            "span: axial frequencies (Hz): " + ", ".join(f"{f:.3f}" for f in out["span_axial_frequencies_hz"])
        )


def _fail(message: str) -> NoReturn:
    """One line on stderr naming the --set key, exit status 2 (as an invalid scenario)."""
    typer.echo(f"error: --set {message}", err=True)
    raise typer.Exit(2)


def _fail_file(message: str) -> NoReturn:
    """One line on stderr about the scenario file, exit status 2."""
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(2)


def _load(model: str) -> VehicleModel:
    # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
    from ...codegen.topology import load_topology
    from ...codegen.vehicle import derive_vehicle

    try:
        vehicle = derive_vehicle(load_topology(model))
        vehicle.numeric()  # the topology's own values: a mechanism is refused here (one line)
        return vehicle
    except TopologyError as exc:
        typer.echo(f"error: {_other_kind(model) or exc}", err=True)
        raise typer.Exit(2) from None


def _other_kind(path: str) -> str:
    """``path: this is a study file...`` when ``path`` is a TOML file of another kind than a topology."""
    try:  # bounded: the topology loader has refused /dev/zero or a FIFO already, in its message
        data = loads_toml(read_text(path, MAX_TOML_BYTES))
    except ValueError:  # not a readable TOML file: the topology loader's message stands
        return ""
    kind = wrong_kind(data, "topology", path)
    return f"{path}: {kind}" if kind else ""


def _scenario_file(path: str, sets: list[str]) -> Scenario | None:
    """The scenario of a scenario file (a TOML file with ``[bridge]`` and ``[train]`` tables, not a
    topology), with the ``--set`` overrides; None for anything else. An invalid one: one line, exit 2."""
    p = Path(path)
    if p.suffix != ".toml" or not os.path.isfile(p):
        return None
    try:
        data = loads_toml(read_text(p, MAX_TOML_BYTES))
    except (InputFileError, TOMLNestingError, tomllib.TOMLDecodeError):
        return None  # not a scenario: the topology loader says what is wrong with it
    if not ("bridge" in data and "train" in data):
        return None
    try:
        return load_scenario(p, overrides=sets)
    except ScenarioError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None


def _scenario_modes(sc: Scenario) -> tuple[str, dict[str, Any], dict[str, float], int]:
    """A 2D scenario as (vehicle reference, its parameter values, its span's keys, its spans)."""
    parameters: dict[str, Any] = dict(sc.train.parameters)
    if sc.train.hslm is not None:
        loads, offsets, length = hslm_axles(sc.train.hslm)
        parameters.update(axle_loads=list(loads), axle_offsets=list(offsets), car_length=length)
    b = sc.bridge
    built = bridge_from_scenario(sc)
    if not built.uniform:  # continuous girders, unequal spans, piers: the whole bridge's modes
        return vehicle_ref(sc), parameters, {"whole": built}, b.spans
    bridge = {key: float(getattr(b, key)) for key in BRIDGE_KEYS}
    return vehicle_ref(sc), parameters, bridge, b.spans


SPAN_FAMILIES_3D = {
    "vertical": "span_frequencies_hz",
    "lateral": "span_lateral_frequencies_hz",
    "torsion": "span_torsional_frequencies_hz",
    "axial": "span_axial_frequencies_hz",
}
"""The families of a 3D span's modes (``span3d.GROUPS``) and their JSON keys."""


def span_frequencies_3d(sc: Scenario, count: int) -> list[dict[str, Any]]:
    """Each distinct span of a 3D scenario: its length, which spans it is, and the ``count`` lowest
    frequencies (Hz) of each family (vertical, lateral, torsional, axial) of the simply supported
    span on forks (``runtime/model/span3d.py``, ``bridge.elements_per_span`` elements)."""
    from ..model.span3d import family_frequencies, simply_supported_span

    out = []
    for spec in distinct_spans_3d(sc):
        span = simply_supported_span(spec.section, spec.length, sc.bridge.elements_per_span)
        entry: dict[str, Any] = {"span_length": spec.length, "spans": list(spec.spans)}
        for family, key in SPAN_FAMILIES_3D.items():
            entry[key] = [float(f) for f in family_frequencies(span, family, count)]
        out.append(entry)
    return out


def vehicle_frequencies_3d(reference: str, parameters: dict[str, Any]) -> list[float]:
    """Natural frequencies (Hz, ascending) of a 3D vehicle with its wheelsets held: its car body's
    and bogies' modes on the suspensions (docs/three-d.md)."""
    import numpy as np
    from scipy.linalg import eigh

    from ..model.system3d import vehicle3d  # deferred: SymPy

    v = vehicle3d(reference, parameters)
    held = {int(i) for w in v.wheelsets for i in w.dofs}
    keep = [i for i in range(len(v.dof_names)) if i not in held]
    eigenvalues = eigh(v.K[np.ix_(keep, keep)], v.M[np.ix_(keep, keep)], eigvals_only=True)
    return [float(f) for f in np.sqrt(np.maximum(eigenvalues, 0.0)) / (2.0 * np.pi)]


def _modes_3d(sc: Scenario, model_path: str, as_json: bool, count: int) -> None:
    """`svbi modes` of a 3D scenario: the vehicle with its wheelsets held, and the vertical,
    lateral, torsional and axial frequencies of each distinct span."""
    if count < 1:
        _fail_file(f"{model_path}: --count: must be at least 1 (got {count})")
    ref = vehicle_ref(sc)
    name = Path(ref).stem if os.sep in ref else ref
    out: dict[str, Any] = {"model": name, "dimensions": 3}
    try:
        out["frequencies_hz"] = vehicle_frequencies_3d(ref, dict(sc.train.parameters))
    except (ValueError, KeyError) as exc:  # a vehicle whose wheelsets the 3D model cannot find
        _fail_file(f"{model_path}: train.vehicle: {exc}")
    spans = span_frequencies_3d(sc, count)
    for entry in spans:
        values = [f for key in SPAN_FAMILIES_3D.values() for f in entry[key]]
        if not all(math.isfinite(f) and f >= MIN_FREQUENCY_HZ for f in values):
            _fail_file(
                f"{model_path}: bridge: the span's frequencies are not finite numbers above "
                f"{MIN_FREQUENCY_HZ:g} Hz with these sections (a unit slip?)"
            )
    if len(spans) == 1:  # the shorthand, or a long form whose spans are all alike
        out.update({key: spans[0][key] for key in SPAN_FAMILIES_3D.values()})
    else:
        out["distinct_spans"] = spans
    if as_json:
        typer.echo(json.dumps(out, indent=1))
        return
    typer.echo(f"{name} (3D): natural frequencies with the wheelsets held (Hz)")
    for i, f in enumerate(out["frequencies_hz"], 1):
        typer.echo(f"  mode {i:2d}: {f:10.4f}")
    labels = {
        "span_frequencies_hz": "vertical bending",
        "span_lateral_frequencies_hz": "lateral bending",
        "span_torsional_frequencies_hz": "torsional",
        "span_axial_frequencies_hz": "axial",
    }
    for entry in spans:
        which = (
            f"each of the {len(entry['spans'])} simply supported spans of the scenario"
            if len(spans) == 1
            else f"spans {', '.join(str(i) for i in entry['spans'])}, simply supported on forks"
        )
        typer.echo(f"span {entry['span_length']:g} m ({which}): frequencies (Hz)")
        for key, label in labels.items():
            typer.echo(f"  {label:16s} " + ", ".join(f"{f:.4f}" for f in entry[key]))


def _parse_sets(items: list[str]) -> tuple[dict[str, Any], dict[str, float]]:
    overrides: dict[str, Any] = {}
    bridge: dict[str, float] = {}
    for item in items:
        if "=" not in item:
            _fail(f"expected name=value, got {item!r}")
        name, raw = (s.strip() for s in item.split("=", 1))
        try:
            value = loads_toml(f"x = {raw}")["x"]
        except (tomllib.TOMLDecodeError, TOMLNestingError):
            _fail(f"{name}: cannot parse value {raw!r}")
        if name in BRIDGE_KEYS:
            if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value < math.inf:
                _fail(f"{name}: must be a finite positive number, got {raw}")
            bridge[name] = float(value)
        else:
            overrides[name] = value
    return overrides, bridge


def register(app: typer.Typer) -> None:
    app.command("derive")(derive)
    app.command("modes")(modes)
