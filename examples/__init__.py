"""The shipped example scenarios (``svbi.examples``): the files themselves, and the paper's bridge
and scenario as dicts, read from ``paper-2020.toml`` (their one home: tests and benchmarks build
their variants from these)."""

from __future__ import annotations

import copy
import functools
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

PAPER = "paper-2020.toml"


def path(name: str) -> Path:
    """The path of a shipped example file."""
    return Path(str(resources.files(__name__).joinpath(name)))


@functools.cache
def _paper() -> dict[str, Any]:
    return tomllib.loads(path(PAPER).read_text(encoding="utf-8"))


def paper_scenario(**tables: dict[str, Any]) -> dict[str, Any]:
    """The paper's numerical application (``paper-2020.toml``) as a TOML-shaped dict, each table
    updated with the given keys (``paper_scenario(train={"cars": 2})``)."""
    data = copy.deepcopy(_paper())
    for name, keys in tables.items():
        data[name] = {**data.get(name, {}), **keys}
    return data


def paper_bridge(**keys: Any) -> dict[str, Any]:
    """The paper's bridge (Section 5: ten simply supported 32 m spans, the section and damping of
    ``paper-2020.toml``), as a ``[bridge]`` table, updated with ``keys``."""
    return {**copy.deepcopy(_paper()["bridge"]), **keys}


def paper_section() -> tuple[float, float, float, float, float]:
    """``(span length, mass per length, Young's modulus, area, second moment)`` of the paper's spans."""
    b = _paper()["bridge"]
    return b["span_length"], b["mass_per_length"], b["youngs_modulus"], b["area"], b["second_moment"]


def paper_section_keys() -> dict[str, float]:
    """The ``[bridge]`` keys of the paper's span section: mass per length, Young's modulus, area and
    second moment (the rest of a bridge table is the caller's)."""
    b = _paper()["bridge"]
    return {k: b[k] for k in ("mass_per_length", "youngs_modulus", "area", "second_moment")}
