"""Which of svbi's TOML files a file is: a scenario, a study, or a vehicle topology.

A file given to the wrong command (a study to ``svbi run``, a scenario to ``svbi derive``) is told
what it is and which command takes it, instead of a list of unknown keys.

A scenario is 2D or 3D: 3D when its ``train.vehicle`` is a 3D vehicle topology
(:func:`vehicle_dimensions`, docs/three-d.md). `svbi run`, `svbi sweep` and `svbi modes` take 3D
scenarios (through ``svbi.simulate``); the 2D model (``build_model``) does not (:data:`NOT_RUN_3D`).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any

from ...codegen.input_files import MAX_TOML_BYTES, loads_toml, read_text

USES = {
    "scenario": "a scenario file: run it with `svbi run {file} -o OUT.nc` (`svbi modes {file}` prints its "
    "modes)",
    "study": "a study file: run it with `svbi sweep {file} -o OUT.nc`",
    "topology": "a vehicle topology file: `svbi derive {file}` and `svbi modes {file}` take it, and a "
    "scenario names it in train.vehicle",
}
"""What each kind of file is and which command takes it."""

NOT_RUN_3D = (
    "a 3D scenario (train.vehicle {vehicle!r} is a 3D vehicle): the 2D model does not take it; "
    "`svbi.simulate` and `svbi run {file}` run it (docs/three-d.md)"
)
"""The one line of ``build_model``, whose model is 2D, for a 3D scenario."""

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


# --------------------------------------------------------------------------------------------------
# 2D and 3D scenarios

VEHICLES_3D_PACKAGE = "svbi.codegen.vehicles3d"
"""Where the built-in 3D vehicle topologies live (read as files here: no SymPy is imported)."""


def builtin_vehicles_3d() -> list[str]:
    """Names of the built-in 3D vehicles (``codegen/vehicles3d/``)."""
    folder = resources.files(VEHICLES_3D_PACKAGE)
    return sorted(p.name[: -len(".toml")] for p in folder.iterdir() if p.name.endswith(".toml"))


def vehicle_dimensions(vehicle: str, base_dir: Path) -> int:
    """3 when ``vehicle`` (a scenario's ``train.vehicle``) is a 3D topology: a built-in 3D vehicle or
    a topology file that says ``dimensions = 3``; 2 otherwise. A file that cannot be read is left to
    the vehicle's own check (2), which names what is wrong with it."""
    if vehicle in builtin_vehicles_3d():
        return 3
    path = Path(vehicle).expanduser()
    path = path if path.is_absolute() else base_dir / path
    if not os.path.isfile(path):
        return 2
    try:
        data = loads_toml(read_text(path, MAX_TOML_BYTES))
    except (ValueError, OSError):  # unreadable or malformed: the 2D loader's message says why
        return 2
    return 3 if isinstance(data, Mapping) and data.get("dimensions") == 3 else 2
