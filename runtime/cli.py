"""The `svbi` command line (typer).

Each sub-command lives in a small module of its own and is registered here, so that the command
modules stay independent of each other.
"""

from __future__ import annotations

import typer

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
    _register()
    app()


if __name__ == "__main__":  # pragma: no cover
    main()
