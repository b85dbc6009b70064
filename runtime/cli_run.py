"""`svbi run SCENARIO -o OUT.nc [--set key.path=value ...]`: run a scenario, write the results.

Exit status: 0 on success, 2 for an invalid scenario or option, 3 when the run diverged (the partial
results are still written, marked ``complete = 0``).
"""

from __future__ import annotations

import time
import warnings
from pathlib import Path
from typing import Annotated

import typer

EXIT_INVALID = 2
EXIT_DIVERGED = 3


def run(
    scenario: Annotated[Path, typer.Argument(help="Scenario file (TOML, DESIGN.md section 3).")],
    output: Annotated[Path, typer.Option("--output", "-o", help="Results file to write (NetCDF).")],
    set_: Annotated[
        list[str] | None,
        typer.Option(
            "--set",
            help="Override a scenario key: --set solver.method=coupled-dynamic "
            "(the value is read as a TOML literal, else as text). Repeatable.",
        ),
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bar.")] = False,
) -> None:
    """Run a scenario and write its results atomically to a NetCDF file."""
    started = time.perf_counter()  # set-up counts from here: the scenario load is part of it
    from svbi.runtime.results import write_netcdf
    from svbi.runtime.scenario import ScenarioError, ScenarioWarning, load_scenario
    from svbi.runtime.simulate import SimulationIncomplete, simulate

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            sc = load_scenario(scenario, overrides=set_ or [])
        except ScenarioError as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(EXIT_INVALID) from None
    for w in caught:
        if issubclass(w.category, ScenarioWarning):
            typer.echo(f"warning: {w.message}", err=True)

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            ds = simulate(sc, progress=not quiet, clock_start=started)
        except (ValueError, NotImplementedError, FileNotFoundError) as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(EXIT_INVALID) from None
    for w in caught:
        if not issubclass(w.category, SimulationIncomplete):
            typer.echo(f"warning: {w.message}", err=True)

    path = write_netcdf(ds, output)
    attrs = ds.attrs
    if not attrs.get("complete", 1):
        typer.echo(f"error: {attrs.get('incomplete', 'run did not complete')}", err=True)
        typer.echo(f"partial results written to {path}", err=True)
        raise typer.Exit(EXIT_DIVERGED)
    if not quiet:
        typer.echo(
            f"wrote {path}: {attrs['steps']} steps of {attrs['time_step']:g} s, {attrs['method']} "
            f"({attrs['backend']})"
        )
        typer.echo(timing_line(attrs))
        if attrs.get("liftoffs"):
            typer.echo(
                f"wheels lifted off {attrs['liftoffs']} times: longest flight "
                f"{attrs['longest_flight_s']:.4g} s, peak uplift {1e3 * attrs['peak_uplift_m']:.3g} mm "
                f"(t = {attrs['peak_uplift_time']:.4g} s, car {attrs['peak_uplift_car']}, wheel "
                f"{attrs['peak_uplift_wheel']})"
            )


def timing_line(attrs: dict) -> str:
    """One short line: set-up, loop and total seconds of a run (results attributes)."""
    return (
        f"time: set-up {attrs['setup_time_s']:.2f} s, loop {attrs['loop_time_s']:.2f} s, "
        f"total {attrs['wall_time_s']:.2f} s"
    )


def register(app: typer.Typer) -> None:
    app.command("run")(run)
