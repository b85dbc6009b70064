"""Pictures of a sweep store (``svbi plot OUT.nc``): a metric against one axis, and fragility curves.

* **Metric against an axis** (the EN 1991-2 dynamic-check figure): the metric's worst value over
  spans, cars and wheels, one curve per value of a second axis (e.g. one per HSLM train), the
  maximum over every other axis, with the limit as a horizontal line.
* **Fragility curve**: the fraction of runs whose metric exceeds a limit at each level of an
  intensity axis (e.g. ``earthquake.scale``), over every other axis (records, speeds, seeds), with
  the lognormal fragility ``P(exceed | x) = Φ(ln(x / θ) / β)`` fitted by maximum likelihood to the
  binomial counts (Baker 2015, Earthquake Spectra 31(1)); the figure gives the median θ and β. A
  run that diverged counts as exceeding; a failed run (no result) is left out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from ..run.atomic import write_atomic
from ..study.en1990 import COMFORT_LEVELS, DECK_ACCELERATION_LIMIT, UNLOADING_LIMITS

DPI = 150
WORST_IS_MIN = {"min_contact_force_filtered"}
PER_RUN_DIMS = ("span", "car", "wheel")
INTENSITY_KEYS = ("earthquake.scale", "earthquake.target_pga", "earthquake.vertical_scale")
"""Axes taken as the intensity of a fragility curve when none is named."""


def worst(store: xr.Dataset, metric: str) -> xr.DataArray:
    """The metric's worst value per run: max (min for a minimum force) over spans, cars, wheels."""
    if metric not in store:
        known = [v for v in store.data_vars if not v.endswith("_time") and v not in ("status", "message")]
        raise ValueError(f"metric {metric!r} is not in the store (it has {', '.join(known)})")
    da = store[metric]
    dims = [d for d in da.dims if d in PER_RUN_DIMS]
    return da.min(dims, skipna=True) if metric in WORST_IS_MIN else da.max(dims, skipna=True)


def default_limit(store: xr.Dataset, metric: str) -> float | None:
    """The EN 1990 limit of a metric (deck acceleration by the scenario's track form)."""
    if metric == "peak_deck_acceleration":
        import tomllib

        try:
            form = tomllib.loads(str(store.attrs.get("scenario", ""))).get("bridge", {}).get("track_form")
        except tomllib.TOMLDecodeError:
            form = None
        return DECK_ACCELERATION_LIMIT.get(form or "ballasted")
    if metric == "peak_carbody_az":
        return COMFORT_LEVELS["acceptable"]
    if metric == "max_unloading_ratio":
        return UNLOADING_LIMITS[-1]
    return None


def axes_of(store: xr.Dataset) -> list[str]:
    import json

    return list(json.loads(store.attrs["axes"]))


def plot_metric_vs_axis(
    store: xr.Dataset, metric: str, axis: str, by: str | None = None, limit: float | None = None
) -> Figure:
    """A metric against one axis, one curve per value of ``by``, worst over the other axes."""
    if axis not in store.dims:
        raise ValueError(f"axis {axis!r} is not a dimension of the store ({', '.join(axes_of(store))})")
    w = worst(store, metric)
    others = [d for d in w.dims if d not in (axis, by)]
    reduce = w.min if metric in WORST_IS_MIN else w.max
    w = reduce(others, skipna=True) if others else w
    fig = Figure(figsize=(7.5, 4.5), layout="constrained")
    ax = fig.add_subplot()
    x = np.asarray(store[axis].values)
    if by is None:
        ax.plot(x, w.transpose(axis).values, marker="o", ms=3)
    else:
        for i, value in enumerate(store[by].values):
            y = w.isel({by: i}).transpose(axis).values
            ax.plot(x, y, marker="o", ms=3, label=str(value))
        ax.legend(fontsize="small", ncols=2, title=by, title_fontsize="small")
    if limit is not None:
        ax.axhline(limit, color="k", ls="--", lw=1.2, label="limit")
        ax.annotate(
            f"limit {limit:g}", (x[0], limit), textcoords="offset points", xytext=(2, 3), fontsize="small"
        )
    units = store[metric].attrs.get("units", "")
    ax.set_xlabel(axis)
    ax.set_ylabel(f"{metric} ({units})" if units else metric)
    title = str(store.attrs.get("title") or "")
    ax.set_title(f"{metric} against {axis}" + (f"\n{title}" if title else ""), fontsize="medium")
    ax.grid(True, lw=0.4, alpha=0.5)
    return fig


@dataclass(frozen=True)
class Fragility:
    """Lognormal fragility fitted to counts: median ``theta`` and log standard deviation ``beta``."""

    levels: np.ndarray
    trials: np.ndarray
    exceed: np.ndarray
    theta: float
    beta: float

    def probability(self, x: np.ndarray) -> np.ndarray:
        from scipy.stats import norm

        return norm.cdf(np.log(np.asarray(x, dtype=float) / self.theta) / self.beta)


def fit_lognormal(levels: np.ndarray, trials: np.ndarray, exceed: np.ndarray) -> tuple[float, float]:
    """Maximum-likelihood median θ and β of ``P = Φ(ln(x/θ)/β)`` from binomial counts (Baker 2015).

    Raises ValueError when the counts cannot determine the fit (every run exceeds, or none does).
    """
    from scipy.optimize import minimize
    from scipy.stats import norm

    x = np.asarray(levels, dtype=float)
    n = np.asarray(trials, dtype=float)
    z = np.asarray(exceed, dtype=float)
    keep = (n > 0) & (x > 0)
    x, n, z = x[keep], n[keep], z[keep]
    if z.sum() == 0 or z.sum() == n.sum():
        raise ValueError("no fragility fit: every run exceeds the limit, or none does")

    def nll(p: np.ndarray) -> float:
        u = (np.log(x) - p[0]) / math.exp(p[1])
        return -float(np.sum(z * norm.logcdf(u) + (n - z) * norm.logsf(u)))

    # start from the level nearest to half exceeding, β = 0.5
    frac = z / n
    start = np.array([math.log(x[np.argmin(np.abs(frac - 0.5))]), math.log(0.5)])
    res = minimize(
        nll, start, method="Nelder-Mead", options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 4000}
    )
    return math.exp(res.x[0]), math.exp(res.x[1])


def fragility(store: xr.Dataset, metric: str, intensity: str, limit: float) -> Fragility:
    """Counts of runs exceeding ``limit`` per level of ``intensity`` and their lognormal fit."""
    if intensity not in store.dims:
        raise ValueError(f"intensity axis {intensity!r} is not a dimension of the store")
    w = worst(store, metric)
    status = store["status"]
    exceeded = (w < limit) if metric in WORST_IS_MIN else (w > limit)
    exceeded = exceeded | (status == "diverged")
    valid = (status == "ok") | (status == "diverged")
    others = [d for d in status.dims if d != intensity]
    trials = valid.sum(others) if others else valid.astype(int)
    exceed = (exceeded & valid).sum(others) if others else (exceeded & valid).astype(int)
    levels = np.asarray(store[intensity].values, dtype=float)
    theta, beta = fit_lognormal(levels, trials.values, exceed.values)
    return Fragility(levels, np.asarray(trials.values), np.asarray(exceed.values), theta, beta)


def plot_fragility(fr: Fragility, metric: str, intensity: str, limit: float, title: str = "") -> Figure:
    fig = Figure(figsize=(7.0, 4.5), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(fr.levels, fr.exceed / np.maximum(fr.trials, 1), "o", label="fraction of runs exceeding")
    x = np.linspace(max(fr.levels.min() * 0.5, 1e-9), fr.levels.max() * 1.5, 200)
    ax.plot(x, fr.probability(x), "-", label=f"lognormal fit: median {fr.theta:.4g}, β = {fr.beta:.3g}")
    ax.set_xlabel(intensity)
    ax.set_ylabel(f"P({metric} exceeds {limit:g})")
    ax.set_ylim(-0.02, 1.02)
    ax.set_title("fragility" + (f"\n{title}" if title else ""), fontsize="medium")
    ax.grid(True, lw=0.4, alpha=0.5)
    ax.legend(fontsize="small", loc="lower right")
    return fig


def save(fig: Figure, path: Path) -> Path:
    return write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=DPI, format=path.suffix.lstrip(".")))


def plot_store(
    store: xr.Dataset,
    out_dir: Path,
    metric: str = "peak_deck_acceleration",
    axis: str | None = None,
    by: str | None = None,
    limit: float | None = None,
    intensity: str | None = None,
) -> tuple[list[Path], str]:
    """The figures of a sweep (and a text summary): the metric against ``axis`` (default: a speed
    axis, else the first), one curve per ``by`` (default: ``train.hslm`` or the second axis), and a
    fragility curve against ``intensity`` (default: an earthquake scale axis, if any)."""
    dims = axes_of(store)
    if axis is None:
        axis = next((d for d in dims if d in ("train.speed_kmh", "train.speed")), dims[0])
    if by is None:
        by = next((d for d in dims if d == "train.hslm" and d != axis), None)
        if by is None:
            by = next((d for d in dims if d != axis and d not in INTENSITY_KEYS), None)
    if limit is None:
        limit = default_limit(store, metric)
    written = [save(plot_metric_vs_axis(store, metric, axis, by, limit), out_dir / f"{metric}_vs_{axis}.png")]
    lines = [f"{metric} against {axis}" + (f", one curve per {by}" if by else "")]
    if intensity is None:
        intensity = next((d for d in dims if d in INTENSITY_KEYS), None)
    if intensity is not None and limit is not None:
        fr = fragility(store, metric, intensity, limit)
        title = str(store.attrs.get("title") or "")
        written.append(
            save(plot_fragility(fr, metric, intensity, limit, title), out_dir / f"fragility_{metric}.png")
        )
        lines.append(
            f"fragility of {metric} > {limit:g} against {intensity}: "
            f"median {fr.theta:.4g}, beta {fr.beta:.3g}"
        )
        lines += [f"  {x:g}: {e}/{n} exceed" for x, n, e in zip(fr.levels, fr.trials, fr.exceed, strict=True)]
    return written, "\n".join(lines) + "\n"
