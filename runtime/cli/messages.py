"""Warnings as the command line prints them: one line each, ``warning: ...``, once, no source lines.

svbi's own warnings (a coarse time step, a value outside the usual bands) are printed as they are.
Warnings of the libraries underneath (SciPy, NumPy, Dask) are translated into what they mean for
the run, or silenced where they mean nothing to act on (:data:`SILENCED`, each with its reason).
"""

from __future__ import annotations

import re
import sys
import warnings
from typing import Any, TextIO

SILENCED: tuple[tuple[str, str], ...] = (
    (
        r"Port \d+ is already in use",
        "Dask's dashboard or scheduler port is taken (another Dask on this machine): Dask picks a "
        "free port itself, and svbi uses no port it would have to tell the user about",
    ),
)
"""(pattern of the message, why it is not shown) of the library warnings never printed."""

TRANSLATED: tuple[tuple[str, str, str], ...] = (
    (
        "LinAlgWarning",
        r"",
        "a linear system of the model is ill-conditioned ({message}): the results may be inaccurate; "
        "check the scenario's values for a unit slip (svbi warns on values outside the usual bands)",
    ),
    (
        "RuntimeWarning",
        r"All-NaN (slice|axis) encountered",
        "a quantity is NaN (not a number) everywhere it was looked at: its peak is NaN; the run's "
        "values or the results file are not valid numbers",
    ),
    (
        "RuntimeWarning",
        r"Mean of empty slice|Degrees of freedom <= 0",
        "a quantity has no samples to average: it is reported as NaN",
    ),
    (
        "RuntimeWarning",
        r"(overflow|invalid value|divide by zero) encountered",
        "a computation overflowed or produced NaN ({message}): the scenario's values are likely out "
        "of range (a unit slip?)",
    ),
)
"""(warning class name, pattern of the message, what is printed instead) of the library warnings."""


def warning_text(message: Warning | str, category: type[Warning]) -> str | None:
    """The one line printed for a warning (without ``warning: ``), or None when it is silenced."""
    text = " ".join(str(message).split())
    for pattern, _reason in SILENCED:
        if re.search(pattern, text):
            return None
    if category.__module__.startswith("svbi"):
        return text
    for name, pattern, out in TRANSLATED:
        if any(c.__name__ == name for c in category.__mro__) and re.search(pattern, text):
            return out.format(message=text.rstrip("."))
    return text


_SHOWN: set[str] = set()


def show_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: TextIO | None = None,
    line: str | None = None,
) -> None:
    """``warnings.showwarning`` of the command line: one line on stderr, each text once."""
    del filename, lineno, line
    text = warning_text(message, category)
    if text is None or text in _SHOWN:
        return
    _SHOWN.add(text)
    print(f"warning: {text}", file=file or sys.stderr)


def echo_caught(caught: list[Any], indent: str = "") -> None:
    """Print warnings recorded by ``warnings.catch_warnings(record=True)`` as :func:`show_warning`."""
    for w in caught:
        text = warning_text(w.message, w.category)
        if text is not None and text not in _SHOWN:
            _SHOWN.add(text)
            print(f"{indent}warning: {text}", file=sys.stderr)


def install() -> None:
    """Print every warning of the command about to run as :func:`show_warning` does (each once)."""
    _SHOWN.clear()
    warnings.showwarning = show_warning
