"""EN 1990 Annex A2 checks of one run (``svbi check``), from its metrics (``svbi.runtime.study.metrics``).

* peak vertical deck acceleration, filtered (EN 1990 A2.4.4.2.1(4)P): 3.5 m/s² on ballasted
  track, 5 m/s² with direct fastening;
* vertical car-body acceleration (EN 1990 A2.4.4.3.2, Table A2.9): 1.0 / 1.3 / 2.0 m/s² for the
  comfort levels very good / good / acceptable;
* wheel unloading ΔP/P: 0.6 and 0.8, as used in running-safety practice (0.8 for transient and
  seismic loading);
* deck end rotation (EN 1990 A2.4.4.2.3(1), ballasted track): 6.5e-3 rad at a transition to the
  embankment, 10e-3 rad for θ1 + θ2 between consecutive decks (EN 1990 states them for the LM71
  load model; here they are applied to the run's own loading); direct fastening: n/a;
* run complete: a run that stopped early certifies nothing.

The comfort row checks the level asked for (``--comfort``, default ``acceptable``) and names the
level reached. Rows that do not apply (no car body on a moving-load train, no end rotation) are
shown as ``n/a`` and do not count. A checked quantity that is NaN (not a number), or whose samples
in the results hold NaN, fails as ``invalid``: a NaN certifies nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import xarray as xr

DECK_ACCELERATION_LIMIT = {"ballasted": 3.5, "direct": 5.0}
"""m/s², EN 1990 A2.4.4.2.1(4)P (the recommended values)."""
COMFORT_LEVELS = {"very-good": 1.0, "good": 1.3, "acceptable": 2.0}
"""m/s², EN 1990 Table A2.9: recommended levels of vertical car-body acceleration."""
ABUTMENT_ROTATION_LIMIT = {"ballasted": 6.5e-3}
"""rad, EN 1990 A2.4.4.2.3(1), ballasted track: deck end at a transition to the embankment."""
JOINT_ROTATION_LIMIT = {"ballasted": 10.0e-3}
"""rad, EN 1990 A2.4.4.2.3(1), ballasted track: θ1 + θ2 between two consecutive decks."""
UNLOADING_LIMITS = (0.6, 0.8)
"""ΔP/P limits of running-safety practice: 0.6 in normal operation, 0.8 under transient loading."""


CHECK_INPUTS: dict[str, tuple[str, ...]] = {
    "peak_deck_acceleration": ("deck_acceleration",),
    "peak_carbody_az": ("carbody_az",),
    "max_unloading_ratio": ("contact_force", "contact_force_filtered"),
    "peak_end_rotation": ("end_rotation",),
    "peak_joint_rotation": ("end_rotation",),
}
"""The results variables behind each checked metric: a NaN sample in one makes the check invalid."""


def nan_samples(results: xr.Dataset) -> dict[str, int]:
    """Number of NaN samples in each results variable of :data:`CHECK_INPUTS` that has any."""
    out: dict[str, int] = {}
    for name in sorted({v for names in CHECK_INPUTS.values() for v in names}):
        if name in results.variables:
            count = int(np.isnan(np.asarray(results[name].values, dtype=float)).sum())
            if count:
                out[name] = count
    return out


def _invalid(metrics: xr.Dataset, name: str, nans: dict[str, int]) -> str:
    """Why the metric ``name`` is not a valid number ("" when it is): NaN samples or values."""
    found = [f"{nans[v]} NaN sample(s) in {v}" for v in CHECK_INPUTS.get(name, ()) if nans.get(v)]
    if found:
        return "invalid: " + ", ".join(found)
    if name in metrics:
        values = np.asarray(metrics[name].values, dtype=float)
        bad = int(np.isnan(values).sum())
        if bad:
            return f"invalid: {name} is NaN ({bad} of {values.size} values)"
    return ""


@dataclass(frozen=True)
class Check:
    """One row of the table. ``passed`` is None when the check does not apply."""

    name: str
    value: float | None
    limit: float | None
    unit: str
    where: str
    when: float | None
    passed: bool | None
    note: str = ""

    @property
    def status(self) -> str:
        return "n/a" if self.passed is None else ("pass" if self.passed else "FAIL")


def _worst(metrics: xr.Dataset, name: str, lowest: bool = False) -> tuple[float, str, float | None] | None:
    """The worst value of a metric, where (dims and their labels) and when; None if absent or NaN."""
    if name not in metrics:
        return None
    da = metrics[name]
    values = np.asarray(da.values, dtype=float)
    if values.size == 0 or not np.isfinite(values).any():
        return None
    flat = int(np.nanargmin(values) if lowest else np.nanargmax(values))
    index = np.unravel_index(flat, values.shape)
    where = ", ".join(f"{d} {metrics.coords[d].values[i]}" for d, i in zip(da.dims, index, strict=True))
    when = None
    if f"{name}_time" in metrics:
        when = float(np.asarray(metrics[f"{name}_time"].values)[index])
    return float(values[index]), where, when


def en1990_checks(
    metrics: xr.Dataset,
    track_form: str = "ballasted",
    comfort: str = "acceptable",
    moving_load: bool = False,
    nans: dict[str, int] | None = None,
) -> list[Check]:
    """The rows of ``svbi check`` for one run's metrics; ``nans``: :func:`nan_samples` of its
    results (a NaN sample in a checked quantity fails that check as invalid)."""
    nans = nans or {}
    if track_form not in DECK_ACCELERATION_LIMIT:
        raise ValueError(f"track form {track_form!r}: expected one of {', '.join(DECK_ACCELERATION_LIMIT)}")
    if comfort not in COMFORT_LEVELS:
        raise ValueError(f"comfort level {comfort!r}: expected one of {', '.join(COMFORT_LEVELS)}")
    rows: list[Check] = []
    limit = DECK_ACCELERATION_LIMIT[track_form]
    worst = _worst(metrics, "peak_deck_acceleration")
    name = f"deck acceleration ({track_form}, A2.4.4.2.1)"
    invalid = _invalid(metrics, "peak_deck_acceleration", nans)
    if invalid:
        rows.append(_failed(name, limit, "m/s^2", invalid))
    elif worst is None:
        rows.append(Check(name, None, limit, "m/s^2", "", None, None, "no deck acceleration"))
    else:
        v, where, when = worst
        cutoff = metrics.attrs.get("deck_acceleration_cutoff_hz")
        note = f"filtered to {float(cutoff):.3g} Hz" if cutoff is not None else ""
        rows.append(Check(name, v, limit, "m/s^2", where, when, v <= limit, note))

    limit = COMFORT_LEVELS[comfort]
    name = f"car-body vertical acceleration (comfort {comfort}, Table A2.9)"
    worst = None if moving_load else _worst(metrics, "peak_carbody_az")
    invalid = "" if moving_load else _invalid(metrics, "peak_carbody_az", nans)
    if invalid:
        rows.append(_failed(name, limit, "m/s^2", invalid))
    elif worst is None:
        rows.append(Check(name, None, limit, "m/s^2", "", None, None, "no car body"))
    else:
        v, where, when = worst
        reached = next((lvl for lvl, b in COMFORT_LEVELS.items() if v <= b), "below acceptable")
        rows.append(Check(name, v, limit, "m/s^2", where, when, v <= limit, f"level reached: {reached}"))

    worst = None if moving_load else _worst(metrics, "max_unloading_ratio")
    invalid = "" if moving_load else _invalid(metrics, "max_unloading_ratio", nans)
    for limit in UNLOADING_LIMITS:
        name = f"wheel unloading dP/P <= {limit:g}"
        if invalid:
            rows.append(_failed(name, limit, "1", invalid))
        elif worst is None:
            rows.append(Check(name, None, limit, "1", "", None, None, "prescribed axle loads"))
        else:
            v, where, when = worst
            rows.append(Check(name, v, limit, "1", where, when, v <= limit))

    rows += _rotation_rows(metrics, track_form, nans)
    complete = int(np.asarray(metrics["complete"].values)) if "complete" in metrics else 1
    rows.append(
        Check(
            "run complete",
            float(complete),
            1.0,
            "",
            "",
            None,
            bool(complete),
            "" if complete else str(metrics.attrs.get("incomplete", "stopped early"))[:80],
        )
    )
    return rows


def _failed(name: str, limit: float | None, unit: str, why: str) -> Check:
    """The row of a check whose quantity is NaN: it fails (a NaN certifies nothing)."""
    return Check(name, math.nan, limit, unit, "", None, False, why)


def _rotation_rows(metrics: xr.Dataset, track_form: str, nans: dict[str, int]) -> list[Check]:
    """EN 1990 A2.4.4.2.3(1): with ballasted track, the deck end rotation at a transition to the
    embankment (the first span's left end, the last span's right end) and the sum of the two end
    rotations between consecutive decks. Direct fastening has project-specific limits (n/a)."""
    name_end, name_joint = "end rotation at abutments (A2.4.4.2.3)", "rotation between decks (A2.4.4.2.3)"
    if "peak_end_rotation" not in metrics:
        return [Check(name_end, None, None, "rad", "", None, None, "not in the results")]
    invalid = _invalid(metrics, "peak_end_rotation", nans)
    if invalid:
        rows = [_failed(name_end, ABUTMENT_ROTATION_LIMIT.get(track_form), "rad", invalid)]
        if "peak_joint_rotation" in metrics and metrics["peak_joint_rotation"].size:
            rows.append(_failed(name_joint, JOINT_ROTATION_LIMIT.get(track_form), "rad", invalid))
        return rows
    rows = []
    end = metrics["peak_end_rotation"]
    when = metrics["peak_end_rotation_time"]
    spans = end.sizes["span"]
    candidates = [
        (float(end.isel(span=0, end=0)), 0, "left"),
        (float(end.isel(span=-1, end=1)), spans - 1, "right"),
    ]
    value, s, side = max(candidates)
    at = float(when.isel(span=s, end=0 if side == "left" else 1))
    label = f"span {int(end.span.values[s])} {side} end"
    limits = ABUTMENT_ROTATION_LIMIT.get(track_form)
    passed = None if limits is None else value <= limits
    note = "" if limits is not None else "limit specified for the project (direct fastening)"
    rows.append(Check(name_end, value, limits, "rad", label, at, passed, note))
    worst = _worst(metrics, "peak_joint_rotation")
    limit = JOINT_ROTATION_LIMIT.get(track_form)
    if worst is None:
        rows.append(Check(name_joint, None, limit, "rad", "", None, None, "one span"))
    else:
        v, where, at = worst
        note = "" if limit is not None else "limit specified for the project (direct fastening)"
        rows.append(
            Check(name_joint, v, limit, "rad", where, at, None if limit is None else v <= limit, note)
        )
    return rows


def _value_text(r: Check) -> str:
    if r.value is None:
        return "n/a"
    return "NaN" if math.isnan(r.value) else f"{r.value:.4g} {r.unit}".strip()


def checks_table(rows: list[Check]) -> str:
    """Plain-text table: check, value, limit, where, when, status, note."""
    head = ("check", "value", "limit", "where", "when (s)", "status", "note")
    cells = [head]
    for r in rows:
        cells.append(
            (
                r.name,
                _value_text(r),
                "" if r.limit is None else f"{r.limit:g} {r.unit}".strip(),
                r.where,
                "" if r.when is None else f"{r.when:.4g}",
                r.status,
                r.note,
            )
        )
    widths = [max(len(c[i]) for c in cells) for i in range(len(head))]
    lines = ["  ".join(c[i].ljust(widths[i]) for i in range(len(head))).rstrip() for c in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines) + "\n"
