"""Which of svbi's TOML files a file is: a scenario, a study, or a vehicle topology.

A file given to the wrong command (a study to ``svbi run``, a scenario to ``svbi derive``) is told
what it is and which command takes it, instead of a list of unknown keys.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

USES = {
    "scenario": "a scenario file: run it with `svbi run {file} -o OUT.nc` (`svbi modes {file}` prints its "
    "modes)",
    "study": "a study file: run it with `svbi sweep {file} -o OUT.nc`",
    "topology": "a vehicle topology file: `svbi derive {file}` and `svbi modes {file}` take it, and a "
    "scenario names it in train.vehicle",
}
"""What each kind of file is and which command takes it."""

LABELS = {"scenario": "scenario", "study": "study", "topology": "vehicle topology", "results": "results"}


def toml_kind(data: Mapping[str, Any]) -> str | None:
    """The kind of a parsed TOML file (a key of :data:`USES`), or None when it is none of them."""
    if "bridge" in data or "train" in data:
        return "scenario"
    if "bodies" in data or "wheels" in data or "suspensions" in data:
        return "topology"
    if "axes" in data or "zip" in data or isinstance(data.get("scenario"), str):
        return "study"
    return None


def wrong_kind(data: Mapping[str, Any], expected: str, file: str = "FILE") -> str:
    """A message when ``data`` (the file ``file``) is clearly another kind of file than
    ``expected``; "" otherwise."""
    kind = toml_kind(data)
    if kind is None or kind == expected:
        return ""
    label = LABELS[expected]
    what = f"{_article(label)} {label} file"
    if expected == "results":
        what = "a results file (NetCDF, of `svbi run`)"
    return f"this is {USES[kind].format(file=file)}; it is not {what}"


def _article(word: str) -> str:
    return "an" if word[0] in "aeiou" else "a"
