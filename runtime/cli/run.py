"""`svbi run SCENARIO -o OUT.nc [--set key.path=value ...]`: run a scenario, write the results.

Exit status: 0 on success; 2 for an invalid scenario, option or output path, or a run above the memory
limit (all found before anything is computed); 3 when the run diverged; 4 when the results could not
be written (full disk...; the previous file is kept); 130 / 143 / 129 when SIGINT (Ctrl-C) /
SIGTERM / SIGHUP stopped it. Incomplete results (diverged or interrupted) are written to
``<stem>.incomplete.nc``, marked ``complete = 0``, never onto the ``-o`` file.
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path
from typing import Annotated

import typer

from ..run.memory import check_memory
from ..run.output import (
    RunInterrupted,
    check_output,
    incomplete_path,
    run_inputs,
    signal_name,
    signals_interrupt,
)
from ..run.results import write_netcdf
from ..run.results3d import summary_lines
from ..run.simulate import SimulationIncomplete, simulate
from ..scenario.schema import ScenarioError, ScenarioWarning, load_scenario
from .messages import echo_caught

EXIT_INVALID = 2
EXIT_DIVERGED = 3
EXIT_WRITE = 4
NETCDF_MODULES = ("netCDF4", "xarray.backends.netCDF4_", "dask.distributed")
"""What ``results.write_netcdf`` imports: loaded while the loop runs (``simulate(import_ahead=...)``).
``dask.distributed`` (0.25 s): xarray's writer asks whether a distributed scheduler is active
(``xarray.backends.locks.get_dask_scheduler``) by importing it whenever dask is installed."""


def run(
    scenario: Annotated[Path, typer.Argument(help="Scenario file (TOML, docs/scenario.md).")],
    output: Annotated[
        str,
        typer.Option(
            "--output",
            "-o",
            help="Results file to write (NetCDF, name ending in .nc). Incomplete results (a diverged "
            "or interrupted run) go to <stem>.incomplete.nc instead.",
        ),
    ],
    set_: Annotated[
        list[str] | None,
        typer.Option(
            "--set",
            help="Override a scenario key: --set solver.method=coupled-dynamic "
            "(the value is read as a TOML literal, else as text). Repeatable.",
        ),
    ] = None,
    max_memory: Annotated[
        str | None,
        typer.Option(
            "--max-memory",
            help="Refuse a run whose estimated memory is above this (e.g. 8GiB, 500MB); default: "
            "half of the memory available when the run starts.",
        ),
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
) -> None:
    """Run a scenario and write its results atomically to a NetCDF file.

    Exit status: 0 done; 2 invalid scenario, option or output path, or a run too large for the
    memory limit (nothing computed); 3 the run diverged; 4 the results could not be written (the
    previous file is kept); 130 / 143 / 129 interrupted by SIGINT (Ctrl-C) / SIGTERM / SIGHUP.
    """
    started = time.perf_counter()  # set-up counts from here: the scenario load is part of it
    with (
        signals_interrupt()
    ):  # from here on SIGTERM and SIGHUP, like Ctrl-C, unwind: finally clauses clean up
        try:
            _run(scenario, output, set_ or [], max_memory, quiet, started)
        except RunInterrupted as exc:  # before or after the loop: no results to keep
            typer.echo(f"error: interrupted by {exc.signal_name}; nothing written", err=True)
            raise typer.Exit(exc.exit_code) from None
        except KeyboardInterrupt as exc:  # Python's own Ctrl-C (SIGINT inherited as ignored: never)
            typer.echo(f"error: interrupted by {signal_name(exc)}; nothing written", err=True)
            raise typer.Exit(130) from None


def _run(
    scenario: Path, output: str, set_: list[str], max_memory: str | None, quiet: bool, started: float
) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            sc = load_scenario(scenario, overrides=set_)
        except ScenarioError as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(EXIT_INVALID) from None
    echo_caught([w for w in caught if issubclass(w.category, ScenarioWarning)])
    try:  # before anything is computed: a bad path would otherwise lose the whole run
        path = check_output(output, run_inputs(sc))
        if sc.dimensions == 2:  # the estimate is the 2D loop's; a 3D run's refusals come first
            check_memory(sc, max_memory)
    except ValueError as exc:  # OutputPathError, MemoryLimitError
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(EXIT_INVALID) from None

    try:
        ds = _simulate(sc, quiet, started)
    except RunInterrupted as exc:
        if exc.results is None:
            raise
        partial = _write(exc.results, incomplete_path(path), exc.results.attrs["incomplete"])
        typer.echo(
            f"error: {exc.results.attrs['incomplete']}; partial results written to {partial}", err=True
        )
        raise typer.Exit(exc.exit_code) from None

    attrs = ds.attrs
    complete = bool(attrs.get("complete", 1))
    cause = "" if complete else str(attrs.get("incomplete", "run did not complete"))
    written = _write(ds, path if complete else incomplete_path(path), cause)
    if not complete:
        typer.echo(
            f"error: {attrs.get('incomplete', 'run did not complete')}; partial results written to {written}",
            err=True,
        )
        raise typer.Exit(EXIT_DIVERGED)
    if not quiet:
        typer.echo(
            f"wrote {written}: {attrs['steps']} steps of {attrs['time_step']:g} s, {attrs['method']} "
            f"({attrs['backend']})"
        )
        typer.echo(timing_line(attrs))
        if attrs.get("liftoffs"):
            typer.echo(
                f"wheels lift off: peak uplift {1e3 * attrs['peak_uplift_m']:.3g} mm "
                f"(t = {attrs['peak_uplift_time']:.4g} s, car {attrs['peak_uplift_car']}, wheel "
                f"{attrs['peak_uplift_wheel']}), longest flight {attrs['longest_flight_s']:.4g} s, "
                f"{attrs.get('airborne_time_s', 0.0):.4g} s airborne over all wheels"
            )
        for line in summary_lines(attrs):  # a 3D run's running safety (none for a 2D run)
            typer.echo(line)
        if "pier_drift" in ds:  # a bridge with piers: the largest drift of a pier top over its base
            import numpy as np

            drift = np.abs(ds["pier_drift"].transpose("time", "pier").values)
            k, i = np.unravel_index(int(np.argmax(drift)), drift.shape)
            typer.echo(
                f"pier drift: peak {1e3 * float(drift[k, i]):.3g} mm (pier {i + 1} = bridge.piers[{i}], "
                f"on support line {int(ds['pier_line'].values[i])}, t = {float(ds['time'].values[k]):.4g} s)"
            )


def _simulate(sc, quiet: bool, started: float):  # noqa: ANN001, ANN202 - Scenario -> Dataset, lazily imported
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            ds = simulate(sc, progress=not quiet, clock_start=started, import_ahead=NETCDF_MODULES)
        except (ValueError, NotImplementedError, FileNotFoundError) as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(EXIT_INVALID) from None
    echo_caught([w for w in caught if not issubclass(w.category, SimulationIncomplete)])
    return ds


def _write(ds, path: Path, cause: str = "") -> Path:  # noqa: ANN001 - xarray.Dataset, imported lazily
    """Write the results atomically; a failed write (full disk...) or a signal during it is one line,
    and whatever was at ``path`` before stays. ``cause``: why the run is incomplete (partial
    results), reported with the failed write so that it is not lost."""
    first = f"error: {cause}; " if cause else "error: "
    try:
        return write_netcdf(ds, path)
    except OSError as exc:
        reason = exc.strerror or str(exc)
        kept = "the previous file is kept" if path.exists() else "nothing written"
        what = "partial results to " if cause else ""
        typer.echo(f"{first}cannot write {what}{path}: {reason}; {kept}", err=True)
        raise typer.Exit(EXIT_WRITE) from None
    except RunInterrupted as exc:
        if getattr(exc, "written", None) is not None:  # the signal came just after the rename
            typer.echo(f"{first}interrupted by {exc.signal_name} after writing {path}", err=True)
        else:  # during the write: acted on before the rename (run.atomic), nothing replaced
            kept = "the previous file is kept" if path.exists() else "nothing written"
            typer.echo(f"{first}interrupted by {exc.signal_name} while writing {path}; {kept}", err=True)
        raise typer.Exit(exc.exit_code) from None


def timing_line(attrs: dict) -> str:
    """One short line: set-up, loop and total seconds of a run (results attributes)."""
    return (
        f"time: set-up {attrs['setup_time_s']:.2f} s, loop {attrs['loop_time_s']:.2f} s, "
        f"total {attrs['wall_time_s']:.2f} s"
    )


def register(app: typer.Typer) -> None:
    app.command("run")(run)
