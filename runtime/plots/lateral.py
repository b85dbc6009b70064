"""The lateral response and running-safety indices of a 3D run, as the paper's Fig. 4 is for the
vertical response (docs/three-d.md, "Results of a 3D run").

Four panels over time: (a) the derailment quotient Y/Q of the wheel with the run's peak (and its
2 m sliding mean), with Nadal's limit and the EN 14363 limit of ``(Y/Q)_2m``; (b) the track-shift
force ΣY of the wheelset with the peak (and its 2 m mean) within ± Prud'homme's limit of that
wheelset; (c) the car-body lateral acceleration of every car; (d) the lateral displacement and the
twist at midspan of the span that sways most.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from matplotlib.figure import Figure

from ..run.results3d import prudhomme_limit, sum_y_variable
from ..study.en1990 import EN14363_QUOTIENT_LIMIT, NADAL_LIMIT, PRUDHOMME_ALPHA

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.axes import Axes

LATERAL = "lateral_running_safety"
"""The file stem of the figure (drawn for results that carry ``derailment_quotient``)."""


def is_3d(ds: xr.Dataset) -> bool:
    """Whether the results are a 3D run's (they carry the lateral running-safety variables)."""
    return "derailment_quotient" in ds.variables


def _sel(ds: xr.Dataset, prefix: str, side: bool = True) -> dict[str, object]:
    """The (car, wheel[, side]) of the attributes ``<prefix>_car`` ... (the first when absent)."""
    out: dict[str, object] = {
        "car": int(ds.attrs.get(f"{prefix}_car", ds["car"].values[0])),
        "wheel": int(ds.attrs.get(f"{prefix}_wheel", ds["wheel"].values[0])),
    }
    if side:
        out["side"] = str(ds.attrs.get(f"{prefix}_side", "left"))
    return out


def _t(ds: xr.Dataset) -> np.ndarray:
    return np.asarray(ds["time"].values, dtype=float)


def panel_quotient(ax: Axes, ds: xr.Dataset) -> None:
    """(a) Y/Q of the wheel with the peak, its 2 m mean, Nadal's and EN 14363's limits."""
    sel = _sel(ds, "peak_derailment_quotient")
    where = f"car {sel['car']}, wheelset {sel['wheel']}, {sel['side']}"
    ax.plot(_t(ds), ds["derailment_quotient"].sel(sel).values, lw=0.8, color="C0", label=f"Y/Q ({where})")
    if "derailment_quotient_2m" in ds.variables:
        ax.plot(
            _t(ds), ds["derailment_quotient_2m"].sel(sel).values, lw=1.6, color="C1", label="(Y/Q) 2 m mean"
        )
    ax.axhline(NADAL_LIMIT, color="C3", ls="--", lw=1.0, label=f"Nadal {NADAL_LIMIT:g}")
    ax.axhline(
        EN14363_QUOTIENT_LIMIT,
        color="C3",
        ls=":",
        lw=1.0,
        label=f"EN 14363 (Y/Q)_2m {EN14363_QUOTIENT_LIMIT:g}",
    )
    ax.set_ylabel("Y/Q (-)")
    ax.set_title("(a) Derailment quotient, wheel of the peak (Y outwards)")
    ax.legend(fontsize="small", loc="upper right")
    ax.grid(True, lw=0.3)


def panel_track_shift(ax: Axes, ds: xr.Dataset, alpha: float = PRUDHOMME_ALPHA) -> None:
    """(b) ΣY (filtered forces) of the wheelset with the peak, its 2 m mean and ± Prud'homme's limit (kN)."""
    sel = _sel(ds, "peak_axle_lateral_force", side=False)
    sum_y = sum_y_variable(ds.variables)  # the one whose peak the summary names
    filtered = sum_y == "axle_lateral_force_filtered"
    ax.plot(
        _t(ds),
        1e-3 * ds[sum_y].sel(sel).values,
        lw=0.8,
        color="C0",
        label=f"sum Y{', filtered' if filtered else ''} (car {sel['car']}, wheelset {sel['wheel']})",
    )
    if "axle_lateral_force_2m" in ds.variables:
        ax.plot(
            _t(ds), 1e-3 * ds["axle_lateral_force_2m"].sel(sel).values, lw=1.6, color="C1", label="2 m mean"
        )
    p0 = float(ds["static_wheel_load"].sel(sel).sum().values)
    limit = 1e-3 * float(prudhomme_limit(p0, alpha))
    for sign in (1.0, -1.0):
        ax.axhline(
            sign * limit,
            color="C3",
            ls="--",
            lw=1.0,
            label=f"Prud'homme {alpha:g} (10 + P0/3) = {limit:.4g} kN" if sign > 0 else None,
        )
    ax.set_ylabel("sum Y (kN), + left")
    ax.set_title("(b) Track-shift force of the wheelset with the peak")
    ax.legend(fontsize="small", loc="upper right")
    ax.grid(True, lw=0.3)


def panel_carbody_ay(ax: Axes, ds: xr.Dataset) -> None:
    """(c) Car-body lateral acceleration of every car."""
    for i, car in enumerate(ds["car"].values):
        ax.plot(_t(ds), ds["carbody_ay"].sel(car=car).values, lw=1.0, color=f"C{i % 10}", label=f"car {car}")
    ax.set_ylabel("a_y (m/s^2), + left")
    ax.set_title("(c) Car-body lateral acceleration")
    ax.legend(fontsize="small", loc="upper right", ncols=4)
    ax.grid(True, lw=0.3)


def panel_midspan(ax: Axes, ds: xr.Dataset) -> None:
    """(d) Lateral displacement (mm, left axis) and twist (mrad, right axis) at midspan of the span
    that sways most."""
    uy = np.abs(np.asarray(ds["midspan_uy"].transpose("time", "span").values, dtype=float))
    span = ds["span"].values[int(np.argmax(uy.max(axis=0))) if uy.size else 0]
    ax.plot(_t(ds), 1e3 * ds["midspan_uy"].sel(span=span).values, color="C0", lw=1.0, label="u_y absolute")
    if "midspan_uy_rel" in ds.variables:
        ax.plot(
            _t(ds),
            1e3 * ds["midspan_uy_rel"].sel(span=span).values,
            color="C0",
            ls="--",
            lw=1.0,
            label="u_y relative",
        )
    ax.set_ylabel("u_y (mm), + left")
    twin = ax.twinx()
    twin.plot(_t(ds), 1e3 * ds["midspan_twist"].sel(span=span).values, color="C2", lw=1.0, label="twist")
    twin.set_ylabel("twist (mrad), + left up", color="C2")
    handles = ax.get_legend_handles_labels()[0] + twin.get_legend_handles_labels()[0]
    ax.legend(handles=handles, fontsize="small", loc="upper right")
    ax.set_title(f"(d) Midspan of span {span}: lateral displacement and twist")
    ax.set_xlabel("time (s)")
    ax.grid(True, lw=0.3)


def lateral_figure(ds: xr.Dataset, title: str = "", alpha: float = PRUDHOMME_ALPHA) -> Figure:
    """The four panels of the module docstring, one above the other."""
    fig = Figure(figsize=(10.0, 12.0), layout="constrained")
    axes = fig.subplots(4, 1, sharex=True)
    panel_quotient(axes[0], ds)
    panel_track_shift(axes[1], ds, alpha)
    panel_carbody_ay(axes[2], ds)
    panel_midspan(axes[3], ds)
    if title:
        fig.suptitle(title, fontsize="large", fontweight="bold")
    return fig
