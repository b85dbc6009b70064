"""`svbi metrics`, `svbi check` and `svbi sweep`: engineering quantities of one run and of a study.

Exit status: 0 on success (``check``: every limit met), 2 for bad input, 3 when ``check`` finds a
limit exceeded (``sweep``: when runs were lost, e.g. to dead workers: run it again to resume), 130
when a sweep is interrupted (its finished runs are kept).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from ..run.results import write_netcdf
from ..study.en1990 import checks_table, en1990_checks, nan_samples
from ..study.metrics import MetricsError, compute_metrics, metrics_text, scenario_table
from ..study.sweep import StudyError, load_study, run_sweep

if TYPE_CHECKING:
    import xarray as xr

EXIT_INVALID = 2
EXIT_EXCEEDED = 3


def _fail(message: str) -> typer.Exit:
    typer.echo(f"error: {message}", err=True)
    return typer.Exit(EXIT_INVALID)


def _metrics_of(path: Path) -> tuple[xr.Dataset, xr.Dataset]:
    from ..plots.results import ResultsFileError, read_results

    try:
        ds = read_results(path)
        return ds, compute_metrics(ds)
    except (ResultsFileError, MetricsError) as exc:
        raise _fail(f"{path}: {exc}" if str(path) not in str(exc) else str(exc)) from None


def metrics(
    results: Annotated[Path, typer.Argument(metavar="RESULTS.nc", help="Results file of `svbi run`.")],
    output: Annotated[
        Path | None, typer.Option("--output", "-o", help="Also write the metrics to this NetCDF file.")
    ] = None,
) -> None:
    """Print the engineering metrics of one run (peaks, when and where; docs/sweep.md)."""
    _, m = _metrics_of(results)
    if output is not None:
        write_netcdf(m, output)
    typer.echo(f"metrics of {results}")
    typer.echo(metrics_text(m), nl=False)


def check(
    results: Annotated[Path, typer.Argument(metavar="RESULTS.nc", help="Results file of `svbi run`.")],
    track_form: Annotated[
        str | None,
        typer.Option(
            "--track-form",
            help="ballasted (3.5 m/s²) or direct (5 m/s²); default: the scenario's bridge.track_form.",
        ),
    ] = None,
    comfort: Annotated[
        str,
        typer.Option(
            "--comfort", help="Comfort level required: very-good (1.0), good (1.3), acceptable (2.0)."
        ),
    ] = "acceptable",
) -> None:
    """EN 1990 Annex A2 checks of one run: value, limit, where, when, pass or fail.

    Exit status 0 when every limit is met, 3 when one is exceeded, 2 on bad input."""
    ds, m = _metrics_of(results)
    try:
        table = scenario_table(ds)
    except MetricsError as exc:
        raise _fail(f"{results}: {exc}") from None
    form = track_form or str(table.get("bridge", {}).get("track_form", "ballasted"))
    moving_load = table.get("train", {}).get("vehicle") == "moving-load"
    try:
        rows = en1990_checks(m, form, comfort, moving_load=moving_load, nans=nan_samples(ds))
    except ValueError as exc:
        raise _fail(str(exc)) from None
    typer.echo(f"EN 1990 Annex A2 checks of {results}")
    typer.echo(checks_table(rows), nl=False)
    failed = [r for r in rows if r.passed is False]
    invalid = [r for r in failed if r.note.startswith("invalid")]
    if failed:
        parts = [f"{len(failed) - len(invalid)} limit(s) exceeded"] if len(failed) > len(invalid) else []
        parts += [f"{len(invalid)} check(s) invalid: NaN values in the results"] if invalid else []
        typer.echo("; ".join(parts), err=True)
        raise typer.Exit(EXIT_EXCEEDED)


def sweep(
    study: Annotated[Path, typer.Argument(metavar="STUDY.toml", help="Study file (docs/sweep.md).")],
    output: Annotated[Path, typer.Option("--output", "-o", help="Store to write (NetCDF).")],
    workers: Annotated[
        int | None,
        typer.Option(
            "--workers", "-w", help="Worker processes of the local cluster (default: one per core)."
        ),
    ] = None,
    scheduler: Annotated[
        str | None,
        typer.Option("--scheduler", help="Address of a running Dask scheduler, e.g. tcp://host:8786."),
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
) -> None:
    """Run a study (a scenario over axes of its keys) on Dask: metrics per run in one store.

    Finished runs are kept in OUT.parts/; running the same command again resumes (docs/sweep.md)."""
    import gc

    gc.enable()  # the client runs as long as the study, on Dask's event loop (cli.main turned it off)
    if workers is not None and workers < 1:
        raise _fail("--workers must be at least 1")
    try:
        st = load_study(study)
    except StudyError as exc:
        raise _fail(str(exc)) from None
    _base_warnings(st.scenario_path)
    try:
        report = run_sweep(st, output, workers=workers, scheduler=scheduler, progress=not quiet)
    except KeyboardInterrupt:
        typer.echo(
            f"interrupted: the finished runs are kept in {output}.parts; run the same command to resume",
            err=True,
        )
        raise typer.Exit(130) from None
    counts = ", ".join(f"{n} {s}" for s, n in sorted(report.statuses.items()))
    typer.echo(
        f"wrote {report.store}: {report.total} runs ({counts}); ran {report.ran}, "
        f"{report.reused} found finished in {report.store}.parts"
    )
    if report.statuses.get("missing"):
        typer.echo("some runs were lost: run the same command again to resume", err=True)
        raise typer.Exit(EXIT_EXCEEDED)


def _base_warnings(path: Path) -> None:
    """The study's base scenario's warnings (a coarse time step, a value outside the usual bands),
    printed once before the runs (whose own loads are silent)."""
    import warnings

    from ..scenario.schema import ScenarioError, ScenarioWarning, load_scenario
    from .messages import echo_caught

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            load_scenario(path)
        except ScenarioError:
            return  # a base scenario that only the axes make valid: each run reports its own
    echo_caught([w for w in caught if issubclass(w.category, ScenarioWarning)])


def register(app: typer.Typer) -> None:
    app.command("metrics")(metrics)
    app.command("check")(check)
    app.command("sweep")(sweep)
