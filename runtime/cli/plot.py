"""`svbi plot` and `svbi compare`: the paper's Fig. 4 panels and a summary from results files."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import typer

from ..run.atomic import write_atomic
from ..run.output import OutputPathError, prepare_folder
from ..study.store import is_store, read_store

if TYPE_CHECKING:
    import xarray as xr

SUMMARY_NAME = "summary.txt"


def _read(paths: list[Path]) -> list[xr.Dataset]:
    # matplotlib and xarray load here, not when the CLI starts (every `svbi` command registers us)
    from ..plots.results import ResultsFileError, read_results

    try:
        return [read_results(p) for p in paths]
    except ResultsFileError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None


def _prepare(out_dir: Path) -> None:
    """Create the figures' folder, or refuse it in one line (exit 2)."""
    try:
        prepare_folder(out_dir, "-o")
    except OutputPathError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None


def _draw(paths: list[Path], out_dir: Path) -> None:
    # deferred: plots bring matplotlib (about 0.3 s), which only figures need
    from ..plots.results import default_labels, plot_results, summary_text

    datasets = _read(paths)
    _prepare(out_dir)
    results = dict(zip(default_labels(datasets, [p.stem for p in paths]), datasets, strict=True))
    written = plot_results(results, out_dir)
    text = summary_text(results)
    summary = out_dir / SUMMARY_NAME
    write_atomic(summary, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    for path in [*written, summary]:
        typer.echo(f"wrote {path}")
    typer.echo("")
    typer.echo(text, nl=False)


def plot(
    results: Path = typer.Argument(
        ..., metavar="RESULTS.nc", help="Results NetCDF file written by `svbi run`, or a `svbi sweep` store."
    ),
    out: Path | None = typer.Option(
        None, "--out", "-o", help="Folder for the figures (default: <stem>-figures/ next to the file)."
    ),
    metric: str = typer.Option("peak_deck_acceleration", "--metric", help="Sweep: the metric to draw."),
    axis: str | None = typer.Option(None, "--axis", help="Sweep: the x axis (default: the speed axis)."),
    by: str | None = typer.Option(None, "--by", help="Sweep: one curve per value of this axis."),
    limit: float | None = typer.Option(None, "--limit", help="Sweep: limit line / fragility threshold."),
    intensity: str | None = typer.Option(
        None, "--intensity", help="Sweep: intensity axis of the fragility curve (default: earthquake.scale)."
    ),
) -> None:
    """Figures of a results file (Fig. 4 panels, gaps, summary) or of a sweep store (metric, fragility)."""
    out_dir = out if out is not None else results.with_name(f"{results.stem}-figures")
    if is_store(results):
        _draw_store(results, out_dir, metric, axis, by, limit, intensity)
        return
    _draw([results], out_dir)


def _draw_store(
    path: Path,
    out_dir: Path,
    metric: str,
    axis: str | None,
    by: str | None,
    limit: float | None,
    intensity: str | None,
) -> None:
    # deferred: plots bring matplotlib (about 0.3 s), which only figures need
    from ..plots.study import plot_store

    _prepare(out_dir)
    try:
        written, text = plot_store(read_store(path), out_dir, metric, axis, by, limit, intensity)
    except ValueError as exc:
        typer.echo(f"error: {path}: {exc}", err=True)
        raise typer.Exit(2) from None
    summary = out_dir / SUMMARY_NAME
    write_atomic(summary, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    for p in [*written, summary]:
        typer.echo(f"wrote {p}")
    typer.echo(text, nl=False)


def compare(
    results: list[Path] = typer.Argument(
        ..., metavar="A.nc B.nc [MORE.nc...]", help="Two or more results NetCDF files to overlay."
    ),
    out: Path | None = typer.Option(
        None,
        "--out",
        "-o",
        help="Folder for the figures (default: <first stem>-compare-figures/ next to the first file).",
    ),
) -> None:
    """Overlay two or more results files (e.g. the three methods) on the Fig. 4 panels."""
    if len(results) < 2:
        typer.echo("error: compare needs at least two results files (use `svbi plot` for one)", err=True)
        raise typer.Exit(2)
    first = results[0]
    _draw(results, out if out is not None else first.with_name(f"{first.stem}-compare-figures"))


def register(app: typer.Typer) -> None:
    app.command("plot")(plot)
    app.command("compare")(compare)
