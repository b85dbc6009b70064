"""``python -m svbi.runtime.cli``: the ``svbi`` command."""

from .app import main

main()
