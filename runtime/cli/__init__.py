"""The ``svbi`` command line: :mod:`.app` (the Typer app and its entry point) and one module per
group of commands."""
