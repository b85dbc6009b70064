"""``python -m svbi.runtime.cli``: the ``svbi`` command."""

from svbi.runtime.cli.app import main

main()
