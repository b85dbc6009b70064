"""Pictures of a sweep store (``svbi plot OUT.nc``): a metric against one axis, and fragility curves.

* **Metric against an axis** (the EN 1991-2 dynamic-check figure): the metric's worst value over
  spans, cars and wheels, one curve per value of a second axis (e.g. one per HSLM train) with their
  envelope, the maximum over every other axis (named on the figure), and the limit as a horizontal
  line labelled with its value, unit and clause. Axes are labelled with their quantity and unit
  (``train speed (km/h)``; a scale of the ground motion is drawn as the PGA it gives, in m/s²).
* **Fragility curve**: the fraction of runs whose metric exceeds a limit at each level of an
  intensity axis (e.g. ``earthquake.scale``), over every other axis (records, speeds, seeds), with
  the counts ``k/n`` and their 95 % Wilson intervals, and the lognormal fragility
  ``P(exceed | x) = Φ(ln(x / θ) / β)`` fitted by maximum likelihood to the binomial counts (Baker
  2015, Earthquake Spectra 31(1)) with a 90 % bootstrap band (counts resampled per level), drawn over
  the levels run. A run that diverged counts as exceeding; a failed run (no result) is left out.
"""

from __future__ import annotations

import json
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
PER_RUN_DIMS = ("span", "car", "wheel", "side", "end", "joint", "pier")
INTENSITY_KEYS = ("earthquake.scale", "earthquake.target_pga", "earthquake.vertical_scale")
"""Axes taken as the intensity of a fragility curve when none is named."""
SPEED_KEYS = ("train.speed_kmh", "train.speed")
SCALE_KEYS = ("earthquake.scale", "earthquake.vertical_scale")
G = 9.80665
"""Standard gravity, m/s² (PGA in g)."""
UNIT_TEXT = {"m/s^2": "m/s²", "m^2": "m²", "m^4": "m⁴"}
BOOTSTRAP = 200
"""Resamples of the fragility counts for the fit's band."""


def _unit(units: str) -> str:
    return UNIT_TEXT.get(units, units)


def axis_keys(store: xr.Dataset) -> dict[str, str]:
    """Dimension or coordinate name -> the dotted scenario key it sweeps (stores of earlier versions
    named their dimensions by the keys themselves)."""
    keys = json.loads(store.attrs.get("axis_keys", "{}") or "{}")
    for name in axes_of(store):
        keys.setdefault(name, str(store[name].attrs.get("scenario_key", name)) if name in store else name)
    return keys


def dim_of(store: xr.Dataset, name: str) -> str:
    """The store's dimension for ``name``: a dimension name, or the dotted key it sweeps."""
    if name in store.dims:
        return name
    for dim, key in axis_keys(store).items():
        if key == name and dim in store.dims:
            return dim
    raise ValueError(f"axis {name!r} is not a dimension of the store ({', '.join(axes_of(store))})")


def _find(store: xr.Dataset, keys: tuple[str, ...], exclude: tuple[str | None, ...] = ()) -> str | None:
    for dim, key in axis_keys(store).items():
        if key in keys and dim in store.dims and dim not in exclude:
            return dim
    return None


def worst(store: xr.Dataset, metric: str) -> xr.DataArray:
    """The metric's worst value per run: max (min for a minimum force) over spans, cars, wheels (and
    sides, of a 3D run)."""
    if metric not in store:
        known = [v for v in store.data_vars if not v.endswith("_time") and v not in ("status", "message")]
        raise ValueError(f"metric {metric!r} is not in the store (it has {', '.join(known)})")
    da = store[metric]
    dims = [d for d in da.dims if d in PER_RUN_DIMS]
    return da.min(dims, skipna=True) if metric in WORST_IS_MIN else da.max(dims, skipna=True)


def _scenario(store: xr.Dataset) -> dict:
    import tomllib

    try:
        table = tomllib.loads(str(store.attrs.get("scenario", "")))
    except tomllib.TOMLDecodeError:
        table = {}
    for key, value in json.loads(store.attrs.get("set", "{}") or "{}").items():  # svbi sweep --set
        node = table
        *head, last = key.split(".")
        for part in head:
            node = node.setdefault(part, {}) if isinstance(node.get(part, {}), dict) else {}
        node[last] = value
    return table


def default_limit(store: xr.Dataset, metric: str) -> float | None:
    """The EN 1990 limit of a metric (deck acceleration by the scenario's track form)."""
    found = _limit(store, metric)
    return None if found is None else found[0]


def _limit(store: xr.Dataset, metric: str) -> tuple[float, str] | None:
    """The EN 1990 limit of a metric and where it comes from."""
    if metric == "peak_deck_acceleration":
        form = _scenario(store).get("bridge", {}).get("track_form") or "ballasted"
        value = DECK_ACCELERATION_LIMIT.get(form)
        return None if value is None else (value, f"EN 1990 A2.4.4.2.1(4), {form} track")
    if metric == "peak_carbody_az":
        return COMFORT_LEVELS["acceptable"], "EN 1990 Table A2.9, comfort acceptable"
    if metric == "max_unloading_ratio":
        return UNLOADING_LIMITS[-1], "running safety, transient loading"
    return None


def limit_label(store: xr.Dataset, metric: str, limit: float) -> str:
    """``limit 3.5 m/s² (EN 1990 A2.4.4.2.1(4), ballasted track)``: value, unit and clause."""
    units = _unit(str(store[metric].attrs.get("units", ""))) if metric in store else ""
    units = "" if units == "1" else units
    text = f"limit {limit:g}" + (f" {units}" if units else "")
    found = _limit(store, metric)
    if found is not None and math.isclose(found[0], limit):
        return f"{text} ({found[1]})"
    for level, value in COMFORT_LEVELS.items():
        if metric == "peak_carbody_az" and math.isclose(value, limit):
            return f"{text} (EN 1990 Table A2.9, comfort {level.replace('-', ' ')})"
    return f"{text} (given)"


def axes_of(store: xr.Dataset) -> list[str]:
    return list(json.loads(store.attrs["axes"]))


def axis_values(store: xr.Dataset, dim: str) -> tuple[np.ndarray, str]:
    """The values drawn along ``dim`` and the axis label with its unit. A scale of the ground motion
    is drawn as the peak ground acceleration it gives (scale x earthquake.target_pga) when the
    scenario sets a target PGA; otherwise as the scale itself."""
    values = np.asarray(store[dim].values)
    key = axis_keys(store).get(dim, dim)
    attrs = store[dim].attrs
    if key in SCALE_KEYS:
        eq = _scenario(store).get("earthquake", {})
        pga = eq.get("target_pga")
        if isinstance(pga, int | float) and not isinstance(pga, bool):
            what = "PGA" if key == "earthquake.scale" else "vertical PGA"
            return values.astype(float) * float(pga), f"{what} (m/s²) = {dim} × {float(pga):g} m/s²"
        return values, f"{attrs.get('long_name', key)} (× the record)"
    if key == "earthquake.target_pga":
        return values, "PGA (m/s²)"
    name = str(attrs.get("long_name", key))
    units = _unit(str(attrs.get("units", "")))
    return values, f"{name} ({units})" if units and units != "1" else name


def _label(store: xr.Dataset, metric: str) -> str:
    attrs = store[metric].attrs
    units = _unit(str(attrs.get("units", "")))
    return f"{metric} ({units})" if units and units != "1" else metric


def _maximised(store: xr.Dataset, metric: str, others: list[str]) -> str:
    """`worst over span, seed (5 values)`: what a curve's every point is the worst of."""
    words = []
    per_run = [d for d in store[metric].dims if d in PER_RUN_DIMS and store.sizes[d] > 1]
    words += per_run
    words += [f"{d} ({store.sizes[d]} values)" for d in others]
    how = "min" if metric in WORST_IS_MIN else "max"
    return f"{how} over {', '.join(words)}" if words else ""


def plot_metric_vs_axis(
    store: xr.Dataset, metric: str, axis: str, by: str | None = None, limit: float | None = None
) -> Figure:
    """A metric against one axis, one curve per value of ``by`` (and their envelope), worst over the
    other axes (named under the title), with the limit line labelled with value, unit and clause."""
    axis = dim_of(store, axis)
    by = dim_of(store, by) if by is not None else None
    w = worst(store, metric)
    others = [d for d in w.dims if d not in (axis, by)]
    reduce = w.min if metric in WORST_IS_MIN else w.max
    w = reduce(others, skipna=True) if others else w
    fig = Figure(figsize=(7.5, 4.8), layout="constrained")
    ax = fig.add_subplot()
    x, xlabel = axis_values(store, axis)
    if by is None:
        ax.plot(x, w.transpose(axis).values, marker="o", ms=3)
    else:
        for i, value in enumerate(store[by].values):
            y = w.isel({by: i}).transpose(axis).values
            ax.plot(x, y, marker="o", ms=2.5, lw=1.0, label=str(value))
        envelope = (w.min if metric in WORST_IS_MIN else w.max)(by, skipna=True).transpose(axis).values
        what = "HSLM trains" if axis_keys(store).get(by) == "train.hslm" else f"values of {by}"
        ax.plot(x, envelope, color="k", lw=2.2, label=f"envelope of the {store.sizes[by]} {what}")
        ax.legend(fontsize="small", ncols=2, title=by, title_fontsize="small")
    if limit is not None:
        label = limit_label(store, metric, limit)
        ax.axhline(limit, color="firebrick", ls="--", lw=1.2)
        ax.annotate(
            label, (0.01, limit), xycoords=("axes fraction", "data"), textcoords="offset points",
            xytext=(0, 3), fontsize="small", color="firebrick",
        )  # fmt: skip
    ax.set_xlabel(xlabel)
    ax.set_ylabel(_label(store, metric))
    title = str(store.attrs.get("title") or "")
    over = _maximised(store, metric, others)
    heading = f"{metric} against {axis}" + (f"\n{title}" if title else "") + (f"\n{over}" if over else "")
    ax.set_title(heading, fontsize="medium")
    ax.grid(True, lw=0.4, alpha=0.5)
    return fig


@dataclass(frozen=True)
class Fragility:
    """Counts per intensity level and the lognormal fragility fitted to them: median ``theta`` and
    log standard deviation ``beta`` (NaN when the counts cannot determine a fit, ``why`` says why)."""

    levels: np.ndarray
    trials: np.ndarray
    exceed: np.ndarray
    theta: float
    beta: float
    why: str = ""

    @property
    def fitted(self) -> bool:
        return math.isfinite(self.theta) and math.isfinite(self.beta)

    def probability(self, x: np.ndarray) -> np.ndarray:
        from scipy.stats import norm

        return norm.cdf(np.log(np.asarray(x, dtype=float) / self.theta) / self.beta)


def wilson_interval(
    exceed: np.ndarray, trials: np.ndarray, z: float = 1.959964
) -> tuple[np.ndarray, np.ndarray]:
    """The Wilson score interval of binomial fractions (95 % by default); NaN where no trials."""
    k = np.asarray(exceed, dtype=float)
    n = np.asarray(trials, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = k / n
        centre = (p + z * z / (2 * n)) / (1 + z * z / n)
        half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return centre - half, centre + half


def fit_lognormal(levels: np.ndarray, trials: np.ndarray, exceed: np.ndarray) -> tuple[float, float]:
    """Maximum-likelihood median θ and β of ``P = Φ(ln(x/θ)/β)`` from binomial counts (Baker 2015).

    Raises ValueError when the counts cannot determine the fit (every run exceeds, or none does).
    """
    from scipy.optimize import minimize
    from scipy.special import log_ndtr  # norm.logcdf's own function, without scipy.stats' per-call checks

    x = np.asarray(levels, dtype=float)
    n = np.asarray(trials, dtype=float)
    z = np.asarray(exceed, dtype=float)
    keep = (n > 0) & (x > 0)
    x, n, z = x[keep], n[keep], z[keep]
    if z.sum() == 0 or z.sum() == n.sum():
        raise ValueError("no fragility fit: every run exceeds the limit, or none does")

    def nll(p: np.ndarray) -> float:
        u = (np.log(x) - p[0]) / math.exp(p[1])
        return -float(np.sum(z * log_ndtr(u) + (n - z) * log_ndtr(-u)))

    # start from the level nearest to half exceeding, β = 0.5
    frac = z / n
    start = np.array([math.log(x[np.argmin(np.abs(frac - 0.5))]), math.log(0.5)])
    res = minimize(
        nll, start, method="Nelder-Mead", options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 4000}
    )
    return math.exp(res.x[0]), math.exp(res.x[1])


def bootstrap_band(
    fr: Fragility, x: np.ndarray, resamples: int = BOOTSTRAP, seed: int = 0
) -> tuple[np.ndarray, np.ndarray] | None:
    """A 90 % band of the fitted curve at ``x``: the counts resampled per level (binomial with the
    observed fraction), refitted; None when fewer than half the resamples can be fitted."""
    from scipy.special import ndtr  # norm.cdf

    rng = np.random.default_rng(seed)
    n = np.asarray(fr.trials, dtype=int)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = np.where(n > 0, fr.exceed / np.maximum(n, 1), 0.0)
    curves = []
    for _ in range(resamples):
        k = rng.binomial(n, p)
        try:
            theta, beta = fit_lognormal(fr.levels, n, k)
        except ValueError:
            continue
        curves.append(ndtr(np.log(x / theta) / beta))
    if len(curves) < resamples // 2:
        return None
    stack = np.array(curves)
    return np.percentile(stack, 5, axis=0), np.percentile(stack, 95, axis=0)


def fragility(store: xr.Dataset, metric: str, intensity: str, limit: float) -> Fragility:
    """Counts of runs exceeding ``limit`` per level of ``intensity`` and their lognormal fit (NaN,
    with the reason, when every run exceeds or none does)."""
    try:
        intensity = dim_of(store, intensity)
    except ValueError:
        raise ValueError(f"intensity axis {intensity!r} is not a dimension of the store") from None
    w = worst(store, metric)
    status = store["status"]
    exceeded = (w < limit) if metric in WORST_IS_MIN else (w > limit)
    exceeded = exceeded | (status == "diverged")
    valid = (status == "ok") | (status == "diverged")
    others = [d for d in status.dims if d != intensity]
    trials = valid.sum(others) if others else valid.astype(int)
    exceed = (exceeded & valid).sum(others) if others else (exceeded & valid).astype(int)
    levels, _ = axis_values(store, intensity)
    levels = np.asarray(levels, dtype=float)
    try:
        theta, beta = fit_lognormal(levels, trials.values, exceed.values)
        why = ""
    except ValueError as exc:
        theta = beta = float("nan")
        why = str(exc)
    return Fragility(levels, np.asarray(trials.values), np.asarray(exceed.values), theta, beta, why)


def plot_fragility(
    fr: Fragility, metric: str, intensity: str, limit: float, title: str = "", xlabel: str | None = None,
    limit_text: str | None = None,
) -> Figure:  # fmt: skip
    """The fractions exceeding with their counts and Wilson intervals, the fit and its band."""
    fig = Figure(figsize=(7.0, 4.8), layout="constrained")
    ax = fig.add_subplot()
    frac = fr.exceed / np.maximum(fr.trials, 1)
    lo, hi = wilson_interval(fr.exceed, fr.trials)
    ok = fr.trials > 0
    ax.errorbar(
        fr.levels[ok], frac[ok], yerr=[frac[ok] - lo[ok], hi[ok] - frac[ok]], fmt="o", capsize=3,
        label="fraction of runs exceeding (95 % Wilson interval)",
    )  # fmt: skip
    for x, k, n in zip(fr.levels, fr.exceed, fr.trials, strict=True):
        ax.annotate(f"{int(k)}/{int(n)}", (x, k / max(n, 1)), textcoords="offset points", xytext=(4, -10),
                    fontsize="x-small")  # fmt: skip
    if fr.fitted:
        positive = fr.levels[fr.levels > 0]
        x = np.linspace(positive.min(), positive.max(), 200)  # over the levels run, no further
        band = bootstrap_band(fr, x)
        if band is not None:
            ax.fill_between(x, band[0], band[1], color="C1", alpha=0.2, lw=0, label="90 % bootstrap band")
        ax.plot(x, fr.probability(x), "-", color="C1",
                label=f"lognormal fit: median {fr.theta:.4g}, β = {fr.beta:.3g}")  # fmt: skip
    else:
        ax.text(0.02, 0.95, fr.why, transform=ax.transAxes, fontsize="small", va="top")
    ax.set_xlabel(xlabel or intensity)
    ax.set_ylabel(f"P({metric} > {limit:g})")
    ax.set_ylim(-0.02, 1.02)
    head = "fragility" + (f": {limit_text}" if limit_text else "")
    ax.set_title(head + (f"\n{title}" if title else ""), fontsize="medium")
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
    axis, else the first), one curve per ``by`` (default: the HSLM train axis or the second axis),
    and a fragility curve against ``intensity`` (default: an earthquake scale axis, if any).
    Axes may be named by dimension (``speed_kmh``) or by scenario key (``train.speed_kmh``)."""
    dims = axes_of(store)
    axis = dim_of(store, axis) if axis is not None else (_find(store, SPEED_KEYS) or dims[0])
    if by is None:
        by = _find(store, ("train.hslm",), exclude=(axis,))
        if by is None:
            keys = axis_keys(store)
            by = next((d for d in dims if d != axis and keys.get(d, d) not in INTENSITY_KEYS), None)
    else:
        by = dim_of(store, by)
    if limit is None:
        limit = default_limit(store, metric)
    written = [save(plot_metric_vs_axis(store, metric, axis, by, limit), out_dir / f"{metric}_vs_{axis}.png")]
    lines = [f"{metric} against {axis}" + (f", one curve per {by}" if by else "")]
    intensity = dim_of(store, intensity) if intensity is not None else _find(store, INTENSITY_KEYS)
    if intensity is not None and limit is not None:
        fr = fragility(store, metric, intensity, limit)
        title = str(store.attrs.get("title") or "")
        _, xlabel = axis_values(store, intensity)
        fig = plot_fragility(fr, metric, intensity, limit, title, xlabel, limit_label(store, metric, limit))
        written.append(save(fig, out_dir / f"fragility_{metric}.png"))
        head = f"fragility of {metric} > {limit:g} against {xlabel}: "
        lines.append(head + (f"median {fr.theta:.4g}, beta {fr.beta:.3g}" if fr.fitted else fr.why))
        lines += [f"  {x:g}: {e}/{n} exceed" for x, n, e in zip(fr.levels, fr.trials, fr.exceed, strict=True)]
    return written, "\n".join(lines) + "\n"
