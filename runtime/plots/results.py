"""Figures and a text summary of one or more results files, after the paper's Fig. 4.

The paper (Stoura, Paraskevopoulos & Dimitrakopoulos, 17WCEE 2020, Section 5) compares three methods
on a ten-car train crossing ten simply supported spans: (a) vertical and (b) longitudinal
displacement at the midspan of the first span, (c) the contact force of the first wheel of the last
car, (d) the acceleration and (e, f) the displacement of the car body of the first car, (f) without
the DAE solution (`coupled-classic`), whose drift dwarfs the others. Here every run is overlaid on
each panel, and a further figure shows the constraint violations (the gaps of Eqs. 18, 20-21, 23)
that the dynamic multipliers keep at round-off while the classic ones drift.

Input is the results Dataset of docs/design.md section 7. Figures are drawn with matplotlib's object interface
(`Figure`, no pyplot), which renders with Agg and never opens a window. Files are written atomically.
"""

from __future__ import annotations

import math
import os
import textwrap
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import matplotlib
import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from ...codegen.input_files import MAX_TOML_BYTES, loads_toml, read_text
from ..run.atomic import write_atomic
from ..scenario.kinds import wrong_kind
from .lateral import LATERAL, is_3d, lateral_figure

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the same parser as the tomli backport (pyproject)
    import tomli as tomllib

DPI = 150
REFERENCE_METHOD = "localized-dynamic"
DRIFTING_METHOD = "coupled-classic"
# Gaps of the dynamic methods sit at round-off and can be exactly zero; a log axis cannot show zero,
# so values below this floor are drawn on it (and the axes say so).
GAP_FLOOR_M = 1e-18
DEFAULT_FILTER_HZ = 20.0  # docs/scenario.md default of output.force_filter_hz
MESSAGE_CHARS = 70  # of a stopped run's `incomplete` message, in panel titles
NOTE_CHARS = 80  # line length of the notes under a panel title

# Variables without which a file is not a results file worth plotting, with their dims (docs/design.md
# section 7).
REQUIRED_VARIABLES: dict[str, tuple[str, ...]] = {
    "time": ("time",),
    "midspan_uz": ("time", "span"),
    "midspan_ux": ("time", "span"),
    "contact_force": ("time", "car", "wheel"),
}
# Variables a panel needs but whose absence is only noted (e.g. a moving-load train has no car body).
OPTIONAL_VARIABLES: dict[str, tuple[str, ...]] = {
    "midspan_uz_rel": ("time", "span"),
    "midspan_ux_rel": ("time", "span"),
    "contact_force_filtered": ("time", "car", "wheel"),
    "carbody_uz": ("time", "car"),
    "carbody_az": ("time", "car"),
    "gap_vehicle": ("time", "car", "wheel"),
    "gap_bridge": ("time", "car", "wheel"),
    "gap_support": ("time", "support"),
    "contact_state": ("time", "car", "wheel"),
    "wheel_uplift": ("time", "car", "wheel"),
    "unloading_ratio": ("time", "car", "wheel"),
}
EXPECTED_DIMS = {**REQUIRED_VARIABLES, **OPTIONAL_VARIABLES}


class ResultsFileError(ValueError):
    """A results file that cannot be read or lacks what the figures need; the message names both."""


@dataclass(frozen=True)
class LineStyle:
    """How one run is drawn. Later runs are thinner and dashed and lie on top, so equal curves all show."""

    color: str
    dashes: tuple[float, ...] | None
    width: float
    zorder: float


# Okabe-Ito colours (distinguishable with colour-blindness), with dash patterns and widths that differ
# as well: a wide solid line, a dashed one on it, a thin dark dotted one on top, so that the paper's
# case of three coinciding curves still shows all three.
_STYLES = (
    LineStyle("#0072B2", None, 3.0, 2.0),
    LineStyle("#D55E00", (4.0, 2.0), 1.8, 2.1),
    LineStyle("#000000", (1.0, 1.5), 1.1, 2.2),
    LineStyle("#009E73", (6.0, 2.0, 1.5, 2.0), 1.1, 2.3),
    LineStyle("#CC79A7", (3.0, 1.5), 1.0, 2.4),
    LineStyle("#E69F00", (1.0, 1.0), 0.8, 2.5),
)


def line_style(index: int) -> LineStyle:
    """The style of the `index`-th run (0-based) in a set of overlaid runs."""
    style = _STYLES[index % len(_STYLES)]
    return LineStyle(style.color, style.dashes, style.width, 2.0 + 0.1 * index)


@dataclass(frozen=True)
class Run:
    """One results Dataset with the label it carries in legends and in the summary."""

    label: str
    data: xr.Dataset
    style: LineStyle

    @property
    def method(self) -> str:
        return str(self.data.attrs.get("method", ""))

    @property
    def complete(self) -> bool:
        return is_complete(self.data)


Results = Mapping[str, xr.Dataset] | Sequence[xr.Dataset] | xr.Dataset


def is_complete(ds: xr.Dataset) -> bool:
    """False only when the file says so (`complete == 0`): a run that stopped early."""
    flag = ds.attrs.get("complete", 1)
    try:
        return int(np.asarray(flag).ravel()[0]) != 0
    except (TypeError, ValueError, IndexError):
        return str(flag).strip().lower() not in ("0", "false", "no")


def default_labels(datasets: Sequence[xr.Dataset], names: Sequence[str] | None = None) -> list[str]:
    """Legend labels: the `method` attribute, disambiguated by backend, then by `names` or position."""
    labels = [str(ds.attrs.get("method") or f"run {i + 1}") for i, ds in enumerate(datasets)]
    if len(set(labels)) < len(labels):
        labels = [
            f"{lab} ({ds.attrs['backend']})" if "backend" in ds.attrs else lab
            for lab, ds in zip(labels, datasets, strict=True)
        ]
    if len(set(labels)) < len(labels):
        extra = list(names) if names is not None else [f"#{i + 1}" for i in range(len(labels))]
        labels = [f"{lab} [{x}]" for lab, x in zip(labels, extra, strict=True)]
    return labels


def make_runs(results: Results) -> list[Run]:
    """Normalise a Dataset, a sequence of them or a {label: Dataset} mapping to styled runs."""
    if isinstance(results, xr.Dataset):
        results = [results]
    if isinstance(results, Mapping):
        pairs = list(results.items())
    else:
        datasets = list(results)
        pairs = list(zip(default_labels(datasets), datasets, strict=True))
    if not pairs:
        raise ValueError("no results to plot")
    # A time variable stored as data rather than as the coordinate still labels the time axis.
    pairs = [(label, ds.set_coords("time") if "time" in ds.data_vars else ds) for label, ds in pairs]
    return [Run(label, ds, line_style(i)) for i, (label, ds) in enumerate(pairs)]


# ----------------------------------------------------------------------------------------------
# Reading results files


def read_results(path: str | os.PathLike[str]) -> xr.Dataset:
    """Load a results NetCDF file into memory and check the variables the figures need.

    Raises ResultsFileError naming the file, and the variable where one is missing or malformed.
    """
    path = Path(path)
    if not os.path.lexists(path):  # os.path: a name too long is "not found", not a traceback
        raise ResultsFileError(f"{path}: file not found")
    if not os.path.isfile(path):
        raise ResultsFileError(f"{path}: not a file")
    try:
        # Time is seconds from the start of the run (docs/design.md section 7); a units attribute such as
        # "seconds" must not turn it into timedeltas or dates.
        with xr.open_dataset(path, decode_times=False, decode_timedelta=False) as ds:
            data = ds.load()
    except Exception as exc:  # any backend failure means "not a readable NetCDF file"
        kind = _toml_kind(path)
        if kind:
            raise ResultsFileError(f"{path}: {kind}") from None
        raise ResultsFileError(f"{path}: cannot read as a NetCDF results file ({exc})") from None
    if data.attrs.get("svbi_sweep"):
        raise ResultsFileError(
            f"{path}: this is a sweep store (`svbi sweep`: the metrics of every run of a study), not "
            f"the results of one run: `svbi plot {path}` draws it, `svbi check {path}` checks every run, "
            f"and each run's results are in {path}.histories/ when the study keeps them"
        )
    check_results(data, str(path))
    return data


def _toml_kind(path: Path) -> str:
    """What a TOML file given as results is (a scenario, a study...), "" when it is not one."""
    try:  # bounded, and no RecursionError on a deeply nested file
        data = loads_toml(read_text(path, MAX_TOML_BYTES))
    except ValueError:
        return ""
    return wrong_kind(data, "results", str(path))


def check_results(ds: xr.Dataset, name: str = "results") -> None:
    """Raise ResultsFileError if a required variable is missing or any known one has wrong dims."""
    for var in REQUIRED_VARIABLES:
        if var not in ds.variables:
            raise ResultsFileError(
                f"{name}: required variable '{var}' is missing (a results file has "
                f"{', '.join(REQUIRED_VARIABLES)}; see docs/design.md section 7)"
            )
    side = {"side"} if is_3d(ds) else set()  # a 3D run's wheels have a side (docs/scenario.md)
    for var, dims in EXPECTED_DIMS.items():
        allowed = (set(dims), set(dims) | side) if "wheel" in dims else (set(dims),)
        if var in ds.variables and set(ds[var].dims) not in allowed:
            raise ResultsFileError(f"{name}: variable '{var}' has dims {ds[var].dims}, expected {dims}")


# ----------------------------------------------------------------------------------------------
# Quantities


def _index_name(ds: xr.Dataset, dim: str, index: int) -> str:
    """Number of an entry along `dim` as the user knows it (coordinate value, else 1-based)."""
    if dim in ds.coords:
        value = ds.coords[dim].values[index]
        return str(value.item() if hasattr(value, "item") else value)
    return str(range(1, ds.sizes[dim] + 1)[index])


def _series(ds: xr.Dataset, var: str, select: Mapping[str, int]) -> xr.DataArray | None:
    """The time series `var` at the given positions, or None when the variable is absent or empty."""
    if var not in ds.variables or any(ds.sizes.get(d, 0) == 0 for d in EXPECTED_DIMS[var]):
        return None
    picked = {d: i for d, i in select.items() if d in ds[var].dims}
    if "side" in ds[var].dims:  # a 3D run's wheel: the left one of the wheelset, unless chosen
        picked.setdefault("side", 0)
    return ds[var].isel(picked)


def _max_abs_over(ds: xr.Dataset, var: str) -> xr.DataArray | None:
    """max over all non-time dims of |var|, per time step (NaNs of a truncated run are skipped)."""
    if var not in ds.variables or ds[var].size == 0:
        return None
    da = abs(ds[var])
    return da.max(dim=[d for d in da.dims if d != "time"], skipna=True)


def _in_contact_gaps(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` with ``gap_bridge`` kept for wheels in contact only: an airborne wheel's gap is its
    uplift (reported apart), not a constraint violation."""
    if "contact_state" not in ds.variables or "gap_bridge" not in ds.variables:
        return ds
    return ds.assign(gap_bridge=ds["gap_bridge"].where(ds["contact_state"] == 1))


def _scalar(da: xr.DataArray | None) -> float | None:
    if da is None or da.size == 0:
        return None
    values = np.asarray(da.values, dtype=float)
    if not np.any(np.isfinite(values)):
        return None
    return float(np.nanmax(values))


def _filter_hz(ds: xr.Dataset) -> float | None:
    """The contact-force filter cutoff from the scenario text (docs/scenario.md `output.force_filter_hz`)."""
    text = ds.attrs.get("scenario")
    if not isinstance(text, str):
        return None
    try:
        output = tomllib.loads(text).get("output", {})
    except tomllib.TOMLDecodeError:
        return None
    if not isinstance(output, dict):
        return None
    value = output.get("force_filter_hz", DEFAULT_FILTER_HZ)
    return float(value) if isinstance(value, int | float) else None


def scenario_title(runs: Sequence[Run]) -> str:
    """The scenario title(s) of the runs: one title, or all of them when the runs differ."""
    titles: list[str] = []
    for run in runs:
        title = str(run.data.attrs.get("title") or "").strip() or _title_from_scenario(run.data)
        if title not in titles:
            titles.append(title)
    return " | ".join(titles)


def _title_from_scenario(ds: xr.Dataset) -> str:
    try:
        title = tomllib.loads(str(ds.attrs.get("scenario", ""))).get("title")
    except tomllib.TOMLDecodeError:
        title = None
    return str(title) if title else "untitled scenario"


# ----------------------------------------------------------------------------------------------
# Panels


def _seconds(t: xr.DataArray | np.ndarray) -> np.ndarray:
    """Time axis in s, also for a Dataset built in memory with timedelta times."""
    values = np.asarray(t)
    if np.issubdtype(values.dtype, np.timedelta64):
        return values / np.timedelta64(1, "s")
    return values.astype(float)


def _draw(ax: Axes, t: xr.DataArray | np.ndarray, y: np.ndarray, style: LineStyle, label: str) -> None:
    (line,) = ax.plot(_seconds(t), y, color=style.color, lw=style.width, zorder=style.zorder, label=label)
    if style.dashes is not None:
        line.set_dashes(style.dashes)


def _finish(ax: Axes, title: str, ylabel: str, notes: list[str]) -> None:
    ax.set_xlabel("time t (s)")
    ax.set_ylabel(ylabel)
    if notes:
        # Wrapped to the width of one overview column, so that neighbouring titles never overlap.
        title += "\n" + textwrap.fill("(" + "; ".join(notes) + ")", width=NOTE_CHARS, break_on_hyphens=False)
    ax.set_title(title, fontsize="medium")
    ax.grid(True, lw=0.4, alpha=0.5)
    if ax.get_legend_handles_labels()[0]:
        # Outside, right of the axes: time histories fill the whole width, so any place inside
        # would hide part of a curve. Long handles show the dash patterns.
        ax.legend(fontsize="small", handlelength=4.0, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    else:
        ax.text(0.5, 0.5, "no data", transform=ax.transAxes, ha="center", va="center", color="0.4")


def _run_notes(runs: Sequence[Run], missing: list[str]) -> list[str]:
    notes = [f"{run.label}: {_incomplete_note(run.data)}" for run in runs if not run.complete]
    return notes + missing


def _incomplete_note(ds: xr.Dataset) -> str:
    """'incomplete run', with the last time whose bridge response was stored and the run's message."""
    note = "incomplete run"
    uz = ds["midspan_uz"] if "midspan_uz" in ds.variables else None
    if uz is not None and "time" in ds.variables:
        values = np.asarray(uz.transpose("time", ...).values, dtype=float)
        stored = np.isfinite(values).reshape(uz.sizes["time"], -1).all(axis=1)
        if stored.any():
            note += f", last stored t = {float(_seconds(ds['time'])[np.flatnonzero(stored)[-1]]):.4g} s"
        else:
            note += ", nothing stored"
    message = str(ds.attrs.get("incomplete", "")).strip()
    if message:
        # The simulator's message names time, quantity and cause; the title keeps its start.
        short = message if len(message) <= MESSAGE_CHARS else message[: MESSAGE_CHARS - 1] + "…"
        note += f", reason: {short}"
    return note


def _time_history(
    ax: Axes, runs: Sequence[Run], var: str, select: Mapping[str, int], scale: float, ylabel: str, title: str
) -> None:
    missing: list[str] = []
    for run in runs:
        da = _series(run.data, var, select)
        if da is None:
            missing.append(f"{var} missing in {run.label}")
            continue
        _draw(ax, da["time"], np.asarray(da.values, dtype=float) * scale, run.style, run.label)
    _finish(ax, title, ylabel, _run_notes(runs, missing))


def _where(runs: Sequence[Run], dim: str, index: int) -> str:
    return _index_name(runs[0].data, dim, index) if dim in runs[0].data.sizes else "?"


def _absolute_and_relative(ax: Axes, runs: Sequence[Run], var: str, ylabel: str, title: str) -> None:
    """The deformation (``<var>_rel``: relative to the ground under the span) in the run's style, and
    the absolute response faded behind it: under an earthquake the absolute displacement is mostly the
    ground's, which is what the paper's "very small" longitudinal response leaves out."""
    missing: list[str] = []
    relative = False
    for run in runs:
        da = _series(run.data, var, {"span": 0})
        if da is None:
            missing.append(f"{var} missing in {run.label}")
            continue
        rel = _series(run.data, f"{var}_rel", {"span": 0})
        if rel is None:  # results of svbi before the relative outputs: the absolute one as it was
            _draw(ax, da["time"], np.asarray(da.values, dtype=float) * 1e3, run.style, run.label)
            continue
        relative = True
        ax.plot(
            _seconds(da["time"]), np.asarray(da.values, dtype=float) * 1e3, color=run.style.color,
            lw=max(run.style.width, 1.0), alpha=0.3, zorder=run.style.zorder - 10,
            label=f"{run.label}, absolute",
        )  # fmt: skip
        _draw(ax, rel["time"], np.asarray(rel.values, dtype=float) * 1e3, run.style, f"{run.label}, relative")
    if relative:
        title += ": relative to the ground (bold), absolute (faded)"
    _finish(ax, title, ylabel, _run_notes(runs, missing))


def panel_midspan_uz(ax: Axes, runs: Sequence[Run]) -> None:
    """Fig. 4(a): vertical displacement at the midspan of span 1, relative and absolute."""
    title = f"(a) Vertical displacement at midspan of span {_where(runs, 'span', 0)}"
    _absolute_and_relative(ax, runs, "midspan_uz", "vertical displacement $u_z$ (mm)", title)


def panel_midspan_ux(ax: Axes, runs: Sequence[Run]) -> None:
    """Fig. 4(b): longitudinal displacement at the midspan of span 1, relative and absolute."""
    title = f"(b) Longitudinal displacement at midspan of span {_where(runs, 'span', 0)}"
    _absolute_and_relative(ax, runs, "midspan_ux", "longitudinal displacement $u_x$ (mm)", title)


def panel_contact_force(ax: Axes, runs: Sequence[Run]) -> None:
    """Fig. 4(c): normal contact force of the first wheel of the last car, raw (thin) and filtered (bold)."""
    select = {"car": -1, "wheel": 0}
    missing: list[str] = []
    # Raw forces first, all of them, so that they lie underneath and fill the legend's first
    # column. The impulses at slope kinks (docs/design.md section 3) are real, so the raw force is
    # shown, but light and thin behind the filtered force that a railway engineer reads.
    for run in runs:
        raw = _series(run.data, "contact_force", select)
        if raw is None:
            missing.append(f"contact_force missing in {run.label}")
            continue
        ax.plot(
            _seconds(raw["time"]),
            np.asarray(raw.values, dtype=float) * 1e-3,
            color=run.style.color,
            lw=0.7,
            alpha=0.4,
            zorder=1.0 + 0.01 * run.style.zorder,
            label=f"{run.label}, raw",
        )
    for run in runs:
        filtered = _series(run.data, "contact_force_filtered", select)
        if filtered is None:
            missing.append(f"contact_force_filtered missing in {run.label}")
            continue
        cutoff = _filter_hz(run.data)
        name = f"low-pass {cutoff:g} Hz" if cutoff is not None else "filtered"
        _draw(
            ax,
            filtered["time"],
            np.asarray(filtered.values, dtype=float) * 1e-3,
            run.style,
            f"{run.label}, {name}",
        )
    _clip_impulses(ax, runs, select, missing)
    car = _where(runs, "car", -1)
    title = f"(c) Contact force, wheel {_where(runs, 'wheel', 0)} of car {car} (last car)"
    _finish(ax, title, "contact force (kN, compression +)", _run_notes(runs, missing))


def _clip_impulses(ax: Axes, runs: Sequence[Run], select: dict[str, int], notes: list[str]) -> None:
    """Keep the filtered force readable: the raw impulses at slope kinks are clipped, and said so.

    The joint impulses are physical (docs/design.md section 3) but their peaks scale as 1/dt and
    would squash the filtered force, which is what the engineer reads, into a flat line.
    """
    filtered = [_series(r.data, "contact_force_filtered", select) for r in runs]
    raw = [_series(r.data, "contact_force", select) for r in runs]
    filtered_vals = [np.asarray(f.values, dtype=float) * 1e-3 for f in filtered if f is not None]
    raw_vals = [np.asarray(f.values, dtype=float) * 1e-3 for f in raw if f is not None]
    if not filtered_vals or not raw_vals:
        return
    lo = min(float(np.nanmin(v)) for v in filtered_vals)
    hi = max(float(np.nanmax(v)) for v in filtered_vals)
    pad = max(0.75 * (hi - lo), 0.25 * max(abs(hi), abs(lo)), 1.0)
    bottom, top = lo - pad, hi + pad
    raw_lo = min(float(np.nanmin(v)) for v in raw_vals)
    raw_hi = max(float(np.nanmax(v)) for v in raw_vals)
    if raw_lo < bottom or raw_hi > top:
        ax.set_ylim(bottom, top)
        notes.append(f"raw impulses at span joints span {raw_lo:.0f} to {raw_hi:.0f} kN (clipped)")


def panel_carbody_az(ax: Axes, runs: Sequence[Run]) -> None:
    """Fig. 4(d): absolute vertical acceleration of the car body of car 1."""
    title = f"(d) Car-body vertical acceleration, car {_where(runs, 'car', 0)}"
    _time_history(ax, runs, "carbody_az", {"car": 0}, 1.0, "acceleration $a_z$ (m/s²)", title)


def panel_carbody_uz(ax: Axes, runs: Sequence[Run]) -> None:
    """Fig. 4(e): car-body bounce of car 1 from static equilibrium, all methods."""
    title = f"(e) Car-body vertical displacement, car {_where(runs, 'car', 0)}"
    _time_history(ax, runs, "carbody_uz", {"car": 0}, 1e3, "displacement $u_z$ (mm)", title)


def panel_carbody_uz_without_classic(ax: Axes, runs: Sequence[Run]) -> None:
    """Fig. 4(f): as (e) without the DAE solution (`coupled-classic`), whose drift hides the others."""
    kept = [run for run in runs if run.method != DRIFTING_METHOD]
    title = f"(f) Car-body vertical displacement, car {_where(runs, 'car', 0)}, without {DRIFTING_METHOD}"
    if not kept:
        _finish(ax, title, "displacement $u_z$ (mm)", [f"every run is {DRIFTING_METHOD}"])
        return
    _time_history(ax, kept, "carbody_uz", {"car": 0}, 1e3, "displacement $u_z$ (mm)", title)


GAP_PANELS = (
    ("gap_vehicle", "vehicle-contact gap, max over wheels", "|$g_N^V$| (m)"),
    ("gap_bridge", "bridge-contact gap, max over wheels in contact", "|$g_N^B$| (m)"),
    ("gap_support", "support gap, max over supports", "|$g^S$| (m)"),
)


def panel_gap(ax: Axes, runs: Sequence[Run], var: str, title: str, ylabel: str) -> None:
    """Constraint violation max |gap| per time step, log scale (Eqs. 18, 20-21 and 23)."""
    missing: list[str] = []
    clipped = False
    for run in runs:
        da = _max_abs_over(_in_contact_gaps(run.data), var)
        if da is None:
            missing.append(f"{var} missing in {run.label}")
            continue
        y = np.asarray(da.values, dtype=float)
        clipped |= bool(np.any(y < GAP_FLOOR_M))
        _draw(ax, da["time"], np.where(y < GAP_FLOOR_M, GAP_FLOOR_M, y), run.style, run.label)
    ax.set_yscale("log")
    _finish(ax, title, ylabel, _run_notes(runs, missing))
    if clipped:
        ax.text(
            0.995,
            0.02,
            f"values below {GAP_FLOOR_M:g} m (incl. exact zeros) drawn at {GAP_FLOOR_M:g} m",
            transform=ax.transAxes,
            ha="right",
            va="bottom",
            fontsize="x-small",
            color="0.3",
        )


# ----------------------------------------------------------------------------------------------
# Figures

SINGLE_SIZE = (10.0, 4.4)
PanelFn = Callable[[Axes, Sequence[Run]], None]
PANELS: dict[str, PanelFn] = {
    "fig4a_midspan_uz": panel_midspan_uz,
    "fig4b_midspan_ux": panel_midspan_ux,
    "fig4c_contact_force": panel_contact_force,
    "fig4d_carbody_az": panel_carbody_az,
    "fig4e_carbody_uz": panel_carbody_uz,
    "fig4f_carbody_uz_without_classic": panel_carbody_uz_without_classic,
}
OVERVIEW = "fig4_overview"
GAPS = "constraint_violation"
FIGURE_NAMES = (*PANELS, OVERVIEW, GAPS)
CONTACT = "wheel_lift_off"
"""Drawn in addition to FIGURE_NAMES when a wheel of any run lifts off (unilateral contact)."""
PIERS = "bridge_piers"
"""Drawn in addition when the first run's bridge has piers (``pier_top_ux``)."""


def lifts_off(ds: xr.Dataset) -> bool:
    """True when a wheel of the run left its rail (``contact_state`` has a 0)."""
    return "contact_state" in ds.variables and bool((ds["contact_state"] == 0).any())


def _wheel_of(ds: xr.Dataset, prefix: str) -> dict[str, int]:
    """The (car, wheel) named by the run's ``<prefix>_car`` / ``_wheel`` attributes (1-based)."""
    car = int(ds.attrs.get(f"{prefix}_car", 1))
    wheel = int(ds.attrs.get(f"{prefix}_wheel", 1))
    out = {"car": car - 1, "wheel": wheel - 1}
    if f"{prefix}_side" in ds.attrs:  # a 3D run: the wheel of the wheelset
        out["side"] = 0 if str(ds.attrs[f"{prefix}_side"]) == "left" else 1
    return out


def panel_airborne(ax: Axes, runs: Sequence[Run]) -> None:
    """Number of wheels in the air at each stored step (``1 - contact_state`` summed)."""
    missing: list[str] = []
    for run in runs:
        cs = run.data.get("contact_state")
        if cs is None:
            missing.append(f"contact_state missing in {run.label}")
            continue
        off = (1 - cs).sum(dim=[d for d in cs.dims if d != "time"])
        _draw(ax, cs["time"], np.asarray(off.values, dtype=float), run.style, run.label)
    _finish(ax, "Wheels in the air (contact_state = 0)", "airborne wheels", _run_notes(runs, missing))


def panel_uplift(ax: Axes, runs: Sequence[Run]) -> None:
    """Uplift of the wheel with each run's peak uplift."""
    missing: list[str] = []
    for run in runs:
        sel = _wheel_of(run.data, "peak_uplift")
        da = _series(run.data, "wheel_uplift", sel)
        if da is None:
            missing.append(f"wheel_uplift missing in {run.label}")
            continue
        label = f"{run.label} (car {sel['car'] + 1}, wheel {sel['wheel'] + 1})"
        _draw(ax, da["time"], np.asarray(da.values, dtype=float) * 1e3, run.style, label)
    _finish(ax, "Wheel uplift, wheel of the peak", "uplift (mm)", _run_notes(runs, missing))


def panel_unloading(ax: Axes, runs: Sequence[Run]) -> None:
    """Unloading ratio ``1 - P_filtered / P_static`` of the wheel with each run's peak."""
    missing: list[str] = []
    for run in runs:
        sel = _wheel_of(run.data, "peak_unloading_ratio")
        da = _series(run.data, "unloading_ratio", sel)
        if da is None:
            missing.append(f"unloading_ratio missing in {run.label}")
            continue
        label = f"{run.label} (car {sel['car'] + 1}, wheel {sel['wheel'] + 1})"
        _draw(ax, da["time"], np.asarray(da.values, dtype=float), run.style, label)
    ax.axhline(1.0, color="0.3", lw=0.8, ls=":")
    _finish(
        ax,
        "Unloading ratio 1 - P_filtered / P_static, wheel of the peak (1: fully unloaded)",
        "unloading ratio (-)",
        _run_notes(runs, missing),
    )


def _suptitle(fig: Figure, runs: Sequence[Run]) -> None:
    fig.suptitle(scenario_title(runs), fontsize="large", fontweight="bold")


def _shared_legend(fig: Figure, runs: Sequence[Run], raw_note: bool) -> None:
    """One legend for a figure of several panels, in place of a legend beside every panel."""
    for ax in fig.axes:
        if ax.get_legend() is not None:
            ax.get_legend().remove()
    handles: list[Line2D] = []
    for run in runs:
        handle = Line2D([], [], color=run.style.color, lw=run.style.width, label=run.label)
        if run.style.dashes is not None:
            handle.set_dashes(run.style.dashes)
        handles.append(handle)
    if raw_note:
        handles.append(
            Line2D([], [], color="0.5", lw=0.7, alpha=0.6, label="(c) thin, light: raw force; bold: filtered")
        )
    fig.legend(handles=handles, loc="outside lower center", ncols=len(handles), handlelength=4.0)


def make_figures(results: Results) -> dict[str, Figure]:
    """Every figure, keyed by file stem (FIGURE_NAMES): one per Fig. 4 panel, the 3×2 overview, gaps."""
    runs = make_runs(results)
    figures: dict[str, Figure] = {}
    for name, panel in PANELS.items():
        fig = Figure(figsize=SINGLE_SIZE, layout="constrained")
        panel(fig.add_subplot(), runs)
        _suptitle(fig, runs)
        figures[name] = fig
    fig = Figure(figsize=(16.0, 12.5), layout="constrained")
    for ax, panel in zip(fig.subplots(3, 2).ravel(), PANELS.values(), strict=True):
        panel(ax, runs)
    _suptitle(fig, runs)
    _shared_legend(fig, runs, raw_note=True)
    figures[OVERVIEW] = fig
    fig = Figure(figsize=(10.0, 9.5), layout="constrained")
    for ax, (var, title, ylabel) in zip(fig.subplots(3, 1, sharex=True), GAP_PANELS, strict=True):
        panel_gap(ax, runs, var, f"Constraint violation: {title}", ylabel)
        ax.label_outer()
    _suptitle(fig, runs)
    _shared_legend(fig, runs, raw_note=False)
    figures[GAPS] = fig
    if any(lifts_off(run.data) for run in runs):
        fig = Figure(figsize=(10.0, 9.5), layout="constrained")
        for ax, panel in zip(
            fig.subplots(3, 1, sharex=True), (panel_airborne, panel_uplift, panel_unloading), strict=True
        ):
            panel(ax, runs)
            ax.label_outer()
        _suptitle(fig, runs)
        figures[CONTACT] = fig
    if is_3d(runs[0].data):  # a 3D run: the lateral response and running safety
        figures[LATERAL] = lateral_figure(runs[0].data, scenario_title(runs[:1]))
    if "pier_top_ux" in runs[0].data:
        fig = Figure(figsize=(10.0, 7.5), layout="constrained")
        top, bottom = fig.subplots(2, 1, sharex=True)
        panel_piers(top, runs[0])
        panel_spans_relative(bottom, runs[0])
        bottom.label_outer()
        _suptitle(fig, runs[:1])
        figures[PIERS] = fig
    return figures


def _one_line_each(ax: Axes, t: xr.DataArray, rows: Sequence[tuple[np.ndarray, str]], cmap: str) -> None:
    """One line per row (values, label), coloured along ``cmap``."""
    colours = matplotlib.colormaps[cmap]
    for i, (y, label) in enumerate(rows):
        ax.plot(_seconds(t), y, color=colours(i / max(len(rows), 1)), lw=1.0, label=label)


def panel_piers(ax: Axes, run: Run) -> None:
    """Longitudinal displacement of every pier top, with the ground's (a long-form bridge)."""
    ds = run.data
    rows = [
        (
            np.asarray(ds["pier_top_ux"].isel(pier=i).values, dtype=float) * 1e3,
            f"pier {i + 1} (line {int(ds['pier_line'].values[i])})",
        )
        for i in range(ds.sizes["pier"])
    ]
    _one_line_each(ax, ds["time"], rows, "viridis")
    g = ds["ground_ux"]
    gx = g.values if g.ndim == 1 else g.isel(support=0).values
    ax.plot(
        _seconds(ds["time"]), np.asarray(gx, dtype=float) * 1e3, color="k", lw=1.0, ls="--", label="ground"
    )
    ax.legend(fontsize="small", ncols=4)
    _finish(ax, "Pier tops: longitudinal displacement (absolute)", "u (mm)", [])


def panel_spans_relative(ax: Axes, run: Run) -> None:
    """Vertical midspan deflection of every span relative to the ground under it."""
    ds = run.data
    rows = [
        (np.asarray(ds["midspan_uz_rel"].isel(span=i).values, dtype=float) * 1e3, f"span {i + 1}")
        for i in range(ds.sizes["span"])
    ]
    _one_line_each(ax, ds["time"], rows, "plasma")
    ax.legend(fontsize="small", ncols=5)
    _finish(ax, "Midspan deflection relative to the ground under each span", "w (mm)", [])


def save_figures(
    figures: Mapping[str, Figure], out_dir: str | os.PathLike[str], dpi: int = DPI
) -> list[Path]:
    """Write each figure as `<out_dir>/<name>.png` at `dpi`; returns the written paths in order."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths: list[Path] = []
    for name, fig in figures.items():
        path = out / f"{name}.png"
        write_atomic(path, lambda tmp, fig=fig: fig.savefig(tmp, format="png", dpi=dpi))
        paths.append(path)
    return paths


def plot_results(results: Results, out_dir: str | os.PathLike[str], dpi: int = DPI) -> list[Path]:
    """Draw every figure of FIGURE_NAMES for the runs and write them as PNG into `out_dir`."""
    return save_figures(make_figures(results), out_dir, dpi)


# ----------------------------------------------------------------------------------------------
# Summary

SUMMARY_ROWS: dict[str, str] = {
    "midspan_uz": "max |midspan_uz| span 1 (mm)",
    "midspan_ux": "max |midspan_ux| span 1 (mm)",
    "midspan_uz_rel": "max |midspan_uz_rel| span 1 (mm)",
    "midspan_ux_rel": "max |midspan_ux_rel| span 1 (mm)",
    "support_reaction": "max support reaction (kN)",
    "contact_force": "max contact force, all wheels (kN)",
    "contact_force_filtered": "max filtered contact force (kN)",
    "carbody_az": "max |carbody_az| car 1 (m/s2)",
    "gap_vehicle": "max |gap_vehicle| (m)",
    "gap_bridge": "max |gap_bridge|, wheels in contact (m)",
    "gap_support": "max |gap_support| (m)",
    "longest_flight_s": "longest flight (s)",
    "airborne_time_s": "time airborne, all wheels (s)",
    "liftoffs": "wheel lift-offs (not converged in dt)",
    "peak_uplift_m": "peak uplift (mm)",
    "peak_unloading_ratio": "peak unloading ratio",
    "setup_time_s": "set-up time (s)",
    "loop_time_s": "loop time (s)",
    "wall_time_s": "wall time (s)",
}
"""The timing rows: set-up (model build, initial state, compilation) is shown apart from the loop,
because the first run of a session pays one-time costs (imports, compile cache) the others do not."""


def summary_values(results: Results) -> dict[str, dict[str, float | None]]:
    """Peak values per run label, keyed as SUMMARY_ROWS, plus `wall_time_ratio` to localized-dynamic.

    None where a variable or attribute is absent (or, in a truncated run, never stored).
    """
    return _summary_values(make_runs(results))


def _summary_values(runs: Sequence[Run]) -> dict[str, dict[str, float | None]]:
    out: dict[str, dict[str, float | None]] = {}
    for run in runs:
        ds = run.data
        span1, car1 = {"span": 0}, {"car": 0}
        peaks: dict[str, tuple[xr.DataArray | None, float]] = {
            "midspan_uz": (_abs(_series(ds, "midspan_uz", span1)), 1e3),
            "midspan_ux": (_abs(_series(ds, "midspan_ux", span1)), 1e3),
            "midspan_uz_rel": (_abs(_series(ds, "midspan_uz_rel", span1)), 1e3),
            "midspan_ux_rel": (_abs(_series(ds, "midspan_ux_rel", span1)), 1e3),
            "support_reaction": (ds.get("support_reaction"), 1e-3),
            "contact_force": (ds.get("contact_force"), 1e-3),
            "contact_force_filtered": (ds.get("contact_force_filtered"), 1e-3),
            "carbody_az": (_abs(_series(ds, "carbody_az", car1)), 1.0),
            "gap_vehicle": (_max_abs_over(ds, "gap_vehicle"), 1.0),
            "gap_bridge": (_max_abs_over(_in_contact_gaps(ds), "gap_bridge"), 1.0),
            "gap_support": (_max_abs_over(ds, "gap_support"), 1.0),
        }
        values: dict[str, float | None] = {}
        for key, (da, scale) in peaks.items():
            peak = _scalar(da)
            values[key] = None if peak is None else peak * scale
        for key in (
            "setup_time_s",
            "loop_time_s",
            "wall_time_s",
            "liftoffs",
            "longest_flight_s",
            "airborne_time_s",
        ):
            values[key] = _attr_float(ds, key)
        up = _attr_float(ds, "peak_uplift_m")
        values["peak_uplift_m"] = None if up is None else up * 1e3
        values["peak_unloading_ratio"] = _attr_float(ds, "peak_unloading_ratio")
        out[run.label] = values
    reference = _reference(runs, out)
    for key in ("wall_time", "loop_time"):
        ref = out[reference][f"{key}_s"] if reference is not None else None
        for run in runs:
            own = out[run.label][f"{key}_s"]
            out[run.label][f"{key}_ratio"] = None if own is None or not ref else own / ref
    return out


def _speed_key(runs: Sequence[Run], values: Mapping[str, Mapping[str, float | None]]) -> str:
    """Compare methods by loop time when every run has it (results of svbi >= 0.1 with timings),
    else by wall time, which includes the set-up."""
    if runs and all(values[run.label].get("loop_time_s") is not None for run in runs):
        return "loop_time"
    return "wall_time"


def _abs(da: xr.DataArray | None) -> xr.DataArray | None:
    return None if da is None else abs(da)


def _attr_float(ds: xr.Dataset, name: str) -> float | None:
    try:
        value = float(np.asarray(ds.attrs[name]).ravel()[0])
    except (KeyError, TypeError, ValueError, IndexError):
        return None
    return value if math.isfinite(value) else None


def _reference(runs: Sequence[Run], values: Mapping[str, Mapping[str, float | None]]) -> str | None:
    """Label of the first localized-dynamic run with a positive wall time: the speed reference."""
    for run in runs:
        wall = values[run.label]["wall_time_s"]
        if run.method == REFERENCE_METHOD and wall is not None and wall > 0:
            return run.label
    return None


def _fmt(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.6g}"


def summary_text(results: Results) -> str:
    """A table with one column per run: peak responses, max |gap|, timings and the speed ratio.

    Rows are those of SUMMARY_ROWS, plus method, backend, complete, and, when a localized-dynamic
    run is present, the loop-time ratio to it (the wall-time ratio for results without
    ``loop_time_s``) (the paper reports localized ≈ 2× faster than
    coupled-dynamic, Section 5). Columns are separated by at least two spaces.
    """
    runs = make_runs(results)
    values = _summary_values(runs)
    reference = _reference(runs, values)
    rows: list[tuple[str, list[str]]] = [
        ("run", [run.label for run in runs]),
        ("method", [run.method or "n/a" for run in runs]),
        ("backend", [str(run.data.attrs.get("backend", "n/a")) for run in runs]),
        ("complete", ["yes" if run.complete else "no" for run in runs]),
    ]
    rows += [(name, [_fmt(values[run.label][key]) for run in runs]) for key, name in SUMMARY_ROWS.items()]
    if reference is not None:
        key = _speed_key(runs, values)
        rows.append(
            (
                f"{key.replace('_', ' ')} / {reference}",
                [_fmt(values[run.label][f"{key}_ratio"]) for run in runs],
            )
        )
    first = max(len(name) for name, _ in rows)
    widths = [max(len(cells[i]) for _, cells in rows) for i in range(len(runs))]
    lines = [f"Summary: {scenario_title(runs)}"]
    for name, cells in rows:
        lines.append(
            name.ljust(first) + "".join("  " + cell.rjust(w) for cell, w in zip(cells, widths, strict=True))
        )
    if not all(run.complete for run in runs):
        lines.append("complete = no: the run stopped early; values cover the stored part only.")
        for run in runs:
            if not run.complete and str(run.data.attrs.get("incomplete", "")).strip():
                lines.append(f"  {run.label}: {str(run.data.attrs['incomplete']).strip()}")
    return "\n".join(lines) + "\n"
