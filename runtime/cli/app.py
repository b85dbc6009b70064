"""The `svbi` command line (typer).

Each sub-command lives in a small module of its own and is registered here, so that the command
modules stay independent of each other.
"""

from __future__ import annotations

import gc
import os
import sys

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


COMMAND_MODULES = {
    "derive": "model",
    "modes": "model",
    "generate": "generate",
    "export": "generate",
    "run": "run",
    "plot": "plot",
    "compare": "plot",
    "demo": "demo",
    "metrics": "study",
    "check": "study",
    "sweep": "study",
}
"""The module of ``svbi.runtime.cli`` that registers each command (tests/run/test_timings.py checks it
against the modules)."""


@app.callback()
def _commands() -> None:
    # A group, also when only one command is registered (main: the one invoked). Every warning of
    # a command is one line, translated or silenced (cli.messages).
    from .messages import install

    install()


def _register(command: str | None = None) -> None:
    """Register the commands: all of them, or the module of ``command`` only (a known command
    invoked: its process does not import and build the others, about 0.015 s)."""
    # Imports are inside the function so that `svbi --help` stays fast and a broken optional
    # module cannot take the whole CLI down.
    names = (
        [COMMAND_MODULES[command]]
        if command in COMMAND_MODULES
        else list(dict.fromkeys(COMMAND_MODULES.values()))
    )
    if "model" in names:
        from . import model as cli_model

        cli_model.register(app)
        names.remove("model")
    for name in names:
        try:
            module = __import__(f"svbi.runtime.cli.{name}", fromlist=["register"])
        except ModuleNotFoundError as exc:
            if exc.name != f"svbi.runtime.cli.{name}":
                raise
            continue
        module.register(app)


def main() -> None:
    """Console-script entry point. `svbi run` ends the process itself (:func:`_end_run`): call
    ``app`` (typer), not ``main``, to run commands inside another Python process."""
    # A command is one short process: no cyclic garbage collection. The imports (SciPy, xarray,
    # dask: about 125,000 objects) otherwise trigger full collections over everything loaded so
    # far, about 0.07 s of a 1.45 s `svbi run examples/paper-2020.toml`; the time loop runs in C
    # (or, on NumPy, frees its temporaries by reference counting), so little cyclic garbage is left
    # to reclaim before the process ends. `svbi sweep`, whose client lives as long as the study and
    # runs Dask's event loop, turns collection back on.
    gc.disable()
    _register(sys.argv[1] if len(sys.argv) > 1 else None)
    try:
        app()
    except SystemExit as exc:
        if sys.argv[1:2] == ["run"]:
            _end_run(exc.code)
        raise
    finally:
        # The process ends here. Left alone, the interpreter's shutdown runs cyclic garbage
        # collections over every object of the imported libraries (about 125,000 once SciPy, xarray
        # and dask are loaded: 0.3 s, a quarter of the paper example's loop). Freezing them (a
        # public gc API) skips those passes; objects are still released by reference counting,
        # atexit handlers and weakref finalizers still run, and the results file is already closed.
        gc.freeze()


def _end_run(code: object) -> None:
    """End `svbi run` without the interpreter's shutdown.

    By then the results file is written and closed (atomically) or nothing is; `svbi run` starts no
    process, thread pool or server that outlives it. The shutdown would only release every object
    and module one by one: 0.025-0.03 s of the paper example's 0.85 s process. The atexit handlers
    still run, the output is flushed, and the exit status is the command's.
    """
    import atexit

    if code is not None and not isinstance(code, int):
        print(code, file=sys.stderr)
        code = 1
    atexit._run_exitfuncs()  # what the shutdown would run first; CPython has no public name for it
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code or 0)


if __name__ == "__main__":  # pragma: no cover
    main()
