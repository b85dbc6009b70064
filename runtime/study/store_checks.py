"""``svbi check STORE``: the checks of every run of a sweep store, and their envelope.

Each run is checked as ``svbi check`` checks one results file (:mod:`svbi.runtime.study.en1990`),
with its own scenario: the store's base scenario (attribute ``scenario``) with the run's values of
the study's keys. The run dimensions are read from the store (the dimensions of ``status``), and
each is matched to the study's keys by name, or else by its values, so the reader follows the
store's layout rather than assuming one.
"""

from __future__ import annotations

import copy
import json
import tomllib
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..scenario.schema import apply_overrides
from .en1990 import Check, CheckOptions, check_set, en1990_checks

if TYPE_CHECKING:
    import xarray as xr

LISTED_RUNS = 10
"""Failing runs named per check; the rest are counted."""


class StoreCheckError(ValueError):
    """The store lacks what the checks need; the message names it."""


@dataclass
class RowSummary:
    """One check over the runs: the envelope, the run that governs it and the runs that fail."""

    name: str
    unit: str
    limit: float | None = None
    envelope: float | None = None
    governing: str = ""
    where: str = ""
    runs: int = 0
    failing: list[tuple[str, float | None]] = field(default_factory=list)
    applies: int = 0
    values: set[float] = field(default_factory=set)


@dataclass
class StoreReport:
    """Per check set (traffic, seismic): why, and the summary of every check."""

    sets: dict[str, tuple[str, list[RowSummary]]]
    runs: int
    dims: list[str]
    not_run: list[tuple[str, str]]

    @property
    def failed(self) -> bool:
        return bool(self.not_run) or any(r.failing for _, rows in self.sets.values() for r in rows)


def _study_keys(store: xr.Dataset) -> dict[str, list[Any]]:
    """The study's keys and their values (``study`` attribute; empty when absent or unreadable)."""
    text = store.attrs.get("study")
    if not isinstance(text, str):
        return {}
    try:
        spec = tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        return {}
    keys: dict[str, list[Any]] = {}
    for table in ("axes", "zip"):
        for k, v in dict(spec.get(table, {})).items():
            keys[k] = list(v)
    return keys


def _normal(value: Any) -> str:
    if isinstance(value, bytes):
        value = value.decode()
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    return value if isinstance(value, str) else json.dumps(value)


def _dim_keys(store: xr.Dataset, dims: list[str]) -> dict[str, dict[str, list[Any]]]:
    """For every run dimension, the scenario keys along it and their values by index."""
    keys = _study_keys(store)
    out: dict[str, dict[str, list[Any]]] = {}
    for d in dims:
        found: dict[str, list[Any]] = {}
        coords = [c for c in store.coords if store[c].dims == (d,)]
        for c in coords:
            values = list(np.asarray(store[c].values).tolist())
            if c in keys and len(keys[c]) == len(values):
                found[c] = keys[c]
                continue
            match = [
                k
                for k, v in keys.items()
                if len(v) == len(values) and [_normal(a) for a in v] == [_normal(b) for b in values]
            ]
            if match:
                found[match[0]] = keys[match[0]]
            elif str(store[c].attrs.get("key", "")):
                found[str(store[c].attrs["key"])] = values
            elif "." in c:
                found[c] = values
        out[d] = found
    return out


def store_runs(store: xr.Dataset) -> Iterator[tuple[dict[str, int], dict[str, Any], dict[str, Any]]]:
    """Every run: its index along the run dimensions, its values of the study's keys and its
    scenario table."""
    if "status" not in store:
        raise StoreCheckError("the store has no 'status' variable (not written by svbi sweep?)")
    text = store.attrs.get("scenario")
    if not isinstance(text, str):
        raise StoreCheckError("the store has no 'scenario' attribute (the base scenario's text)")
    try:
        base = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise StoreCheckError(f"the store's 'scenario' attribute is not valid TOML ({exc})") from None
    dims = list(store["status"].dims)
    keys = _dim_keys(store, dims)
    for index in np.ndindex(*(store.sizes[d] for d in dims)):
        where = dict(zip(dims, index, strict=True))
        values = {k: v[where[d]] for d in dims for k, v in keys[d].items()}
        table = copy.deepcopy(base)
        apply_overrides(table, values)
        yield where, values, table


def _label(values: Mapping[str, Any], where: Mapping[str, int]) -> str:
    if values:
        return " ".join(f"{k}={_normal(v)}" for k, v in values.items())
    return " ".join(f"{d}={i}" for d, i in where.items())


def check_store(store: xr.Dataset, options: CheckOptions) -> StoreReport:
    """Every run's checks and their summary per check set."""
    dims = list(store["status"].dims) if "status" in store else []
    sets: dict[str, tuple[str, dict[str, RowSummary]]] = {}
    not_run: list[tuple[str, str]] = []
    runs = 0
    for where, values, table in store_runs(store):
        runs += 1
        label = _label(values, where)
        status = str(np.asarray(store["status"].isel(where).values).item())
        if status not in ("ok", "diverged"):
            message = (
                str(np.asarray(store["message"].isel(where).values).item()) if "message" in store else ""
            )
            not_run.append((label, f"{status}: {message}".strip(": ")))
            continue
        metrics = store.isel(where)
        which, why = check_set(table)
        form = options.track_form or str(table.get("bridge", {}).get("track_form", "ballasted"))
        moving_load = table.get("train", {}).get("vehicle") == "moving-load"
        opts = replace(options, track_form=form)
        rows = en1990_checks(metrics, form, options.comfort, moving_load, table, opts)
        _, summary = sets.setdefault(which, (why, {}))
        for row in rows:
            _add(summary, row, label)
    report = {k: (why, list(rows.values())) for k, (why, rows) in sets.items()}
    return StoreReport(report, runs, dims, not_run)


def _add(summary: dict[str, RowSummary], row: Check, label: str) -> None:
    s = summary.setdefault(row.name, RowSummary(row.name, row.unit))
    s.runs += 1
    if row.limit is not None:
        s.limit = row.limit if s.limit is None else max(s.limit, row.limit)
    if row.passed is not None:
        s.applies += 1
    if row.value is not None:
        s.values.add(row.value)
    if row.value is not None and (s.envelope is None or row.value > s.envelope):
        s.envelope, s.governing, s.where = row.value, label, row.where
    if row.passed is False:
        s.failing.append((label, row.value))


def store_text(report: StoreReport, name: str) -> str:
    """The tables of ``svbi check STORE``: per check set, per check: limit, envelope, the governing
    run, where, and how many runs fail; then the failing runs by check."""
    lines = [f"checks of {name}: {report.runs} runs over {' x '.join(report.dims) or 'one run'}"]
    for which, (why, rows) in report.sets.items():
        lines.append("")
        lines.append(f"{which} set: {why}")
        head = ("check", "limit", "envelope", "governing run", "where", "failing runs")
        cells = [head]
        for r in rows:
            runs = "n/a" if r.applies == 0 else f"{len(r.failing)} of {r.applies}"
            cells.append(
                (
                    r.name,
                    "" if r.limit is None else f"{r.limit:.4g} {r.unit}".strip(),
                    "n/a" if r.envelope is None else f"{r.envelope:.4g} {r.unit}".strip(),
                    "every run" if len(r.values) == 1 and r.runs > 1 else r.governing,
                    r.where,
                    runs,
                )
            )
        widths = [max(len(c[i]) for c in cells) for i in range(len(head))]
        table = ["  ".join(c[i].ljust(widths[i]) for i in range(len(head))).rstrip() for c in cells]
        table.insert(1, "  ".join("-" * w for w in widths))
        lines += table
        for r in rows:
            if not r.failing:
                continue
            lines.append("")
            lines.append(f"FAIL {r.name}: {len(r.failing)} of {r.applies} runs")
            for label, value in r.failing[:LISTED_RUNS]:
                shown = "" if value is None else f" ({value:.4g} {r.unit})".replace(" )", ")")
                lines.append(f"  {label}{shown}")
            if len(r.failing) > LISTED_RUNS:
                lines.append(f"  ... and {len(r.failing) - LISTED_RUNS} more")
    if report.not_run:
        lines.append("")
        lines.append(f"FAIL {len(report.not_run)} run(s) without results (they certify nothing):")
        for label, why in report.not_run[:LISTED_RUNS]:
            lines.append(f"  {label}: {why}")
        if len(report.not_run) > LISTED_RUNS:
            lines.append(f"  ... and {len(report.not_run) - LISTED_RUNS} more")
    return "\n".join(lines) + "\n"
