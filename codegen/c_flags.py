"""The C warning policy of everything svbi compiles, in a module with no CasADi or Jinja2 import
(the C time loop's run-time path reads it).

Generated and static C compiles with ``-std=c99 -Wall -Wextra -Werror``. CasADi's evaluation
functions all share the signature ``(arg, res, iw, w, mem)`` and an SX function without integer
work or memory never reads ``iw`` and ``mem``; CasADi 3.8 has no option to mark them unused, so
``-Wunused-parameter`` is switched off for CasADi's generated files (``svbi.codegen.c_emit``).
"""

from __future__ import annotations

CASADI_WARNING_EXCEPTION = "-Wno-unused-parameter"
"""The one warning switched off, for CasADi's generated files only."""
STRICT_FLAGS = ("-std=c99", "-Wall", "-Wextra", "-Werror")
