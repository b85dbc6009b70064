"""Engineering metrics of one run: the quantities the codes limit, from a results Dataset.

Every metric is a peak over the whole stored run, with the time at which it occurs (``<name>_time``):

* ``peak_midspan_uz`` (span): max |``midspan_uz``|, the absolute vertical midspan displacement (m).
* ``peak_deck_acceleration`` (span): the vertical deck acceleration EN 1990:2002+A1 A2.4.4.2.1(4)P
  limits. For a run without an earthquake: the envelope over each span's nodes and over time of
  the deck's response by modal truncation, every mode up to the greater of 30 Hz, 1.5 f1 and f3
  counted in full, each with the bridge's damping ratio, under the run's wheel forces
  (:mod:`svbi.runtime.study.deck_modal`: one span's bending modes for the ``[bridge]`` shorthand,
  the whole structure's modes for the long form); ``peak_deck_acceleration_x`` says where along
  the span. With an earthquake (or stored times that are not equally spaced): max |a| of the
  absolute midspan acceleration ``deck_acceleration`` after a low-pass filter at that frequency
  (4th-order Butterworth, zero phase, at the output rate), ``peak_deck_acceleration_x`` the
  midspan. The attribute ``deck_acceleration_method`` says which.
* ``peak_midspan_uz_rel`` (span): max |``midspan_uz_rel``|, the midspan displacement relative to the
  ground under the span (results that carry it).
* ``peak_carbody_az`` (car): max |``carbody_az``|, the vertical car-body acceleration (m/s²); NaN
  for a train of moving loads, which has no car body.
* ``max_unloading_ratio`` (car, wheel): max over time of ΔP/P0 = (P0 - P(t)) / P0, P the filtered
  wheel force ``contact_force_filtered`` and P0 the static wheel load, the raw force at t = 0 (every
  run starts from static equilibrium on rigid track); NaN for a train of moving loads, whose
  prescribed axle loads never unload.
* ``min_contact_force_filtered`` (car, wheel): min over time of ``contact_force_filtered`` (N).
* ``lift_offs``, ``longest_contact_loss`` and ``peak_uplift`` (car, wheel): only when the results
  carry unilateral contact (``contact_state``, 1 in contact and 0 lifted, and ``wheel_uplift`` in
  m): the number of contact-to-lifted transitions, the longest time a wheel stayed lifted (s, from
  the stored times) and the largest uplift.
* ``peak_end_rotation`` (span, end): max |``end_rotation``|, the rotation of each span end (rad);
  ``peak_joint_rotation`` (joint): max over time of the angle between consecutive decks at joint j
  (between spans j and j + 1), |θ_right(j) - θ_left(j + 1)| (rad), the θ1 + θ2 of EN 1990
  A2.4.4.2.3 (the two ends turn in opposite senses under load).
* ``complete``: 1 when the run finished, 0 when it stopped early (then the peaks cover the stored
  part).

A 3D run (results with ``derailment_quotient``, docs/three-d.md) has a ``side`` dimension on its
per-wheel variables: the per-wheel metrics above have it too, ``wheel`` numbering the wheelsets,
and the unloading ratio is ΔQ/Q0 with ``static_wheel_load`` as Q0. These are added (absent for a 2D
run):

* ``peak_derailment_quotient`` (car, wheel, side): max over time of Y/Q (filtered forces, Y positive
  outwards; the samples where the wheel is off its rail left out); ``peak_derailment_quotient_2m``:
  the same of its 2 m sliding mean (EN 14363; a train that moves at every step);
* ``peak_wheel_lateral_force`` (car, wheel, side): max over time of the outward Y (N);
* ``peak_axle_lateral_force`` (car, wheel): max |ΣY| of the filtered forces (N; of the raw ones for
  results without ``axle_lateral_force_filtered``); ``peak_axle_lateral_force_2m``: of its 2 m
  sliding mean; ``static_axle_load`` (car, wheel): the wheelset's static load P0 = ΣQ0 (N), for
  Prud'homme's limit;
* ``flange_contacts`` (car, wheel, side): flange contacts that begin (counted from the stored rows);
* ``peak_carbody_ay`` (car): max |``carbody_ay``|;
* ``peak_midspan_uy``, ``peak_midspan_uy_rel``, ``peak_midspan_twist``, ``peak_midspan_twist_rel``
  (span) and ``peak_pier_top_uy``, ``peak_pier_top_uy_rel`` (pier): max |.| of the variables.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..model.bridge import Bridge
from ..model.modes import span_modes
from ..run.force_filter import design, sosfiltfilt_rows
from ..run.results3d import sum_y_variable
from ..scenario.schema import BridgeSpec
from .deck_modal import EN1990_MIN_CUTOFF_HZ, SpanModeSet, deck_envelope, has_earthquake

if TYPE_CHECKING:
    import xarray as xr

FILTER_ORDER = 4
DECK_MODAL = "modal truncation, envelope over the span's nodes"
DECK_FILTERED = "absolute midspan acceleration, low-pass filtered"

METRIC_DIMS: dict[str, tuple[str, ...]] = {
    "peak_midspan_uz": ("span",),
    "peak_deck_acceleration": ("span",),
    "peak_deck_acceleration_x": ("span",),
    "peak_midspan_uz_rel": ("span",),
    "peak_carbody_az": ("car",),
    "max_unloading_ratio": ("car", "wheel"),
    "min_contact_force_filtered": ("car", "wheel"),
    "lift_offs": ("car", "wheel"),
    "longest_contact_loss": ("car", "wheel"),
    "peak_uplift": ("car", "wheel"),
    "peak_end_rotation": ("span", "end"),
    "peak_joint_rotation": ("joint",),
    "peak_pier_drift": ("pier",),
    "peak_derailment_quotient": ("car", "wheel", "side"),
    "peak_derailment_quotient_2m": ("car", "wheel", "side"),
    "peak_wheel_lateral_force": ("car", "wheel", "side"),
    "peak_axle_lateral_force": ("car", "wheel"),
    "peak_axle_lateral_force_2m": ("car", "wheel"),
    "static_axle_load": ("car", "wheel"),
    "flange_contacts": ("car", "wheel", "side"),
    "peak_carbody_ay": ("car",),
    "peak_midspan_uy": ("span",),
    "peak_midspan_uy_rel": ("span",),
    "peak_midspan_twist": ("span",),
    "peak_midspan_twist_rel": ("span",),
    "peak_track_twist": ("span",),
    "peak_pier_top_uy": ("pier",),
    "peak_pier_top_uy_rel": ("pier",),
    "complete": (),
}
"""Every metric and its dimensions (``lift_offs``, ``longest_contact_loss`` and ``peak_uplift`` only
with unilateral contact, ``peak_midspan_uz_rel`` only when the results carry ``midspan_uz_rel``, the
3D metrics from ``peak_derailment_quotient`` on only for a 3D run, whose per-wheel metrics add
``side``)."""

LATERAL_METRICS = (
    "peak_derailment_quotient",
    "peak_derailment_quotient_2m",
    "peak_wheel_lateral_force",
    "peak_axle_lateral_force",
    "peak_axle_lateral_force_2m",
    "static_axle_load",
    "flange_contacts",
    "peak_carbody_ay",
    "peak_midspan_uy",
    "peak_midspan_uy_rel",
    "peak_midspan_twist",
    "peak_midspan_twist_rel",
    "peak_track_twist",
    "peak_pier_top_uy",
    "peak_pier_top_uy_rel",
)
"""The metrics of a 3D run only."""

METRIC_UNITS = {
    "peak_midspan_uz": "m",
    "peak_deck_acceleration": "m/s^2",
    "peak_deck_acceleration_x": "m",
    "peak_midspan_uz_rel": "m",
    "peak_carbody_az": "m/s^2",
    "max_unloading_ratio": "1",
    "min_contact_force_filtered": "N",
    "lift_offs": "1",
    "longest_contact_loss": "s",
    "peak_uplift": "m",
    "peak_end_rotation": "rad",
    "peak_joint_rotation": "rad",
    "peak_pier_drift": "m",
    "peak_derailment_quotient": "1",
    "peak_derailment_quotient_2m": "1",
    "peak_wheel_lateral_force": "N",
    "peak_axle_lateral_force": "N",
    "peak_axle_lateral_force_2m": "N",
    "static_axle_load": "N",
    "flange_contacts": "1",
    "peak_carbody_ay": "m/s^2",
    "peak_midspan_uy": "m",
    "peak_midspan_uy_rel": "m",
    "peak_midspan_twist": "rad",
    "peak_midspan_twist_rel": "rad",
    "peak_track_twist": "mm/3m",
    "peak_pier_top_uy": "m",
    "peak_pier_top_uy_rel": "m",
    "complete": "1",
}


class MetricsError(ValueError):
    """The results lack what a metric needs; the message names the variable."""


@dataclass(frozen=True)
class SpanFrequencies:
    """First and third bending frequencies of a span (Hz) and the EN 1990 filter cutoff."""

    f1: float
    f3: float

    @property
    def cutoff_hz(self) -> float:
        return max(EN1990_MIN_CUTOFF_HZ, 1.5 * self.f1, self.f3)


def scenario_table(ds: xr.Dataset) -> dict[str, Any]:
    """The normalised scenario echoed in the results (every default filled in)."""
    text = ds.attrs.get("scenario")
    if not isinstance(text, str):
        raise MetricsError("results have no 'scenario' attribute (the echo of the scenario)")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise MetricsError(f"the 'scenario' attribute is not valid TOML ({exc})") from None


def span_frequencies(bridge: dict[str, Any]) -> SpanFrequencies:
    """f1 and f3 of one span of ``[bridge]`` from its generated mass and stiffness matrices. For the
    long form, each girder's own vertical modes on rigid supports, the girder with the highest
    cutoff ``max(1.5 f1, f3)`` taken (the filter keeps what any girder needs)."""
    if bridge.get("girders"):
        spec = BridgeSpec.model_validate(bridge, strict=False)
        girders, piers = spec.layout()
        b = Bridge(
            0,
            0.0,
            1.0,
            1.0,
            1.0,
            1.0,
            0.0,
            spec.elements_per_span,
            spec.rail_height,
            girders,
            piers,
            matrices=False,
        )
        per_girder = [b.girder_frequencies(g, 3) / (2 * np.pi) for g in girders]
        return SpanFrequencies(
            max(float(f[0]) for f in per_girder), max(float(f[min(2, f.size - 1)]) for f in per_girder)
        )
    bending, _ = span_modes(
        float(bridge["span_length"]),
        int(bridge.get("elements_per_span", 16)),
        float(bridge["youngs_modulus"]),
        float(bridge["area"]),
        float(bridge["second_moment"]),
        float(bridge["mass_per_length"]),
    )
    f1 = float(bending[0])
    # a span of one or two elements has fewer than three bending modes: its highest stands in for f3
    f3 = float(bending[min(2, bending.size - 1)])
    return SpanFrequencies(f1, f3)


def lowpass(values: np.ndarray, cutoff_hz: float, sample_hz: float) -> np.ndarray:
    """Zero-phase Butterworth low-pass along axis 0 (unchanged when the cutoff is above Nyquist).

    ``scipy.signal.sosfiltfilt`` of ``scipy.signal.butter``'s design, run by the contact forces'
    compiled filter with the design cached per machine (``zero_phase``): the same bits, and no
    ``scipy.signal`` import (0.38 s of a sweep worker's first run) once the filter was designed.
    """
    n = values.shape[0]
    if n < 2 or cutoff_hz >= 0.5 * sample_hz:
        return values
    sos, zi = design(FILTER_ORDER, cutoff_hz, sample_hz)
    # Odd padding (SciPy's default) over ten periods of the cutoff, not SciPy's 27 samples, which are
    # shorter than the filter's memory at high sample rates. Odd padding keeps the end values: a run
    # starts at rest and ends in free vibration, both inside the pass band.
    padlen = min(max(3 * (2 * len(sos) + 1), int(10 * sample_hz / cutoff_hz)), n - 1)
    rows = np.ascontiguousarray(np.asarray(values, dtype=float).reshape(n, -1))
    return sosfiltfilt_rows(sos, rows, padlen, 1, n, zi).reshape(values.shape)


def filtered_deck_acceleration(ds: xr.Dataset) -> tuple[np.ndarray, float]:
    """The EN 1990 low-pass filtered ``deck_acceleration`` (time x span) and the cutoff used (Hz)."""
    if "deck_acceleration" not in ds.variables:
        raise MetricsError(
            "results have no 'deck_acceleration' (they were written by an older svbi: run the scenario again)"
        )
    acc = np.asarray(ds["deck_acceleration"].transpose("time", "span").values, dtype=float)
    cutoff = span_frequencies(scenario_table(ds)["bridge"]).cutoff_hz
    t = np.asarray(ds["time"].values, dtype=float)
    if t.size < 2:
        return acc, cutoff
    return lowpass(acc, cutoff, 1.0 / float(np.median(np.diff(t)))), cutoff


def _peak_abs(values: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """max |values| over axis 0 and its time, NaN where nothing was stored."""
    if values.shape[0] == 0:
        nan = np.full(values.shape[1:], np.nan)
        return nan, nan.copy()
    a = np.abs(values)
    idx = np.argmax(a, axis=0)
    return np.take_along_axis(a, idx[None], 0)[0], t[idx]


def _moving_load(ds: xr.Dataset) -> bool:
    try:
        return scenario_table(ds).get("train", {}).get("vehicle") == "moving-load"
    except MetricsError:
        return False


METRIC_INPUTS = (
    "midspan_uz",
    "midspan_uz_rel",
    "deck_acceleration",
    "end_rotation",
    "carbody_az",
    "contact_force",
    "contact_force_filtered",
    "contact_state",
    "wheel_uplift",
    "pier_drift",
    # 3D runs
    "static_wheel_load",
    "derailment_quotient",
    "derailment_quotient_2m",
    "wheel_lateral_force",
    "axle_lateral_force",
    "axle_lateral_force_filtered",
    "axle_lateral_force_2m",
    "flange_contact",
    "carbody_ay",
    "midspan_uy",
    "midspan_uy_rel",
    "midspan_twist",
    "midspan_twist_rel",
    "pier_top_uy",
    "pier_top_uy_rel",
    "deck_twist",
    "wheelset_position",
)
"""The results variables :func:`compute_metrics` reads (with ``time`` and the attributes): a sweep
worker builds only these (``Recorder.dataset(variables=...)``) when it keeps no history."""


def compute_metrics(ds: xr.Dataset) -> xr.Dataset:
    """The metrics of one results Dataset (module docstring), with ``<name>_time`` for each peak.

    Raises :class:`MetricsError` when a needed variable is missing.
    """
    import xarray as xr

    for var in ("time", "midspan_uz", "contact_force", "contact_force_filtered"):
        if var not in ds.variables:
            raise MetricsError(f"results have no '{var}'")
    t = np.asarray(ds["time"].values, dtype=float)
    out: dict[str, tuple[tuple[str, ...], Any, dict[str, str]]] = {}

    per_wheel = tuple(d for d in ds["contact_force"].dims if d != "time")  # car, wheel[, side]

    def put(name: str, value: np.ndarray, when: np.ndarray | None, doc: str) -> None:
        dims = METRIC_DIMS[name]
        if dims[:2] == ("car", "wheel") and name not in LATERAL_METRICS:
            dims = per_wheel  # a 3D run's wheels have a side
        out[name] = (dims, value, {"units": METRIC_UNITS[name], "long_name": doc})
        if when is not None:
            out[f"{name}_time"] = (dims, when, {"units": "s", "long_name": f"time of {name}"})

    uz = np.asarray(ds["midspan_uz"].transpose("time", "span").values, dtype=float)
    put("peak_midspan_uz", *_peak_abs(uz, t), "max |midspan_uz| (absolute vertical displacement)")

    deck = _deck_acceleration(ds, t)
    put("peak_deck_acceleration", deck.peak, deck.time, deck.doc)
    put("peak_deck_acceleration_x", deck.x, None, "where along the span the deck acceleration peaks")
    cutoff = deck.cutoff
    if "midspan_uz_rel" in ds.variables:
        rel = np.asarray(ds["midspan_uz_rel"].transpose("time", "span").values, dtype=float)
        put("peak_midspan_uz_rel", *_peak_abs(rel, t), "max |midspan_uz_rel| (relative to the ground)")

    ncar = ds.sizes["car"]
    if "carbody_az" in ds.variables and not _moving_load(ds):
        az = np.asarray(ds["carbody_az"].transpose("time", "car").values, dtype=float)
        peak, when = _peak_abs(az, t)
    else:
        peak, when = np.full(ncar, np.nan), np.full(ncar, np.nan)
    put("peak_carbody_az", peak, when, "max |carbody_az| (vertical car-body acceleration)")

    raw = np.asarray(ds["contact_force"].transpose("time", *per_wheel).values, dtype=float)
    pf = np.asarray(ds["contact_force_filtered"].transpose("time", *per_wheel).values, dtype=float)
    shape = raw.shape[1:]
    if raw.shape[0] == 0 or _moving_load(ds):
        # a moving load's wheel force is prescribed: it never unloads (its ratio is rounding, 1e-14)
        nan = np.full(shape, np.nan)
        put("max_unloading_ratio", nan, nan, "max (P0 - P) / P0, P filtered, P0 static")
    if raw.shape[0] == 0:
        put("min_contact_force_filtered", nan, nan, "min contact_force_filtered")
    else:
        if "max_unloading_ratio" not in out:
            p0 = raw[0]
            if "static_wheel_load" in ds.variables:  # a 3D run: Q0 as the results give it
                p0 = np.asarray(ds["static_wheel_load"].transpose(*per_wheel).values, dtype=float)
            with np.errstate(divide="ignore", invalid="ignore"):
                ratio = np.where(p0 > 0, (p0 - pf) / p0, np.nan)
            idx = np.argmax(np.where(np.isnan(ratio), -np.inf, ratio), axis=0)
            put(
                "max_unloading_ratio",
                np.take_along_axis(ratio, idx[None], 0)[0],
                t[idx],
                "max (P0 - P) / P0: P the filtered wheel force, P0 the static wheel load",
            )
        idx = np.argmin(pf, axis=0)
        put(
            "min_contact_force_filtered",
            np.take_along_axis(pf, idx[None], 0)[0],
            t[idx],
            "min contact_force_filtered",
        )

    if "contact_state" in ds.variables:
        state = np.asarray(ds["contact_state"].transpose("time", *per_wheel).values)
        on = state != 0
        lifts = np.sum(on[:-1] & ~on[1:], axis=0) if on.shape[0] > 1 else np.zeros(shape, int)
        put("lift_offs", lifts.astype(np.int64), None, "contact-to-lifted transitions")
        put("longest_contact_loss", *_longest_loss(~on, t), "longest time a wheel stayed lifted")
    if "wheel_uplift" in ds.variables:
        up = np.asarray(ds["wheel_uplift"].transpose("time", *per_wheel).values, dtype=float)
        if up.shape[0]:
            idx = np.argmax(up, axis=0)
            peak, when = np.take_along_axis(up, idx[None], 0)[0], t[idx]
        else:
            peak = when = np.full(shape, np.nan)
        put("peak_uplift", peak, when, "max wheel_uplift")

    if "end_rotation" in ds.variables:
        rot = np.asarray(ds["end_rotation"].transpose("time", "span", "end").values, dtype=float)
        peak, when = _peak_abs(rot, t)
        put("peak_end_rotation", peak, when, "max |end_rotation| of each span end")
        kink = rot[:, :-1, 1] - rot[:, 1:, 0]  # right end of span j against left end of span j + 1
        peak, when = _peak_abs(kink, t)
        put("peak_joint_rotation", peak, when, "max angle between consecutive decks (theta1 + theta2)")

    if "pier_drift" in ds.variables:
        drift = np.asarray(ds["pier_drift"].transpose("time", "pier").values, dtype=float)
        peak, when = _peak_abs(drift, t)
        put("peak_pier_drift", peak, when, "max |pier_drift| (pier top relative to the ground at its base)")

    if "derailment_quotient" in ds.variables:
        _lateral_metrics(ds, t, put)

    complete = _complete(ds)
    put("complete", np.int64(complete), None, "1: the run finished; 0: it stopped early")
    coords = {
        d: ds.coords[d].values for d in ("span", "car", "wheel", "side", "end", "pier") if d in ds.coords
    }
    if "peak_joint_rotation" in out:
        coords["joint"] = np.arange(1, ds.sizes["span"])
    attrs: dict[str, Any] = {
        "deck_acceleration_cutoff_hz": cutoff,
        "deck_acceleration_method": deck.method,
        "deck_acceleration_modes": deck.modes,
    }
    if not complete:
        attrs["incomplete"] = str(ds.attrs.get("incomplete", ""))
    return xr.Dataset(out, coords=coords, attrs=attrs)


def _peak_max(values: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """max over axis 0 with NaN samples left out, and its time; NaN where every sample is NaN."""
    if values.shape[0] == 0:
        nan = np.full(values.shape[1:], np.nan)
        return nan, nan.copy()
    finite = np.isfinite(values)
    idx = np.argmax(np.where(finite, values, -np.inf), axis=0)
    peak = np.take_along_axis(values, idx[None], 0)[0]
    any_finite = finite.any(axis=0)
    return np.where(any_finite, peak, np.nan), np.where(any_finite, t[idx], np.nan)


def _lateral_metrics(ds: xr.Dataset, t: np.ndarray, put: Any) -> None:
    """The metrics of a 3D run (module docstring)."""
    wheel, axle = ("time", "car", "wheel", "side"), ("time", "car", "wheel")

    def arr(name: str, dims: tuple[str, ...]) -> np.ndarray:
        return np.asarray(ds[name].transpose(*dims).values, dtype=float)

    put(
        "peak_derailment_quotient",
        *_peak_max(arr("derailment_quotient", wheel), t),
        "max Y/Q (filtered forces, Y outwards; wheels off their rail left out)",
    )
    if "derailment_quotient_2m" in ds.variables:
        put(
            "peak_derailment_quotient_2m",
            *_peak_max(arr("derailment_quotient_2m", wheel), t),
            "max of the 2 m sliding mean of Y/Q (EN 14363)",
        )
    put("peak_wheel_lateral_force", *_peak_max(arr("wheel_lateral_force", wheel), t), "max Y, outwards")
    sum_y = sum_y_variable(ds.variables)
    put(
        "peak_axle_lateral_force",
        *_peak_abs(arr(sum_y, axle), t),
        f"max |sum Y| of a wheelset ({sum_y})",
    )
    if "axle_lateral_force_2m" in ds.variables:
        put(
            "peak_axle_lateral_force_2m",
            *_peak_abs(arr("axle_lateral_force_2m", axle), t),
            "max |sum Y| of a wheelset, 2 m sliding mean (EN 14363)",
        )
    q0 = np.asarray(ds["static_wheel_load"].transpose("car", "wheel", "side").values, dtype=float)
    put("static_axle_load", q0.sum(axis=-1), None, "static load of the wheelset P0 (sum of Q0)")
    on = arr("flange_contact", wheel) != 0
    starts = on.copy()
    if on.shape[0] > 1:
        starts[1:] &= ~on[:-1]
    put("flange_contacts", starts.sum(axis=0).astype(np.int64), None, "flange contacts that begin")
    put("peak_carbody_ay", *_peak_abs(arr("carbody_ay", ("time", "car")), t), "max |carbody_ay|")
    for name in ("midspan_uy", "midspan_uy_rel", "midspan_twist", "midspan_twist_rel"):
        if name in ds.variables:
            put(f"peak_{name}", *_peak_abs(arr(name, ("time", "span")), t), f"max |{name}|")
    for name in ("pier_top_uy", "pier_top_uy_rel"):
        if name in ds.variables:
            put(f"peak_{name}", *_peak_abs(arr(name, ("time", "pier")), t), f"max |{name}|")
    if "deck_twist" in ds.variables:
        twist, when = track_twist(ds)
        put(
            "peak_track_twist",
            twist,
            when,
            f"max track twist over {TWIST_BASE:g} m at gauge {TWIST_GAUGE:g} m from the deck's twist "
            "(EN 1990 A2.4.4.2.2), within each span",
        )


TWIST_BASE = 3.0
"""m: EN 1990 A2.4.4.2.2 measures the track twist over 3 m."""
TWIST_GAUGE = 1.435
"""m: the track gauge ``s`` of EN 1990 Figure A2.1 (standard gauge)."""


def _linear(xs: np.ndarray, values: np.ndarray, idx: np.ndarray, pos: np.ndarray) -> np.ndarray:
    """``values`` (time x nodes at ``xs``) linearly interpolated at ``pos`` in the intervals ``idx``."""
    w = (pos - xs[idx]) / (xs[idx + 1] - xs[idx])
    return values[:, idx] * (1.0 - w) + values[:, idx + 1] * w


def track_twist(ds: xr.Dataset) -> tuple[np.ndarray, np.ndarray]:
    """The peak track twist (mm per 3 m) of each span and when: ``s |phi(x + 3) - phi(x)|`` over
    every 3 m base within the span, ``phi`` the deck's twist, linear between its nodes as the frame
    element's torsion (exact), ``s`` the gauge; bases every tenth of the element (and ending at the
    span's end) and the nodes."""
    phi = np.asarray(ds["deck_twist"].transpose("time", "deck_node").values, dtype=float)
    x = np.asarray(ds["deck_node_x"].values, dtype=float)
    span = np.asarray(ds["deck_node_span"].values)
    t = np.asarray(ds["time"].values, dtype=float)
    spans = int(span.max()) if span.size else 0
    peak, when = np.full(spans, np.nan), np.full(spans, np.nan)
    for s in range(1, spans + 1):
        at = span == s
        xs, ph = x[at], phi[:, at]
        if xs[-1] - xs[0] < TWIST_BASE:
            continue
        step = float(np.min(np.diff(xs))) / 10.0
        starts = np.concatenate(
            [
                np.arange(xs[0], xs[-1] - TWIST_BASE, step),
                xs[xs <= xs[-1] - TWIST_BASE],
                [xs[-1] - TWIST_BASE],
            ]
        )
        # linear interpolation of every time row at the bases' two ends (the twist is linear between nodes)
        lo = np.clip(np.searchsorted(xs, starts, side="right") - 1, 0, xs.size - 2)
        hi = np.clip(np.searchsorted(xs, starts + TWIST_BASE, side="right") - 1, 0, xs.size - 2)

        twist = (
            1e3 * TWIST_GAUGE * np.abs(_linear(xs, ph, hi, starts + TWIST_BASE) - _linear(xs, ph, lo, starts))
        )
        k = int(np.argmax(twist))
        i, _ = np.unravel_index(k, twist.shape)
        peak[s - 1], when[s - 1] = twist.reshape(-1)[k], t[i]
    return peak, when


@dataclass(frozen=True)
class _Deck:
    peak: np.ndarray
    time: np.ndarray
    x: np.ndarray
    cutoff: float
    method: str
    modes: int
    doc: str


def _deck_acceleration(ds: xr.Dataset, t: np.ndarray) -> _Deck:
    """The deck acceleration EN 1990 A2.4.4.2.1 limits (module docstring): modal truncation for a
    traffic run on simply supported spans, else the filtered absolute midspan acceleration."""
    table = scenario_table(ds)
    bridge = table["bridge"]
    if not has_earthquake(table) and t.size > 1:
        force = ds["contact_force"]
        positions = None
        if "side" in force.dims:  # a 3D run: a wheelset's two vertical wheel forces, where it is
            force = force.sum("side")
            if "wheelset_position" in ds.variables:
                where = ds["wheelset_position"].transpose("time", "car", "wheel").values
                positions = np.asarray(where, dtype=float).reshape(t.size, -1)
        forces = np.asarray(force.transpose("time", "car", "wheel").values, dtype=float)
        try:
            if "side" in ds["contact_force"].dims and positions is None:
                raise ValueError("the 3D results carry no wheelset_position")
            env = deck_envelope(table, t, forces.reshape(t.size, -1), positions)
        except (ValueError, KeyError, OSError) as exc:  # unequal output steps, an unreadable vehicle
            # (a topology file no longer where the scenario says): the filtered midspan value below
            env = None
            reason = str(exc)
        if env is not None:
            cutoff = env.modes.cutoff_hz
            n = env.modes.frequencies_hz.size
            which = "bending modes" if isinstance(env.modes, SpanModeSet) else "modes of the whole bridge"
            doc = (
                f"max |vertical deck acceleration| over the span's nodes, {n} {which} up to "
                f"{cutoff:.4g} Hz, damping ratio {env.modes.damping_ratio:g} each (EN 1990 A2.4.4.2.1)"
            )
            return _Deck(env.peak, env.time, env.x, cutoff, DECK_MODAL, n, doc)
    else:
        reason = ""
    acc, cutoff = filtered_deck_acceleration(ds)
    peak, when = _peak_abs(acc, t)
    length = float(bridge.get("span_length") or np.nan)
    doc = f"max |deck_acceleration| at midspan, low-pass {cutoff:.4g} Hz (EN 1990 A2.4.4.2.1)"
    if reason:
        doc += f"; no modal envelope: {reason}"
    return _Deck(peak, when, np.full(peak.shape, 0.5 * length), cutoff, DECK_FILTERED, 0, doc)


def _longest_loss(lifted: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The longest stretch of stored times a wheel was lifted (s, from the first lifted sample to
    the next in contact) and when it began; 0 and NaN for a wheel that never lifted."""
    shape = lifted.shape[1:]
    flat = lifted.reshape(lifted.shape[0], -1)
    longest = np.zeros(flat.shape[1])
    start = np.full(flat.shape[1], np.nan)
    end_time = t[-1] if t.size else 0.0
    for j in range(flat.shape[1]):
        col = flat[:, j]
        if not col.any():
            continue
        edges = np.diff(np.concatenate([[0], col.astype(np.int8), [0]]))
        begins, ends = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]
        stop = np.array([t[e] if e < t.size else end_time for e in ends])
        length = stop - t[begins]
        k = int(np.argmax(length))
        longest[j], start[j] = length[k], t[begins[k]]
    return longest.reshape(shape), start.reshape(shape)


def _complete(ds: xr.Dataset) -> int:
    flag = ds.attrs.get("complete", 1)
    try:
        return int(int(np.asarray(flag).ravel()[0]) != 0)
    except (TypeError, ValueError, IndexError):
        return 0 if str(flag).strip().lower() in ("0", "false", "no") else 1


def metrics_text(metrics: xr.Dataset) -> str:
    """One line per metric: the worst entry, where (span / car / wheel) and when."""
    lines = []
    for name in METRIC_DIMS:
        if name not in metrics:
            continue
        da = metrics[name]
        if name == "complete":
            lines.append(f"{name:28s} {int(da.values)}")
            continue
        if name == "peak_deck_acceleration_x":  # shown with the deck acceleration
            continue
        values = np.asarray(da.values, dtype=float)
        if values.size == 0 or not np.isfinite(values).any():
            lines.append(f"{name:28s} n/a")
            continue
        worst_is_min = name == "min_contact_force_filtered"
        flat = np.nanargmin(values) if worst_is_min else np.nanargmax(values)
        index = np.unravel_index(flat, values.shape)
        where = ", ".join(f"{d} {metrics.coords[d].values[i]}" for d, i in zip(da.dims, index, strict=True))
        value = values[index]
        unit = METRIC_UNITS[name]
        text = f"{value:.6g}" if not math.isnan(value) else "n/a"
        when = ""
        if f"{name}_time" in metrics:
            t_at = float(metrics[f"{name}_time"].values[index])
            when = f" at t = {t_at:.4g} s" if math.isfinite(t_at) else ""  # NaN: e.g. never lifted
        if name == "peak_deck_acceleration" and "peak_deck_acceleration_x" in metrics:
            x = float(np.asarray(metrics["peak_deck_acceleration_x"].values, dtype=float)[index])
            where += f", x = {x:.4g} m" if math.isfinite(x) else ""
        lines.append(f"{name:28s} {text} {unit} ({where}{when})")
    return "\n".join(lines) + "\n"
