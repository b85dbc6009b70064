"""`svbi demo`: the paper's numerical application with all three methods, results and figures.

Runs the embedded example ``paper-2020.toml`` (10 Pioneer cars, ten 32 m spans, 300 km/h, German
low-interference irregularities, synthetic earthquake) with ``localized-dynamic``,
``coupled-dynamic`` and ``coupled-classic``, and writes into the output folder: one NetCDF results
file per method, the figures of the paper's Fig. 4 with the three methods overlaid, the constraint
violations, and ``summary.txt`` (peaks, max gaps, set-up, loop and wall times, and the methods'
loop-time ratios: the first run also pays one-time set-up costs, so loop time is the fair speed).

Then a strong-shaking run (``strong-shaking.nc``, figures in ``strong-shaking-figures/``): the same
example with unilateral contact under the synthetic vertical record scaled to 2 g (no longitudinal
component), localized-dynamic, where wheels lift off and land again (docs/method.md section 12).

Last a 3D run (``three-d.nc``, figures in ``three-d-figures/``): the first second of
``paper-2020-3d.toml``, ten 3D cars entering the bridge as a three-component synthetic earthquake
arrives, with the lateral response and the running-safety indices (Y/Q, ΣY, ΔQ/Q, flange contacts;
docs/three-d.md).
"""

from __future__ import annotations

import time
import warnings
from importlib import resources
from pathlib import Path
from typing import Annotated, Any

import typer

from ..run.atomic import write_atomic
from ..run.output import OutputPathError, prepare_folder
from ..run.results import write_netcdf
from ..run.simulate import SimulationIncomplete, simulate
from ..scenario.schema import ScenarioError, load_scenario
from .messages import echo_caught

METHODS = ("localized-dynamic", "coupled-dynamic", "coupled-classic")
EXAMPLE = "paper-2020.toml"
QUICK = (
    "train.cars=2",
    "bridge.spans=2",
    "solver.time_step=5.0e-4",
)
"""--quick: 2 cars on 2 spans at a coarser step, so the whole demo takes well under a minute."""
STRONG = (
    "contact.normal=unilateral",
    'earthquake.vertical="synthetic"',
    'earthquake.longitudinal="none"',
    "earthquake.target_pga=19.62",
    "solver.method=localized-dynamic",
)
"""The strong-shaking run: the example under a 2 g vertical synthetic record, wheels free to lift off."""
STRONG_NAME = "strong-shaking"
EXAMPLE_3D = "paper-2020-3d.toml"
THREE_D_NAME = "three-d"
THREE_D_DURATION = 1.0
"""Simulated time of the demo's 3D run (s): the train enters the bridge at 0.36 s with the earthquake."""
THREE_D_QUICK = 0.4
"""... and of --quick's."""


def example_path(name: str = EXAMPLE) -> Path:
    """Path of an example scenario shipped with svbi."""
    return Path(str(resources.files("svbi.examples").joinpath(name)))


def demo(
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder.")] = Path("svbi-demo"),
    quick: Annotated[bool, typer.Option("--quick", help="2 cars, 2 spans, dt = 5e-4 s (CI-sized).")] = False,
    backend: Annotated[str | None, typer.Option(help="Override solver.backend (numpy, casadi, c).")] = None,
    scenario: Annotated[
        Path | None, typer.Option(help="Run this scenario file instead of the built-in paper example.")
    ] = None,
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="No progress bars.")] = False,
) -> None:
    """Run the paper example with the three methods; write results, figures and a summary."""
    # deferred: plots bring matplotlib (about 0.3 s), which only figures need
    from ..plots.results import plot_results, summary_text

    path = scenario or example_path()
    overrides = list(QUICK) if quick else []
    if quick and scenario is None:
        overrides.append('title="Paper 2020, quick: 2 Pioneer cars, 2 x 32 m spans, 300 km/h, dt = 5e-4 s"')
    if backend:
        overrides.append(f"solver.backend={backend}")
    try:  # before anything runs: an existing file or an uncreatable folder is one line
        prepare_folder(out, "-o")
    except OutputPathError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    results = {}
    for method in METHODS:
        started = time.perf_counter()  # set-up counts from the scenario load
        try:
            extra = [f"solver.method={method}"]
            if method == "coupled-classic":
                # Its drift is what the comparison shows: let it run to the end instead of stopping
                # it at the default divergence guard of 1 m.
                extra.append("solver.max_gap=1000.0")
            sc = load_scenario(path, overrides=[*overrides, *extra])
        except ScenarioError as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(2) from None
        typer.echo(f"{method}: {sc.title}")
        ds, written = _simulate(sc, quiet, started, out / f"{method}.nc", keep_incomplete=False)
        status = "" if ds.attrs.get("complete", 1) else f"  (stopped: {ds.attrs.get('incomplete', '')})"
        a = ds.attrs
        typer.echo(
            f"  {written}: {a['steps']} steps, set-up {a['setup_time_s']:.2f} s, loop "
            f"{a['loop_time_s']:.2f} s, wall {a['wall_time_s']:.2f} s{status}"
        )
        results[method] = ds
    figures = plot_results(results, out / "figures")
    summary = summary_text(results)
    # the synthetic record's strong phase starts at 2 s (docs/excitations.md): the quick crossing
    # (1.6 s) would end before it, so that run goes on with the train on the approach track
    strong = _strong_shaking(
        path, [*overrides, *(["solver.duration=4.0"] if quick else [])], backend, out, quiet
    )
    summary += "\n" + strong
    if scenario is None:  # the 3D run shows the built-in 3D example
        summary += "\n" + _three_d(backend, out, quiet, THREE_D_QUICK if quick else THREE_D_DURATION)
    write_atomic(out / "summary.txt", lambda tmp: tmp.write_text(summary + "\n", encoding="utf-8"))
    typer.echo("\n" + summary)
    typer.echo(f"\n{len(figures)} figures in {out / 'figures'}; summary in {out / 'summary.txt'}")


def _simulate(
    sc: Any, quiet: bool, started: float, path: Path, keep_incomplete: bool = True
) -> tuple[Any, Path]:
    """Run ``sc``, print the warnings it gave (a stopped run's own warning left out when
    ``keep_incomplete`` is false: the summary line says it) and write its results to ``path``;
    returns the results and the file written."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ds = simulate(sc, progress=not quiet, clock_start=started)
    if not keep_incomplete:
        caught = [w for w in caught if not issubclass(w.category, SimulationIncomplete)]
    echo_caught(caught, "  ")
    return ds, write_netcdf(ds, path)


def _strong_shaking(path: Path, overrides: list[str], backend: str | None, out: Path, quiet: bool) -> str:
    """The strong-shaking run (module docstring); returns its summary text."""
    # deferred: plots bring matplotlib (about 0.3 s), which only figures need
    from ..plots.results import plot_results, summary_text

    extra = list(STRONG)
    started = time.perf_counter()
    sc = load_scenario(path, overrides=[*overrides, *extra])
    typer.echo(f"{STRONG_NAME}: {sc.title}, unilateral contact, 2 g vertical synthetic record")
    ds, written = _simulate(sc, quiet, started, out / f"{STRONG_NAME}.nc")
    a = ds.attrs
    typer.echo(
        f"  {written}: {a['steps']} steps, loop {a['loop_time_s']:.2f} s; peak uplift "
        f"{1e3 * a['peak_uplift_m']:.3g} mm, longest flight {a['longest_flight_s']:.4g} s, "
        f"{a.get('airborne_time_s', 0.0):.4g} s airborne over all wheels"
    )
    label = f"{STRONG_NAME} (2 g vertical)"
    plot_results({label: ds}, out / f"{STRONG_NAME}-figures")
    return summary_text({label: ds})


def _three_d(backend: str | None, out: Path, quiet: bool, duration: float) -> str:
    """The 3D run (module docstring); returns its summary text."""
    # deferred: plots bring matplotlib (about 0.3 s), which only figures need
    from ..plots.results import plot_results
    from ..run.results3d import summary_lines

    started = time.perf_counter()
    overrides = [f"solver.duration={duration}", *([f"solver.backend={backend}"] if backend else [])]
    sc = load_scenario(example_path(EXAMPLE_3D), overrides=overrides)
    typer.echo(f"{THREE_D_NAME}: {sc.title}, {1e3 * duration:g} ms")
    ds, written = _simulate(sc, quiet, started, out / f"{THREE_D_NAME}.nc")
    a = ds.attrs
    typer.echo(
        f"  {written}: {a['steps']} steps, set-up {a['setup_time_s']:.2f} s, loop {a['loop_time_s']:.2f} s"
    )
    plot_results({THREE_D_NAME: ds}, out / f"{THREE_D_NAME}-figures")
    lines = [f"{THREE_D_NAME} ({sc.title}):", *(f"  {line}" for line in summary_lines(dict(a)))]
    return "\n".join(lines)


def register(app: typer.Typer) -> None:
    app.command("demo")(demo)
