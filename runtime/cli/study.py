"""`svbi metrics`, `svbi check` and `svbi sweep`: engineering quantities of one run and of a study.

Exit status: 0 on success (``check``: every limit met), 2 for bad input, 3 when ``check`` finds a
limit exceeded (``sweep``: when runs were lost, e.g. to dead workers, or no worker is alive: run it
again to resume), 4 when a sweep has failed or diverged runs, 130 / 143 when a sweep is interrupted
by SIGINT / SIGTERM (its finished runs are kept).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from ..run.output import RunInterrupted, signals_interrupt
from ..run.results import write_netcdf
from ..scenario.schema import ScenarioError, ScenarioWarning, load_scenario
from ..study.en1990 import CheckOptions, check_set, checks_table, en1990_checks, nan_samples
from ..study.metrics import MetricsError, compute_metrics, metrics_text, scenario_table
from ..study.store_checks import StoreCheckError, check_store, store_text
from ..study.sweep import (
    StudyError,
    SweepError,
    check_store_output,
    dry_run,
    is_store,
    load_study,
    read_store,
    run_sweep,
)
from .messages import echo_caught

if TYPE_CHECKING:
    import xarray as xr

EXIT_INVALID = 2
EXIT_EXCEEDED = 3
EXIT_RUNS_FAILED = 4


def _fail(message: str) -> typer.Exit:
    typer.echo(f"error: {message}", err=True)
    return typer.Exit(EXIT_INVALID)


def _metrics_of(path: Path) -> tuple[xr.Dataset, xr.Dataset]:
    # deferred: plots bring matplotlib (about 0.3 s), which only figures need
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
    results: Annotated[
        Path,
        typer.Argument(metavar="RESULTS", help="Results file of `svbi run`, or a store of `svbi sweep`."),
    ],
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
    maintenance: Annotated[
        str,
        typer.Option(
            "--maintenance",
            help="Track maintenance for the dynamic factor of LM71: careful (Φ2) or standard (Φ3).",
        ),
    ] = "standard",
    alpha: Annotated[
        float, typer.Option("--alpha", help="Classification factor α of LM71 (EN 1991-2 6.3.2(3)).")
    ] = 1.0,
    comfort_l_over_delta: Annotated[
        float | None,
        typer.Option(
            "--comfort-l-over-delta",
            help="L/δ of EN 1990 Figure A2.3 at the line speed, for the comfort check without a car body.",
        ),
    ] = None,
    flange_height: Annotated[
        float, typer.Option("--flange-height", help="Wheel flange height (m) for the uplift check.")
    ] = 0.028,
    prudhomme_alpha: Annotated[
        float,
        typer.Option(
            "--prudhomme-alpha",
            help="α of Prud'homme's track-shift limit α (10 + P0/3) kN (3D runs): 1.0, 0.85 for freight.",
        ),
    ] = 1.0,
    carbody_ay_limit: Annotated[
        float | None,
        typer.Option(
            "--carbody-ay-limit",
            help="Limit of the car-body lateral acceleration (m/s²), 3D runs; without it, for information.",
        ),
    ] = None,
) -> None:
    """EN 1990 Annex A2 checks of a run or of every run of a sweep store (docs/sweep.md).

    A run without an earthquake gets the traffic set (deck acceleration, deflection, end rotations,
    comfort), a run with one the seismic running-safety set. Exit status 0 when every limit is met,
    3 when one is exceeded, 2 on bad input."""
    for value, name in (
        (alpha, "--alpha"),
        (flange_height, "--flange-height"),
        (prudhomme_alpha, "--prudhomme-alpha"),
        (1.0 if carbody_ay_limit is None else carbody_ay_limit, "--carbody-ay-limit"),
    ):
        if not value > 0:
            raise _fail(f"{name} must be greater than 0")
    if comfort_l_over_delta is not None and not comfort_l_over_delta > 0:
        raise _fail("--comfort-l-over-delta must be greater than 0")
    options = CheckOptions(
        track_form,
        comfort,
        maintenance,
        alpha,
        comfort_l_over_delta,
        flange_height,
        prudhomme_alpha,
        carbody_ay_limit,
    )
    if results.exists() and is_store(results):
        _check_store(results, options)
        return
    ds, m = _metrics_of(results)
    try:
        table = scenario_table(ds)
    except MetricsError as exc:
        raise _fail(f"{results}: {exc}") from None
    form = track_form or str(table.get("bridge", {}).get("track_form", "ballasted"))
    moving_load = table.get("train", {}).get("vehicle") == "moving-load"
    try:
        rows = en1990_checks(
            m, form, comfort, moving_load=moving_load, table=table, options=options, nans=nan_samples(ds)
        )
    except ValueError as exc:
        raise _fail(str(exc)) from None
    which, why = check_set(table)
    typer.echo(f"checks of {results}: {which} set ({why})")
    typer.echo(checks_table(rows), nl=False)
    failed = [r for r in rows if r.passed is False]
    invalid = [r for r in failed if r.note.startswith("invalid")]
    if failed:
        parts = [f"{len(failed) - len(invalid)} limit(s) exceeded"] if len(failed) > len(invalid) else []
        parts += [f"{len(invalid)} check(s) invalid: NaN values in the results"] if invalid else []
        typer.echo("; ".join(parts), err=True)
        raise typer.Exit(EXIT_EXCEEDED)


def _check_store(path: Path, options: CheckOptions) -> None:
    """``svbi check STORE``: every run's checks, their envelope and the failing runs."""
    try:
        store = read_store(path)
        report = check_store(store, options)
    except (StoreCheckError, ValueError, OSError) as exc:
        raise _fail(f"{path}: {exc}" if str(path) not in str(exc) else str(exc)) from None
    typer.echo(store_text(report, str(path)), nl=False)
    if report.failed:
        typer.echo("limit(s) exceeded or runs without results", err=True)
        raise typer.Exit(EXIT_EXCEEDED)


def sweep(
    study: Annotated[Path, typer.Argument(metavar="STUDY.toml", help="Study file (docs/sweep.md).")],
    output: Annotated[
        str,
        typer.Option("--output", "-o", help="Store to write: NetCDF (a name ending in .nc) or Zarr (.zarr)."),
    ],
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
    set_: Annotated[
        list[str] | None,
        typer.Option(
            "--set",
            help="Override a key of the base scenario in every run, e.g. --set solver.duration=2.0 "
            "(a TOML literal, else text; an axis's value wins). Repeatable.",
        ),
    ] = None,
    dry_run_: Annotated[
        bool,
        typer.Option(
            "--dry-run",
            help="Run one probe run and print the runs, the time, disk and memory the study needs; "
            "write nothing.",
        ),
    ] = False,
    worker_timeout: Annotated[
        float,
        typer.Option(
            "--worker-timeout",
            help="With --scheduler: seconds to wait for a worker (at the start, or when all are gone).",
        ),
    ] = 60.0,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
) -> None:
    """Run a study (a scenario over axes of its keys) on Dask: metrics per run in one store.

    Finished runs are kept in OUT.parts/; running the same command again resumes (docs/sweep.md).

    Exit status: 0 all ok; 2 bad input, output path or too little disk (nothing run);
    3 runs lost or no worker alive (run again); 4 failed or diverged runs; 130 / 143 interrupted."""
    import gc
    import shlex
    import sys

    gc.enable()  # the client runs as long as the study, on Dask's event loop (cli.main turned it off)
    if workers is not None and workers < 1:
        raise _fail("--workers must be at least 1")
    if worker_timeout <= 0:
        raise _fail("--worker-timeout must be positive")
    try:
        st = load_study(study, set_ or [])
    except StudyError as exc:
        raise _fail(str(exc)) from None
    _base_warnings(st.scenario_path)
    try:
        out = check_store_output(output, st)
    except SweepError as exc:
        raise _fail(str(exc)) from None
    if dry_run_:
        try:
            est = dry_run(st, out, workers)
        except KeyboardInterrupt:
            typer.echo("interrupted: nothing written", err=True)
            raise typer.Exit(130) from None
        typer.echo(f"study {study} -> {out} (dry run: nothing written)")
        typer.echo(est.text(), nl=False)
        if not est.fits:
            typer.echo("error: the study would not fit on the disk", err=True)
            raise typer.Exit(EXIT_INVALID)
        return
    command = "svbi " + " ".join(shlex.quote(a) for a in sys.argv[1:]) if sys.argv[1:] else ""
    with signals_interrupt():  # SIGTERM, like Ctrl-C, stops the sweep cleanly
        try:
            report = run_sweep(
                st,
                out,
                workers=workers,
                scheduler=scheduler,
                progress=not quiet,
                worker_timeout=worker_timeout,
                command=command,
            )
        except SweepError as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(exc.exit_code) from None
        except KeyboardInterrupt as exc:
            name = exc.signal_name if isinstance(exc, RunInterrupted) else "SIGINT"
            code = exc.exit_code if isinstance(exc, RunInterrupted) else 130
            typer.echo(
                f"interrupted by {name}: the finished runs are kept in {out}.parts; "
                "run the same command to resume",
                err=True,
            )
            raise typer.Exit(code) from None
    counts = ", ".join(f"{n} {s}" for s, n in sorted(report.statuses.items()))
    typer.echo(
        f"wrote {report.store}: {report.total} runs ({counts}); ran {report.ran}, "
        f"{report.reused} found finished in {report.store}.parts"
    )
    if report.statuses.get("missing"):
        typer.echo(
            f"{report.statuses['missing']} of {report.total} runs were lost: "
            "run the same command again to resume",
            err=True,
        )
        raise typer.Exit(EXIT_EXCEEDED)
    bad = {s: report.statuses.get(s, 0) for s in ("failed", "diverged")}
    if any(bad.values()):
        what = " and ".join(f"{n} of {report.total} runs {s}" for s, n in bad.items() if n)
        typer.echo(f"{what}: see status and message in {report.store}", err=True)
        raise typer.Exit(EXIT_RUNS_FAILED)


def _base_warnings(path: Path) -> None:
    """The study's base scenario's warnings (a coarse time step, a value outside the usual bands),
    printed once before the runs (whose own loads are silent)."""
    import warnings

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
