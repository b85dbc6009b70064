"""The `svbi` command line (typer).

Each sub-command lives in a small module of its own and is registered here, so that the command
modules stay independent of each other.
"""

from __future__ import annotations

import gc
import os

import typer

BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
"""Set to 1 before NumPy loads, unless the user set them: svbi's dense algebra is on small matrices
(the loop is in C), so a multi-threaded BLAS only keeps spinning threads busy on the other cores:
`svbi run examples/paper-2020.toml` takes 1.40-1.50 s instead of 1.60 s with them, and two runs side
by side on two cores keep 1.85x the throughput of one instead of 1.07x (benchmarks/bench_sweep.py,
section 4). Dask's workers get the same (its ``pre-spawn-environ``)."""
for _name in BLAS_THREADS:
    os.environ.setdefault(_name, "1")

app = typer.Typer(
    name="svbi",
    help="Seismic vehicle-bridge interaction: derive, generate, run and plot.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _register() -> None:
    # Imports are inside the function so that `svbi --help` stays fast and a broken optional
    # module cannot take the whole CLI down.
    from svbi.runtime import cli_model

    cli_model.register(app)
    for name in ("cli_codegen", "cli_run", "cli_plot", "cli_demo", "cli_study"):
        try:
            module = __import__(f"svbi.runtime.{name}", fromlist=["register"])
        except ModuleNotFoundError as exc:
            if exc.name != f"svbi.runtime.{name}":
                raise
            continue
        module.register(app)


def main() -> None:
    """Console-script entry point."""
    # A command is one short process: no cyclic garbage collection. The imports (SciPy, xarray,
    # dask: about 125,000 objects) otherwise trigger full collections over everything loaded so
    # far, about 0.07 s of a 1.45 s `svbi run examples/paper-2020.toml`; the time loop runs in C
    # (or, on NumPy, frees its temporaries by reference counting), so little cyclic garbage is left
    # to reclaim before the process ends. `svbi sweep`, whose client lives as long as the study and
    # runs Dask's event loop, turns collection back on.
    gc.disable()
    _register()
    try:
        app()
    finally:
        # The process ends here. Left alone, the interpreter's shutdown runs cyclic garbage
        # collections over every object of the imported libraries (about 125,000 once SciPy, xarray
        # and dask are loaded: 0.3 s, a quarter of the paper example's loop). Freezing them (a
        # public gc API) skips those passes; objects are still released by reference counting,
        # atexit handlers and weakref finalizers still run, and the results file is already closed.
        gc.freeze()


if __name__ == "__main__":  # pragma: no cover
    main()
