"""The checks of ``svbi check``: EN 1990 Annex A2 for traffic, running safety for earthquakes.

Clauses are those of EN 1990:2002+A1:2005 (Annex A2, "Application for bridges") and EN 1991-2:2003.
A run is checked against one of two sets, chosen from its scenario:

**Traffic set** (no earthquake): the serviceability limits of EN 1990 A2.4.4 for rail traffic.

* deck acceleration (A2.4.4.2.1(4)P): 3.5 m/s² ballasted, 5 m/s² direct fastening, for frequencies
  up to max(30 Hz, 1.5 f1, f3) (the metric ``peak_deck_acceleration``: modal truncation, envelope
  over the span);
* deck twist (A2.4.4.2.2): a 3D run's track twist over 3 m from the deck's twist (Table A2.7:
  4.5, 3.0, 1.5 mm/3m up to 120, 200 and above 200 km/h); n/a for a 2D run;
* vertical deflection (A2.4.4.2.3(1)): the largest deflection under LM71 x α x Φ (static, the
  bridge's own stiffness, ``svbi.runtime.study.lm71``) at most L/600;
* deck end rotations with ballasted track (A2.4.4.2.3(2) leaves them to EN 1991-2 6.5.4, where they
  are implicit in the track-bridge interaction limits; the explicit values used, 6.5e-3 rad at a
  transition to the embankment and 10e-3 rad for θ1 + θ2 between consecutive decks, are those of
  ENV 1991-3:1995 Annex G, which national rules keep): the run's own loading;
* passenger comfort (A2.4.4.3): with a vehicle model, the vertical car-body acceleration b_v against
  Table A2.9 (A2.4.4.3.1: 1.0 / 1.3 / 2.0 m/s², the level asked for); without one (moving loads: no
  interaction analysis), the deflection criterion of A2.4.4.3.2: δ under LM71 x Φ (α = 1) against
  the L/δ of Figure A2.3 for the line speed (given by the user: the figure is not tabulated here),
  times 0.7 for one or two simply supported spans, divided by b_v of the level asked for, and never
  below 600;
* wheel unloading ΔP/P <= 0.6 (running safety in normal operation; vehicle models only);
* the load model: HSLM-A applies to simply supported spans of 7 m or more (EN 1991-2 Annex E,
  Table E.4); shorter spans need HSLM-B, which is not built in (flagged);
* run complete.

**Seismic set** (an earthquake): EN 1990 A2.4.4 is written for traffic actions and its limits do
not apply to a deck shaken by the ground; the run is checked for running safety instead:

* wheel unloading ΔP/P <= 0.8 (the limit of running-safety practice for short transients);
* lift-offs (counted), the longest loss of contact, and the largest uplift against the wheel's
  flange height (a wheel that rises by its flange height can leave the rail; unilateral contact
  only);
* the deck quantities relative to the ground (midspan displacement ``peak_midspan_uz_rel``), and the
  absolute deck acceleration for information;
* run complete.

A 3D run (metrics with ``peak_derailment_quotient``) adds the lateral running-safety rows to the
seismic set; a 2D run has none of them:

* derailment quotient Y/Q (the largest over the wheels, Y outwards) at most Nadal's flange-climb
  limit ``(tan γ - μ) / (1 + μ tan γ)``: 1.34 for a flange angle of 70° and a friction coefficient of
  0.3;
* its 2 m sliding mean ``(Y/Q)_2m`` at most 0.8, the limit of EN 14363 (vehicle acceptance) for
  curves of radius 250 m or more; n/a for a train that does not move at every step;
* the track-shift force of every wheelset, the 2 m sliding mean ``(ΣY)_2m`` (the unsmoothed ΣY
  when the train does not move), at most Prud'homme's limit ``α (10 + P0/3)`` kN with P0 the
  wheelset's static load in kN, α = 1 (0.85 for freight wagons: ``--prudhomme-alpha``), as
  EN 14363 takes it: the wheelset with the largest ratio to its own limit is shown;
* the wheel unloading ΔQ/Q of the row above, per wheel of each wheelset;
* the car-body lateral acceleration, for information, or against a limit the user gives
  (``--carbody-ay-limit``: svbi carries no code limit for it);
* flange contacts (counted), and the lateral midspan displacement relative to the ground, for
  information.

Rows that do not apply show ``n/a`` and do not count.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .deck_modal import has_earthquake, is_simply_supported
from .lm71 import dynamic_factor, lm71_deflection, long_form_deflections

if TYPE_CHECKING:
    import xarray as xr

DECK_ACCELERATION_LIMIT = {"ballasted": 3.5, "direct": 5.0}
"""m/s², EN 1990 A2.4.4.2.1(4)P (the recommended values)."""
COMFORT_LEVELS = {"very-good": 1.0, "good": 1.3, "acceptable": 2.0}
"""m/s², EN 1990 A2.4.4.3.1, Table A2.9: recommended levels of vertical car-body acceleration b_v."""
ABUTMENT_ROTATION_LIMIT = {"ballasted": 6.5e-3}
"""rad, ballasted track: deck end at a transition to the embankment (ENV 1991-3 Annex G; EN 1990
A2.4.4.2.3(2) refers to EN 1991-2 6.5.4)."""
JOINT_ROTATION_LIMIT = {"ballasted": 10.0e-3}
"""rad, ballasted track: θ1 + θ2 between two consecutive decks (as above)."""
DEFLECTION_RATIO = 600.0
"""EN 1990 A2.4.4.2.3(1): total vertical deflection at most L/600 under LM71 x α x Φ."""
TRAFFIC_UNLOADING_LIMIT = 0.6
"""ΔP/P of running-safety practice in normal operation."""
SEISMIC_UNLOADING_LIMIT = 0.8
"""ΔP/P of running-safety practice for short transients (earthquake)."""
UNLOADING_LIMITS = (TRAFFIC_UNLOADING_LIMIT, SEISMIC_UNLOADING_LIMIT)
"""Both ΔP/P limits, normal operation first (the figures of a store draw the last)."""
FLANGE_HEIGHT = 0.028
"""m, the nominal flange height of the S1002 wheel profile (EN 13715)."""
FLANGE_ANGLE_DEG = 70.0
"""Flange angle γ of Nadal's limit (degrees)."""
FLANGE_FRICTION = 0.3
"""Wheel-rail friction coefficient μ of Nadal's limit."""
NADAL_LIMIT = round(
    (math.tan(math.radians(FLANGE_ANGLE_DEG)) - FLANGE_FRICTION)
    / (1.0 + FLANGE_FRICTION * math.tan(math.radians(FLANGE_ANGLE_DEG))),
    2,
)
"""Nadal's flange-climb limit of Y/Q, ``(tan γ - μ) / (1 + μ tan γ)`` = 1.34 (γ 70°, μ 0.3)."""
EN14363_QUOTIENT_LIMIT = 0.8
"""``(Y/Q)_2m`` of EN 14363 (curves of radius at least 250 m)."""
PRUDHOMME_ALPHA = 1.0
"""α of Prud'homme's limit ``α (10 + P0/3)`` kN: 1.0, or 0.85 for freight wagons."""
HSLM_MIN_SPAN = 7.0
"""m, EN 1991-2 Annex E, Table E.4: HSLM-A for simply supported spans of at least 7 m."""
COMFORT_SPAN_FACTOR = 0.7
"""EN 1990 A2.4.4.3.2(5): Figure A2.3's L/δ times 0.7 for a single span, two simply supported spans
or two continuous spans."""
COMFORT_CONTINUOUS_FACTOR = 0.9
"""EN 1990 A2.4.4.3.2(5): ... and times 0.9 for continuous girders of three or more spans."""

TRAFFIC, SEISMIC = "traffic", "seismic"


@dataclass(frozen=True)
class CheckOptions:
    """What the user chooses: track form (None: the scenario's), comfort level, track maintenance
    (Φ2 or Φ3), α, Figure A2.3's L/δ at the line speed, the flange height and, for 3D runs,
    Prud'homme's α and a limit of the car-body lateral acceleration (None: for information)."""

    track_form: str | None = None
    comfort: str = "acceptable"
    maintenance: str = "standard"
    alpha: float = 1.0
    comfort_l_over_delta: float | None = None
    flange_height: float = FLANGE_HEIGHT
    prudhomme_alpha: float = PRUDHOMME_ALPHA
    carbody_ay_limit: float | None = None


def check_set(table: Mapping[str, Any]) -> tuple[str, str]:
    """The set of checks a run's scenario calls for, and why."""
    if has_earthquake(table):
        eq = table.get("earthquake", {})
        parts = ", ".join(
            f"{c} = {eq.get(c)!r}"
            for c in ("vertical", "longitudinal", "lateral")
            if eq.get(c, "none") != "none"
        )
        return SEISMIC, (
            f"the run has an earthquake ({parts}): running safety under the earthquake; the traffic "
            "serviceability limits of EN 1990 A2.4.4 are not applied to a deck shaken by the ground"
        )
    return TRAFFIC, "the run has no earthquake: EN 1990 A2.4.4 traffic serviceability limits"


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
    table: Mapping[str, Any] | None = None,
    options: CheckOptions | None = None,
    nans: dict[str, int] | None = None,
) -> list[Check]:
    """The rows of ``svbi check`` for one run's metrics; ``table`` is the run's scenario (the set and
    the static checks come from it; without it, the traffic rows that need only the metrics);
    ``nans``: :func:`nan_samples` of its results (a NaN sample in a checked quantity, or a NaN
    metric, fails that check as invalid: a NaN certifies nothing)."""
    opts = options or CheckOptions(track_form=track_form, comfort=comfort)
    form = opts.track_form or track_form
    if form not in DECK_ACCELERATION_LIMIT:
        raise ValueError(f"track form {form!r}: expected one of {', '.join(DECK_ACCELERATION_LIMIT)}")
    if opts.comfort not in COMFORT_LEVELS:
        raise ValueError(f"comfort level {opts.comfort!r}: expected one of {', '.join(COMFORT_LEVELS)}")
    dynamic_factor(10.0, opts.maintenance)  # raises on an unknown maintenance
    table = table or {}
    which, _ = check_set(table)
    if which == SEISMIC:
        bilateral = table.get("contact", {}).get("normal") == "bilateral"
        rows = _seismic_rows(metrics, moving_load, opts, bilateral)
    else:
        rows = _traffic_rows(metrics, form, moving_load, table, opts)
    rows.append(_complete_row(metrics))
    return [_validated(row, metrics, nans or {}) for row in rows]


CHECK_INPUTS: dict[str, tuple[str, ...]] = {
    "peak_deck_acceleration": ("deck_acceleration",),
    "peak_carbody_az": ("carbody_az",),
    "max_unloading_ratio": ("contact_force", "contact_force_filtered"),
    "peak_end_rotation": ("end_rotation",),
    "peak_joint_rotation": ("end_rotation",),
    "peak_derailment_quotient": ("contact_force", "wheel_lateral_force"),
    "peak_derailment_quotient_2m": ("contact_force", "wheel_lateral_force"),
    "peak_axle_lateral_force_2m": ("wheel_lateral_force",),
    "peak_axle_lateral_force": ("wheel_lateral_force",),
    "peak_carbody_ay": ("carbody_ay",),
}
"""The results variables behind each checked metric: a NaN sample in one makes the check invalid."""

ROW_METRICS: tuple[tuple[str, str], ...] = (
    ("deck acceleration", "peak_deck_acceleration"),
    ("comfort, car-body acceleration", "peak_carbody_az"),
    ("wheel unloading", "max_unloading_ratio"),
    ("end rotation at abutments", "peak_end_rotation"),
    ("rotation between decks", "peak_joint_rotation"),
    ("derailment quotient Y/Q <=", "peak_derailment_quotient"),
    ("derailment quotient (Y/Q)_2m", "peak_derailment_quotient_2m"),
    ("track-shift force (sum Y)_2m", "peak_axle_lateral_force_2m"),
    ("track-shift force sum Y", "peak_axle_lateral_force"),
    ("car-body lateral acceleration", "peak_carbody_ay"),
)
"""The metric each row of the table reads, by the start of the row's name."""


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


def _validated(row: Check, metrics: xr.Dataset, nans: dict[str, int]) -> Check:
    """``row``, or a failed row when the metric it reads is NaN or has NaN inputs. A row that does
    not apply (``passed`` None with no value: prescribed axle loads, no car body) stays as it is."""
    metric = next((m for start, m in ROW_METRICS if row.name.startswith(start)), None)
    if metric is None or (row.passed is None and row.value is None):
        return row
    why = _invalid(metrics, metric, nans)
    if not why:
        return row
    return Check(row.name, math.nan, row.limit, row.unit, "", None, False, why)


TWIST_LIMITS = ((120.0, 4.5), (200.0, 3.0), (float("inf"), 1.5))
"""EN 1990 A2.4.4.2.2(2)P, Table A2.7: the deck twist t (mm/3m) at most 4.5 for V <= 120 km/h,
3.0 for 120 < V <= 200 km/h, 1.5 above."""


def _twist_row(metrics: xr.Dataset, speed: float | None) -> Check:
    name = "deck twist (A2.4.4.2.2)"
    worst = _worst(metrics, "peak_track_twist")
    if worst is None:
        return Check(name, None, None, "mm/3m", "", None, None, "needs a 3D run (the deck's twist)")
    if speed is None:
        return Check(name, worst[0], None, "mm/3m", worst[1], worst[2], None, "no line speed in the scenario")
    limit = next(lim for v, lim in TWIST_LIMITS if speed <= v)
    v, where, when = worst
    note = f"Table A2.7 at V = {speed:.0f} km/h; the run's own traffic over 3 m at gauge 1.435 m"
    return Check(name, v, limit, "mm/3m", where, when, v <= limit, note)


def _traffic_rows(
    metrics: xr.Dataset, form: str, moving_load: bool, table: Mapping[str, Any], opts: CheckOptions
) -> list[Check]:
    rows: list[Check] = []
    limit = DECK_ACCELERATION_LIMIT[form]
    worst = _worst(metrics, "peak_deck_acceleration")
    name = f"deck acceleration ({form}, A2.4.4.2.1)"
    if worst is None:
        rows.append(Check(name, None, limit, "m/s^2", "", None, None, "no deck acceleration"))
    else:
        v, where, when = worst
        rows.append(
            Check(name, v, limit, "m/s^2", _with_x(metrics, where), when, v <= limit, _deck_note(metrics))
        )
    bridge = table.get("bridge", {})
    speed = _speed_kmh(table)
    rows.append(_twist_row(metrics, speed))
    rows += _deflection_rows(bridge, opts, moving_load, speed, metrics)
    rows += _rotation_rows(metrics, form)
    worst = None if moving_load else _worst(metrics, "max_unloading_ratio")
    name = f"wheel unloading dP/P <= {TRAFFIC_UNLOADING_LIMIT:g}"
    if worst is None:
        rows.append(Check(name, None, TRAFFIC_UNLOADING_LIMIT, "1", "", None, None, "prescribed axle loads"))
    else:
        v, where, when = worst
        rows.append(Check(name, v, TRAFFIC_UNLOADING_LIMIT, "1", where, when, v <= TRAFFIC_UNLOADING_LIMIT))
    hslm = table.get("train", {}).get("hslm")
    length = bridge.get("span_length")
    if hslm and length is not None and float(length) < HSLM_MIN_SPAN and is_simply_supported(bridge):
        rows.append(
            Check(
                "load model (EN 1991-2 E, Table E.4)",
                None,
                None,
                "",
                "",
                None,
                None,
                f"HSLM-{hslm} on a {float(length):g} m span: spans under 7 m need HSLM-B (not built in)",
            )
        )
    return rows


def _deck_note(metrics: xr.Dataset) -> str:
    method = str(metrics.attrs.get("deck_acceleration_method", ""))
    cutoff = metrics.attrs.get("deck_acceleration_cutoff_hz")
    fc = f"{float(cutoff):.3g} Hz" if cutoff is not None else "fc"
    if method.startswith("modal"):
        return (
            f"{int(metrics.attrs.get('deck_acceleration_modes', 0))} modes up to {fc}, envelope over the span"
        )
    return f"midspan, filtered to {fc}" if cutoff is not None else ""


def _with_x(metrics: xr.Dataset, where: str) -> str:
    """``where`` with the position along the span of the deck-acceleration peak, when known."""
    if "peak_deck_acceleration_x" not in metrics or "span" not in where:
        return where
    values = np.asarray(metrics["peak_deck_acceleration"].values, dtype=float)
    if not np.isfinite(values).any():
        return where
    index = np.unravel_index(int(np.nanargmax(values)), values.shape)
    x = float(np.asarray(metrics["peak_deck_acceleration_x"].values, dtype=float)[index])
    return f"{where}, x = {x:.4g} m" if np.isfinite(x) else where


def _speed_kmh(table: Mapping[str, Any]) -> float | None:
    train = table.get("train", {})
    if train.get("speed_kmh") is not None:
        return float(train["speed_kmh"])
    if train.get("speed") is not None:
        return 3.6 * float(train["speed"])
    return None


@dataclass(frozen=True)
class _SpanDelta:
    """δ under LM71 Φ (α = 1) of every span, with what the rows say of it."""

    length: np.ndarray
    delta: np.ndarray
    phi: np.ndarray
    lphi: np.ndarray
    where: list[str]
    comfort_factor: float
    """EN 1990 A2.4.4.3.2(5): Figure A2.3's L/δ times 0.7 for one span, two simply supported spans
    or two continuous spans, 0.9 for continuous girders of three or more spans."""


def _span_deltas(bridge: Mapping[str, Any], opts: CheckOptions) -> _SpanDelta:
    if is_simply_supported(bridge):
        length = float(bridge["span_length"])
        phi = dynamic_factor(length, opts.maintenance)
        delta = lm71_deflection(bridge, 1.0) * phi
        spans = int(bridge.get("spans", 1))
        factor = COMFORT_SPAN_FACTOR if spans <= 2 else 1.0
        return _SpanDelta(
            np.array([length]), np.array([delta]), np.array([phi]), np.array([length]), ["every span"], factor
        )
    d = long_form_deflections(bridge)
    phi = np.array([dynamic_factor(x, opts.maintenance) for x in d.determinant_length])
    if d.span_length.size <= 2:
        factor = COMFORT_SPAN_FACTOR
    elif d.continuous_spans.max() >= 3:
        factor = COMFORT_CONTINUOUS_FACTOR
    else:
        factor = 1.0
    where = [f"span {k + 1}" for k in range(d.span_length.size)]
    return _SpanDelta(d.span_length, d.deflection * phi, phi, d.determinant_length, where, factor)


def _deflection_rows(
    bridge: Mapping[str, Any], opts: CheckOptions, moving_load: bool, speed: float | None, metrics: xr.Dataset
) -> list[Check]:
    """A2.4.4.2.3(1) (L/600 under α LM71 Φ) and, without a car body, the comfort criterion of
    A2.4.4.3.2 (δ under LM71 Φ, α = 1); with one, the car-body acceleration of A2.4.4.3.1. On a
    long-form bridge each span is checked against its own length, with its girder's Φ; the row
    shows the governing span."""
    name = "vertical deflection, LM71 x alpha x Phi (A2.4.4.2.3(1))"
    comfort_name = f"comfort, car-body acceleration b_v ({opts.comfort}, A2.4.4.3.1, Table A2.9)"
    rows: list[Check] = []
    b_v = COMFORT_LEVELS[opts.comfort]
    phi_name = "Phi2" if opts.maintenance == "careful" else "Phi3"
    spans: _SpanDelta | None = None
    if not bridge:
        rows.append(Check(name, None, None, "m", "", None, None, "no [bridge]"))
    else:
        try:
            spans = _span_deltas(bridge, opts)
        except (ValueError, KeyError) as exc:  # a bridge the static solve cannot take
            rows.append(Check(name, None, None, "m", "", None, None, f"not computed: {exc}"))
    if spans is not None:
        value = opts.alpha * spans.delta
        limit = spans.length / DEFLECTION_RATIO
        k = int(np.argmax(value / limit))
        lphi = f" (L_Phi = {spans.lphi[k]:.4g} m)" if spans.where[k] != "every span" else ""
        ratio = spans.length[k] / value[k]
        note = f"alpha = {opts.alpha:g}, {phi_name} = {spans.phi[k]:.3f}{lphi}; L/delta = {ratio:.0f}"
        rows.append(
            Check(name, value[k], limit[k], "m", spans.where[k], None, bool(np.all(value <= limit)), note)
        )
    worst = None if moving_load else _worst(metrics, "peak_carbody_az")
    if worst is not None:
        v, where, when = worst
        reached = next((lvl for lvl, b in COMFORT_LEVELS.items() if v <= b), "below acceptable")
        rows.append(Check(comfort_name, v, b_v, "m/s^2", where, when, v <= b_v, f"level reached: {reached}"))
        return rows
    name = f"comfort, deflection delta/L ({opts.comfort}, A2.4.4.3.2)"
    if spans is None:
        rows.append(Check(name, None, None, "m", "", None, None, "no car body and no LM71 deflection"))
        return rows
    at = f" at V = {speed:.0f} km/h" if speed is not None else ""
    if opts.comfort_l_over_delta is None:
        k = int(np.argmax(spans.delta / spans.length))
        rows.append(
            Check(
                name,
                spans.delta[k],
                None,
                "m",
                spans.where[k],
                None,
                None,
                f"no car body: L/delta = {spans.length[k] / spans.delta[k]:.0f}; give Figure A2.3's "
                f"L/delta{at} (--comfort-l-over-delta)",
            )
        )
        return rows
    required = max(opts.comfort_l_over_delta * spans.comfort_factor / b_v, DEFLECTION_RATIO)
    limit = spans.length / required
    k = int(np.argmax(spans.delta / limit))
    ratio = spans.length[k] / spans.delta[k]
    note = f"no car body: L/delta = {ratio:.0f} against {required:.0f} (Figure A2.3{at})"
    rows.append(
        Check(
            name,
            spans.delta[k],
            limit[k],
            "m",
            spans.where[k],
            None,
            bool(np.all(spans.delta <= limit)),
            note,
        )
    )
    return rows


def _seismic_rows(
    metrics: xr.Dataset, moving_load: bool, opts: CheckOptions, bilateral: bool = False
) -> list[Check]:
    rows: list[Check] = []
    worst = None if moving_load else _worst(metrics, "max_unloading_ratio")
    name = f"wheel unloading dP/P <= {SEISMIC_UNLOADING_LIMIT:g} (transient)"
    if worst is None:
        rows.append(Check(name, None, SEISMIC_UNLOADING_LIMIT, "1", "", None, None, "prescribed axle loads"))
    else:
        v, where, when = worst
        rows.append(Check(name, v, SEISMIC_UNLOADING_LIMIT, "1", where, when, v <= SEISMIC_UNLOADING_LIMIT))
    unilateral = "lift_offs" in metrics and not bilateral
    if moving_load or not unilateral:
        why = "prescribed axle loads" if moving_load else "bilateral contact: a wheel cannot lift"
        rows.append(Check("lift-offs", None, None, "", "", None, None, why))
        rows.append(Check("longest contact loss", None, None, "s", "", None, None, why))
        rows.append(
            Check("wheel uplift <= flange height", None, opts.flange_height, "m", "", None, None, why)
        )
    else:
        total = float(np.nansum(np.asarray(metrics["lift_offs"].values, dtype=float)))
        w = _worst(metrics, "lift_offs")
        rows.append(
            Check("lift-offs", total, None, "", w[1] if w and w[0] > 0 else "", None, None, "all wheels")
        )
        w = _worst(metrics, "longest_contact_loss")
        if w is None:
            rows.append(Check("longest contact loss", None, None, "s", "", None, None, "not in the results"))
        else:
            lifted = w[0] > 0
            rows.append(
                Check(
                    "longest contact loss",
                    w[0],
                    None,
                    "s",
                    w[1] if lifted else "",
                    w[2] if lifted else None,
                    None,
                )
            )
        w = _worst(metrics, "peak_uplift")
        if w is None:
            rows.append(
                Check(
                    "wheel uplift <= flange height",
                    None,
                    opts.flange_height,
                    "m",
                    "",
                    None,
                    None,
                    "not in the results",
                )
            )
        else:
            v, where, when = w
            rows.append(
                Check(
                    "wheel uplift <= flange height",
                    v,
                    opts.flange_height,
                    "m",
                    where,
                    when,
                    v <= opts.flange_height,
                )
            )
    if "peak_derailment_quotient" in metrics:
        rows += _lateral_rows(metrics, opts)
    w = _worst(metrics, "peak_midspan_uz_rel")
    if w is not None:
        rows.append(
            Check(
                "deck displacement relative to the ground",
                w[0],
                None,
                "m",
                w[1],
                w[2],
                None,
                "midspan, for information",
            )
        )
    w = _worst(metrics, "peak_deck_acceleration")
    if w is not None:
        rows.append(
            Check(
                "deck acceleration (absolute)",
                w[0],
                None,
                "m/s^2",
                w[1],
                w[2],
                None,
                "includes the ground's motion: not a traffic limit (A2.4.4.2.1) in a seismic run",
            )
        )
    return rows


def _lateral_rows(metrics: xr.Dataset, opts: CheckOptions) -> list[Check]:
    """The running-safety rows of a 3D run (module docstring)."""
    rows: list[Check] = []
    name = (
        f"derailment quotient Y/Q <= {NADAL_LIMIT:g} "
        f"(Nadal, flange {FLANGE_ANGLE_DEG:g} deg, mu {FLANGE_FRICTION:g})"
    )
    w = _worst(metrics, "peak_derailment_quotient")
    if w is None:
        rows.append(Check(name, math.nan, NADAL_LIMIT, "1", "", None, False, "invalid: no wheel with Q > 0"))
    else:
        rows.append(Check(name, w[0], NADAL_LIMIT, "1", w[1], w[2], w[0] <= NADAL_LIMIT))
    name = f"derailment quotient (Y/Q)_2m <= {EN14363_QUOTIENT_LIMIT:g} (EN 14363)"
    w = _worst(metrics, "peak_derailment_quotient_2m")
    if "peak_derailment_quotient_2m" not in metrics:
        rows.append(
            Check(name, None, EN14363_QUOTIENT_LIMIT, "1", "", None, None, "no 2 m window: the train stands")
        )
    elif w is not None:
        rows.append(
            Check(name, w[0], EN14363_QUOTIENT_LIMIT, "1", w[1], w[2], w[0] <= EN14363_QUOTIENT_LIMIT)
        )
    else:
        rows.append(Check(name, math.nan, EN14363_QUOTIENT_LIMIT, "1", "", None, False, "invalid: all NaN"))
    rows.append(_prudhomme_row(metrics, opts.prudhomme_alpha))
    w = _worst(metrics, "peak_carbody_ay")
    limit = opts.carbody_ay_limit
    name = "car-body lateral acceleration"
    if w is not None:
        note = "for information (no limit given)" if limit is None else "limit given by the user"
        passed = None if limit is None else w[0] <= limit
        rows.append(Check(name, w[0], limit, "m/s^2", w[1], w[2], passed, note))
    if "flange_contacts" in metrics:
        counts = np.asarray(metrics["flange_contacts"].values, dtype=float)
        total = float(np.nansum(counts))
        w = _worst(metrics, "flange_contacts")
        where = w[1] if w is not None and w[0] > 0 else ""
        rows.append(Check("flange contacts", total, None, "", where, None, None, "all wheels"))
    w = _worst(metrics, "peak_midspan_uy_rel")
    if w is not None:
        rows.append(
            Check(
                "lateral deck displacement relative to the ground",
                w[0],
                None,
                "m",
                w[1],
                w[2],
                None,
                "midspan, for information",
            )
        )
    return rows


def _prudhomme_row(metrics: xr.Dataset, alpha: float) -> Check:
    """``(ΣY)_2m`` (or ΣY) of every wheelset against ``α (10 + P0/3)`` kN of its own static load."""
    smoothed = "peak_axle_lateral_force_2m" in metrics
    metric = "peak_axle_lateral_force_2m" if smoothed else "peak_axle_lateral_force"
    label = "(sum Y)_2m" if smoothed else "sum Y"
    name = f"track-shift force {label} <= alpha (10 + P0/3) kN (Prud'homme, alpha = {alpha:g})"
    if metric not in metrics or "static_axle_load" not in metrics:
        return Check(name, None, None, "N", "", None, None, "not in the results")
    da = metrics[metric]
    values = np.asarray(da.values, dtype=float)
    p0 = np.asarray(metrics["static_axle_load"].transpose(*da.dims).values, dtype=float)
    limits = alpha * (10e3 + p0 / 3.0)
    ratio = values / limits
    if values.size == 0 or not np.isfinite(ratio).any():
        return Check(name, math.nan, None, "N", "", None, False, "invalid: all NaN")
    index = np.unravel_index(int(np.nanargmax(ratio)), ratio.shape)
    where = ", ".join(f"{d} {metrics.coords[d].values[i]}" for d, i in zip(da.dims, index, strict=True))
    when = float(np.asarray(metrics[f"{metric}_time"].values)[index]) if f"{metric}_time" in metrics else None
    value, limit = float(values[index]), float(limits[index])
    note = f"P0 = {p0[index] / 1e3:.4g} kN" + ("" if smoothed else "; no 2 m window: the train stands")
    return Check(name, value, limit, "N", where, when, value <= limit, note)


def _complete_row(metrics: xr.Dataset) -> Check:
    raw = np.asarray(metrics["complete"].values, dtype=float) if "complete" in metrics else np.array(1.0)
    complete = int(raw) if np.isfinite(raw) else 0
    return Check(
        "run complete",
        float(complete),
        1.0,
        "",
        "",
        None,
        bool(complete),
        "" if complete else str(metrics.attrs.get("incomplete", "stopped early"))[:80],
    )


def _rotation_rows(metrics: xr.Dataset, track_form: str) -> list[Check]:
    """With ballasted track, the deck end rotation at a transition to the embankment (the first
    span's left end, the last span's right end) and the sum of the two end rotations between
    consecutive decks (module docstring: EN 1990 A2.4.4.2.3(2), EN 1991-2 6.5.4, the values of
    ENV 1991-3 Annex G). Direct fastening has project-specific limits (n/a)."""
    name_end = "end rotation at abutments (A2.4.4.2.3(2))"
    name_joint = "rotation between decks (A2.4.4.2.3(2))"
    if "peak_end_rotation" not in metrics:
        return [Check(name_end, None, None, "rad", "", None, None, "not in the results")]
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


def checks_table(rows: list[Check]) -> str:
    """Plain-text table: check, value, limit, where, when, status, note."""
    head = ("check", "value", "limit", "where", "when (s)", "status", "note")
    cells = [head]
    for r in rows:
        cells.append(
            (
                r.name,
                "n/a" if r.value is None else f"{r.value:.4g} {r.unit}".strip(),
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
