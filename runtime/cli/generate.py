"""`svbi generate` and `svbi export`: emit the kernels of a model as CasADi and C files."""

from __future__ import annotations

import difflib
import os
import tempfile
from pathlib import Path

import typer

from ...codegen.loop_abi import GLUE_NAMES
from ..run.export import PROGRAM, example_scenario, scenario_files
from ..run.output import OutputPathError, prepare_folder
from ..scenario.schema import ScenarioError, load_scenario
from ..toolchain import generated_root

MAX_DIFF_LINES = 400


def _generated_root() -> Path:
    return generated_root()


def _is_file_target(target: str) -> bool:
    return target.endswith(".toml") or Path(target).is_file()


def _render(target: str, embedded: bool = False) -> tuple[str, dict[str, bytes]]:
    """Every generated file of a model folder: the C kernels, build files and CasADi Functions
    (``c_emit``), the NumPy module (``python_emit``) that the runtime calls, and the C time loop's
    glue of the model (``svbi.codegen.loop_glue``: the topology header of a vehicle, the contact rows
    and creep law of frame2d). A moving-load vehicle has only its NumPy module (its data) and its
    topology header."""
    # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
    from ...codegen import c_emit, python_emit
    from ...codegen import loop_glue as c_glue
    from ...codegen.contact3d_kernels import CONTACT3D
    from ...codegen.frame3d import FRAME3D
    from ...codegen.kernels import FRAME2D, frame2d_model_spec, skip_reason, vehicle_model_spec
    from ...codegen.topology3d import builtin_topologies_3d
    from ...codegen.vehicle3d import render_vehicle3d

    if target == FRAME3D:
        # the 3D element is not yet in the C loop: its NumPy module only
        name, source = python_emit.render_target(target)
        return name, {python_emit.FILENAME: source}
    if target == CONTACT3D:
        # the 3D contact: C kernels and CasADi Functions as every model, no loop glue (the C loop
        # has no 3D contact yet)
        from ...codegen.contact3d_kernels import contact3d_model_spec

        options = c_emit.EmitOptions.embedded() if embedded else c_emit.EmitOptions()
        name, source = python_emit.render_target(target)
        files = {**c_emit.render_model(contact3d_model_spec(), options), python_emit.FILENAME: source}
        return name, dict(sorted(files.items()))
    if target in builtin_topologies_3d():
        # a 3D vehicle: its NumPy module only (not yet in the C loop)
        name, source = render_vehicle3d(target)
        return name, {python_emit.FILENAME: source}
    if skip_reason(target) is not None:
        name, source = python_emit.render_target(target)
        return name, dict(sorted({python_emit.FILENAME: source, **c_glue.topology(name, 0, 0)}.items()))
    options = c_emit.EmitOptions.embedded() if embedded else c_emit.EmitOptions()
    if target == FRAME2D:
        spec = frame2d_model_spec()
        _, source = python_emit.render_target(target)
    else:
        # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
        from ...codegen.vehicle import derive_vehicle

        vehicle = derive_vehicle(target)
        spec = vehicle_model_spec(vehicle)
        source = python_emit.render_vehicle(vehicle, spec)
    files = {**c_emit.render_model(spec, options), **c_glue.model_glue(spec), python_emit.FILENAME: source}
    return spec.name, dict(sorted(files.items()))


def _targets() -> list[str]:
    """Every built-in model with generated files: the vehicles (moving loads: the NumPy module
    only), ``frame2d``, and the 3D models: the 3D vehicles and ``frame3d`` (NumPy modules only) and
    ``contact3d`` (its NumPy module, C kernels and CasADi Functions)."""
    # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
    from ...codegen.contact3d_kernels import CONTACT3D
    from ...codegen.frame3d import FRAME3D
    from ...codegen.kernels import FRAME2D
    from ...codegen.topology import builtin_topologies
    from ...codegen.topology3d import builtin_topologies_3d

    return [*builtin_topologies(), *builtin_topologies_3d(), FRAME2D, FRAME3D, CONTACT3D]


def _builtin_tree() -> dict[str, dict[str, bytes]]:
    """``{folder: files}`` of the whole committed tree: every built-in model and the loops'
    ``solver/`` and ``solver3d/`` folders, which belong to no model."""
    # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
    from ...codegen import loop_glue as c_glue

    tree = dict(_render(model) for model in _targets())
    tree[c_glue.SOLVER_FOLDER] = c_glue.solver_types()
    tree[c_glue.SOLVER3D_FOLDER] = c_glue.loop3d_types()
    return tree


def _tree(folder: Path) -> dict[str, bytes]:
    """Every model file under ``folder`` (``<model>/<file>``), skipping Python package files."""
    files = {}
    if folder.is_dir():
        for path in sorted(folder.rglob("*")):
            rel = path.relative_to(folder)
            if not path.is_file() or rel.parts[0] == "__init__.py" or "__pycache__" in rel.parts:
                continue
            files[rel.as_posix()] = path.read_bytes()
    return files


def _diff(name: str, expected: bytes | None, actual: bytes | None) -> list[str]:
    if expected is None:
        return [f"only in the committed tree (stale): {name}\n"]
    if actual is None:
        return [f"missing from the committed tree: {name}\n"]
    try:
        new, old = expected.decode().splitlines(True), actual.decode().splitlines(True)
    except UnicodeDecodeError:
        return [f"binary file differs: {name}\n"]
    if name.endswith(".casadi"):
        return [f"serialized CasADi Function differs: {name}\n"]
    return list(difflib.unified_diff(old, new, f"committed/{name}", f"regenerated/{name}"))


def check_tree(committed: Path) -> list[str]:
    """Regenerate every built-in model into a temporary folder and diff it against ``committed``.

    Returns the unified diff lines (empty when the trees match).
    """
    # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
    from ...codegen import c_emit

    with tempfile.TemporaryDirectory(prefix="svbi-check-") as tmp:
        for name, files in _builtin_tree().items():
            c_emit.write_files(files, Path(tmp) / name)
        fresh = _tree(Path(tmp))
    current = _tree(committed)
    lines: list[str] = []
    for name in sorted(set(fresh) | set(current)):
        if fresh.get(name) != current.get(name):
            lines += _diff(name, fresh.get(name), current.get(name))
    return lines


def generate(
    models: list[str] | None = typer.Argument(
        None,
        help="Built-in model names (vehicles, frame2d or frame3d for the bridge elements) or topology files.",
    ),
    all_: bool = typer.Option(False, "--all", help="Every built-in model."),
    out: Path | None = typer.Option(
        None,
        "--out",
        help="Output folder, one sub-folder per model. Default: the package's generated/ for built-in "
        "models, ./svbi-generated for topology files. With --check: the tree to compare against.",
    ),
    check: bool = typer.Option(
        False, "--check", help="Regenerate every built-in model into a temporary folder and diff."
    ),
) -> None:
    """Generate CasADi Functions (.casadi), C kernels, headers, build files and the NumPy module
    (numpy_kernels.py) for models."""
    # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
    from ...codegen import c_emit
    from ...codegen.kernels import skip_reason

    if check:
        committed = out or _generated_root()
        lines = check_tree(committed)
        if lines:
            for line in lines[:MAX_DIFF_LINES]:
                typer.echo(line, nl=not line.endswith("\n"))
            if len(lines) > MAX_DIFF_LINES:
                typer.echo(f"... ({len(lines) - MAX_DIFF_LINES} more diff lines)")
            typer.echo(
                f"\nGenerated code in {committed} is out of date. Update it with `make generate` "
                "(or `svbi generate --all`) and commit the result.",
                err=True,
            )
            raise typer.Exit(1)
        typer.echo(f"generated code in {committed} is up to date")
        return

    targets = list(models or [])
    if all_:
        targets = [t for t in targets if t not in _targets()]
        for name, files in _builtin_tree().items():
            folder = c_emit.write_files(files, (out or _generated_root()) / name)
            typer.echo(f"generated {name}: {len(files)} files in {folder}")
    if not targets and not all_:
        typer.echo("Name one or more models (or topology files), or pass --all.", err=True)
        raise typer.Exit(2)
    for target in targets:
        reason = skip_reason(target)
        if reason:
            typer.echo(f"no C kernels: {reason}; only the NumPy module (its data)")
        base = out or (Path.cwd() / "svbi-generated" if _is_file_target(target) else _generated_root())
        name, files = _render(target)
        folder = c_emit.write_files(files, base / name)
        typer.echo(f"generated {name}: {len(files)} files in {folder}")
    if all_ and out is None:
        # Remove folders of models that are no longer built in, so --check stays clean.
        from ...codegen.python_emit import FILENAME

        for folder in _generated_root().iterdir():
            generated = (folder / "manifest.json").is_file() or (folder / FILENAME).is_file()
            if generated and folder.name not in _targets():
                import shutil

                shutil.rmtree(folder)
                typer.echo(f"removed stale {folder}")


EXPORTED_SUFFIXES = (".c", ".h", "Makefile", "CMakeLists.txt")


def export(
    model: str = typer.Argument(..., help="Built-in model name or topology file."),
    folder: Path = typer.Argument(..., help="Folder to write the self-contained C sources into."),
    solver: bool = typer.Option(
        False,
        "--solver",
        help="Also export the C time loop, with a scenario baked into scenario_data.c and "
        "an example main.c that runs it and writes a CSV.",
    ),
    scenario: Path | None = typer.Option(
        None,
        "--scenario",
        help="With --solver: the scenario to bake in (default: a small built-in one, "
        "2 cars over 2 spans with a synthetic quake and a German-low track).",
    ),
    embedded: bool = typer.Option(
        False, "--embedded", help="32-bit casadi_int and no stack temporaries (small embedded targets)."
    ),
    force: bool = typer.Option(
        False, "--force", help="Overwrite files of the same name in FOLDER (refused otherwise)."
    ),
) -> None:
    """Write a model's C kernels, header, Makefile, CMakeLists.txt and example main.c to FOLDER.

    Files of the same name already in FOLDER with other content (your own main.c or Makefile) are
    not overwritten: the export is refused unless --force.

    With --solver, the folder also holds the whole Newmark time loop (docs/c-backend.md) and the
    example program runs a scenario with it. The folder builds with `make` (or CMake, kernels only)
    and needs no Python, CasADi or SymPy.
    """
    # deferred: brings SymPy and Jinja2 (about 0.5 s), for derivation and emission only
    from ...codegen import c_emit
    from ...codegen.kernels import skip_reason

    try:
        folder = _export_folder(folder)
        reason = skip_reason(model)
        if reason and not solver:
            typer.echo(f"nothing to export: {reason}", err=True)
            raise typer.Exit(1)
        exported: dict[str, bytes] = {}
        name = model
        if not reason:
            name, files = _render(model, embedded=embedded)
            exported = {
                n: d for n, d in files.items() if n.endswith(EXPORTED_SUFFIXES) and n not in GLUE_NAMES
            }
        if not solver:
            _refuse_overwrite(folder, exported, force)
            c_emit.write_files(exported, folder, prune=False)
            typer.echo(f"exported {name} to {folder} ({len(exported)} files): build with `make -C {folder}`")
            return
        # the solver's example replaces the kernels' example program and build files
        kernels = {n: d for n, d in exported.items() if n not in ("main.c", "Makefile", "CMakeLists.txt")}
        sc = load_scenario(scenario) if scenario is not None else None
        files, _ = scenario_files(model, sc or example_scenario(model), kernels, embedded)
        _refuse_overwrite(folder, files, force)
        c_emit.write_files(files, folder, prune=False)
    except (ScenarioError, ValueError) as exc:  # TopologyError, InputFileError, OutputPathError
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    except OSError as exc:  # the folder could be created, but not a file in it (full disk...)
        typer.echo(f"error: cannot write to {folder}: {exc.strerror or exc}", err=True)
        raise typer.Exit(2) from None
    typer.echo(
        f"exported {name} with the C time loop to {folder} ({len(files)} files): build with "
        f"`make -C {folder}`, run `{folder}/{PROGRAM} results.csv`"
    )


def _export_folder(folder: Path) -> Path:
    """The export folder, checked before anything is rendered (created when the files are
    written); :class:`OutputPathError` in one line if it cannot take them."""
    return prepare_folder(folder, "FOLDER", create=False)


def _refuse_overwrite(folder: Path, files: dict[str, bytes], force: bool) -> None:
    """Refuse (:class:`OutputPathError`) files of ``folder`` that the export would replace by other
    content, unless ``force``; the same content is no loss."""
    if force:
        return
    clashes = []
    for name, data in files.items():
        path = folder / name
        if os.path.lexists(path):
            try:
                same = path.is_file() and path.read_bytes() == data
            except OSError:
                same = False
            if not same:
                clashes.append(name)
    if clashes:
        listed = ", ".join(sorted(clashes))
        raise OutputPathError(
            f"{folder} already holds {listed}, which the export would overwrite; export into another "
            "folder, or pass --force to overwrite them"
        )


def register(app: typer.Typer) -> None:
    """Add the code-generation commands to the `svbi` app."""
    app.command("generate")(generate)
    app.command("export")(export)
