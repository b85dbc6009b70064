"""Results of a 3D run: the lateral wheel-rail forces, the running-safety indices and the lateral
response of the bridge, from the histories a 3D time loop records (docs/three-d.md, "Results of a
3D run").

The input is :class:`Histories3D`, one row per time step (every step: the wheel forces are low-pass
filtered at the full rate, as in 2D). :func:`dataset3d` turns it into the variables of the results
Dataset, with the 2D conventions (``units``, ``long_name``, 1-based ``car`` and ``wheel``); the 3D
per-wheel variables gain a ``side`` dimension (``left``, ``right``). In 3D ``wheel`` numbers the
wheelsets (axles) of a car from its front, as the wheels of the 2D model do, and ``side`` the two
wheels of a wheelset. :func:`lateral_summary` gives the run's running-safety attributes and
:func:`summary_lines` the lines ``svbi run`` prints.

Axes are the track's: x along the track in the direction of travel, y to the left, z up; roll and
twist about x, positive lifting the left side. Side ``s`` is +1 on the left, -1 on the right.

**Wheel-rail forces in track axes.** The contact normal of side ``s`` (from the rail into the wheel)
leans towards the track centre by the contact angle ``δ``: ``n = (0, -s sin δ, cos δ)``. The lateral
creep force ``T`` acts on the wheel in the contact plane along ``t = (0, cos δ, s sin δ)`` (positive
towards the left, the direction of the lateral creepage); the flange force ``F ≥ 0`` acts on the
wheel horizontally towards the track centre. The force of the rail on the wheel is then
``F_y = -s N sin δ + T cos δ - s F``, ``F_z = N cos δ + s T sin δ``, and the wheel presses on its rail
with the opposite. EN 14363 names the components of that force in track axes:

* ``Q = N cos δ + s T sin δ``: the vertical wheel force (``contact_force``), downwards on the rail;
* ``Y = -s F_y = N sin δ - s T cos δ + F``: the lateral wheel force (``wheel_lateral_force``),
  **positive outwards**, the sense in which a flanging wheel pushes its rail and in which Nadal's
  derailment quotient ``Y/Q`` is positive (a wheel pulled inwards gives a negative ``Y``);
* ``ΣY = Y_left - Y_right``: the lateral force of the wheelset on the track (``axle_lateral_force``),
  in track axes, positive to the left. The outward pushes of the two inclined normals under a
  symmetric load cancel in it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .force_filter import design, sosfiltfilt_rows

if TYPE_CHECKING:
    import xarray as xr

FILTER_ORDER = 4
SIDES = ("left", "right")
SIDE_SIGN = np.array([1.0, -1.0])
"""``s`` of the ``side`` dimension: +1 left, -1 right."""
WINDOW_M = 2.0
"""m: the sliding mean of EN 14363 for ``(Y/Q)_2m`` and ``(ΣY)_2m``."""

Variable = tuple[tuple[str, ...], np.ndarray, dict[str, str]]


def wheel_forces(
    normal: np.ndarray, angle: np.ndarray, creep_lateral: np.ndarray, flange: np.ndarray, side: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(Q, Y)`` of wheels (module docstring): the vertical and the outward lateral wheel-rail
    force in track axes, from the normal force ``N`` (compression positive), the contact angle
    ``δ`` (rad, the normal leaning towards the track centre), the lateral creep force ``T`` on the
    wheel (in the contact plane, positive to the left), the flange force ``F`` (>= 0) and the side
    ``s`` (+1 left, -1 right). Arrays broadcast."""
    c, s = np.cos(angle), np.sin(angle)
    q = normal * c + side * creep_lateral * s
    y = normal * s - side * creep_lateral * c + flange
    return q, y


def axle_lateral_force(y: np.ndarray) -> np.ndarray:
    """``ΣY`` of each wheelset from the outward ``Y`` of its wheels (last axis: left, right): the
    lateral force of the wheelset on the track, positive to the left, ``Y_left - Y_right``."""
    return y[..., 0] - y[..., 1]


def sum_y_variable(variables: Any) -> str:
    """The ΣY variable whose peak a 3D run's summary, ``svbi metrics`` and the lateral figure read:
    ``axle_lateral_force_filtered`` (the filtered forces, as Y/Q and ΔQ/Q), or ``axle_lateral_force``
    in results written before it existed."""
    return (
        "axle_lateral_force_filtered" if "axle_lateral_force_filtered" in variables else "axle_lateral_force"
    )


def derailment_quotient(y: np.ndarray, q: np.ndarray, in_contact: np.ndarray | None = None) -> np.ndarray:
    """``Y/Q``, NaN where ``Q <= 0`` or the wheel is off its rail."""
    ok = q > 0 if in_contact is None else (q > 0) & in_contact
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(ok, y / np.where(ok, q, 1.0), np.nan)


def prudhomme_limit(static_axle_load: np.ndarray | float, alpha: float = 1.0) -> np.ndarray:
    """Prud'homme's limit of ``ΣY`` (N) for the static axle load ``P0`` (N): ``α (10 kN + P0/3)``,
    ``P0 = 2 Q0`` for a static wheel load ``Q0``; ``α`` 1.0, or 0.85 for freight wagons."""
    return alpha * (10e3 + np.asarray(static_axle_load, dtype=float) / 3.0)


def nadal_limit(flange_angle: float, friction: float) -> float:
    """Nadal's limit of ``Y/Q`` for flange climbing: ``(tan γ - μ) / (1 + μ tan γ)``."""
    t = np.tan(flange_angle)
    return float((t - friction) / (1.0 + friction * t))


def sliding_mean(values: np.ndarray, distance: np.ndarray, window: float = WINDOW_M) -> np.ndarray:
    """The mean along axis 0 of ``values`` over the samples within ``window / 2`` of travel on either
    side (a centred window; shortened at the ends of the run), NaN samples left out (NaN where a
    window has none). ``distance`` (m) must increase strictly."""
    x = np.asarray(values, dtype=float)
    s = np.asarray(distance, dtype=float)
    lo = np.searchsorted(s, s - 0.5 * window, side="left")
    hi = np.searchsorted(s, s + 0.5 * window, side="right")
    flat = x.reshape(x.shape[0], -1)
    valid = np.isfinite(flat)
    total = np.concatenate([np.zeros((1, flat.shape[1])), np.cumsum(np.where(valid, flat, 0.0), axis=0)])
    count = np.concatenate([np.zeros((1, flat.shape[1])), np.cumsum(valid, axis=0)])
    n = count[hi] - count[lo]
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(n > 0, (total[hi] - total[lo]) / np.where(n > 0, n, 1.0), np.nan)
    return out.reshape(x.shape)


@dataclass
class Histories3D:
    """What a 3D time loop records, one row per time step (``n`` steps, ``c`` cars, ``a`` wheelsets
    per car, the last axis of a wheel's array the side: 0 left, 1 right). Signs as in the module
    docstring; displacements from the static state (the deck's from its dead-load state), SI units.

    * ``time`` (n,) s; ``distance`` (n,) m: how far the train has travelled since t = 0 (the 2 m
      windows; a train that does not move at every step gets none);
    * ``normal_force`` (n, c, a, 2) N, compression positive, the static load included;
    * ``contact_angle`` (n, c, a, 2) rad: the angle of the contact normal from the normal of the
      track plane, positive leaning towards the track centre (``atan λ`` plus ``s`` times the
      wheelset's roll relative to the track, for the cones of docs/three-d.md);
    * ``creep_longitudinal`` (n, c, a, 2) N: on the wheel, along +x; ``creep_lateral`` (n, c, a, 2)
      N: on the wheel, in the contact plane, positive to the left;
    * ``flange_force`` (n, c, a, 2) N, >= 0, on the wheel towards the track centre (0 when the flange
      is clear); ``flange_contact`` (n, c, a, 2) bool;
    * ``in_contact`` (n, c, a, 2) bool: the tread on its rail (None: always);
    * ``wheel_rail_lateral`` (n, c, a) m: the wheelset's lateral displacement relative to the track
      centreline under it, positive to the left;
    * ``static_wheel_load`` (c, a, 2) N: the vertical wheel load ``Q0`` in static equilibrium on
      level track;
    * ``carbody_ay`` (n, c) m/s²: car-body absolute lateral acceleration, +y; ``carbody_roll``
      (n, c) rad: from static equilibrium, positive lifting the left side;
    * ``midspan_uy``, ``midspan_twist`` (n, spans) m, rad: absolute; ``midspan_uy_rel``,
      ``midspan_twist_rel`` (n, spans): relative to the ground the span moves with as a rigid body;
    * ``pier_top_uy``, ``pier_top_uy_rel`` (n, piers) m: absolute and relative to the ground at the
      pier's base (None without piers).
    """

    time: np.ndarray
    distance: np.ndarray
    normal_force: np.ndarray
    contact_angle: np.ndarray
    creep_longitudinal: np.ndarray
    creep_lateral: np.ndarray
    flange_force: np.ndarray
    flange_contact: np.ndarray
    wheel_rail_lateral: np.ndarray
    static_wheel_load: np.ndarray
    carbody_ay: np.ndarray
    carbody_roll: np.ndarray
    midspan_uy: np.ndarray
    midspan_uy_rel: np.ndarray
    midspan_twist: np.ndarray
    midspan_twist_rel: np.ndarray
    in_contact: np.ndarray | None = None
    pier_top_uy: np.ndarray | None = None
    pier_top_uy_rel: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = np.asarray(self.time).shape[0]
        wheel = np.asarray(self.normal_force).shape
        if len(wheel) != 4 or wheel[0] != n or wheel[3] != 2:
            raise ValueError(f"normal_force: expected (steps, cars, wheelsets, 2), got {wheel}")
        for name in (
            "contact_angle",
            "creep_longitudinal",
            "creep_lateral",
            "flange_force",
            "flange_contact",
        ):
            if np.shape(getattr(self, name)) != wheel:
                raise ValueError(f"{name}: expected shape {wheel}, got {np.shape(getattr(self, name))}")
        if self.in_contact is not None and np.shape(self.in_contact) != wheel:
            raise ValueError(f"in_contact: expected shape {wheel}, got {np.shape(self.in_contact)}")
        checks = {
            "distance": (n,),
            "wheel_rail_lateral": wheel[:3],
            "static_wheel_load": wheel[1:],
            "carbody_ay": wheel[:2],
            "carbody_roll": wheel[:2],
        }
        for name, shape in checks.items():
            if np.shape(getattr(self, name)) != shape:
                raise ValueError(f"{name}: expected shape {shape}, got {np.shape(getattr(self, name))}")
        spans = np.shape(self.midspan_uy)
        for name in ("midspan_uy", "midspan_uy_rel", "midspan_twist", "midspan_twist_rel"):
            shape = np.shape(getattr(self, name))
            if len(shape) != 2 or shape[0] != n or shape != spans:
                raise ValueError(f"{name}: expected (steps, spans) like midspan_uy {spans}, got {shape}")
        if (self.pier_top_uy is None) != (self.pier_top_uy_rel is None):
            raise ValueError("pier_top_uy and pier_top_uy_rel: give both or neither")
        if self.pier_top_uy is not None:
            for name in ("pier_top_uy", "pier_top_uy_rel"):
                shape = np.shape(getattr(self, name))
                if len(shape) != 2 or shape[0] != n or shape != np.shape(self.pier_top_uy):
                    raise ValueError(f"{name}: expected (steps, piers), got {shape}")
        if np.any(np.asarray(self.flange_force) < 0):
            raise ValueError("flange_force: must be >= 0 (its direction is towards the track centre)")

    @property
    def moving(self) -> bool:
        """Whether the train moves at every step (the 2 m windows need it)."""
        s = np.asarray(self.distance, dtype=float)
        return s.size > 1 and bool(np.all(np.diff(s) > 0))


def _a(units: str, long_name: str) -> dict[str, str]:
    return {"units": units, "long_name": long_name}


def _lowpass(rows: np.ndarray, cutoff_hz: float, dt: float) -> np.ndarray:
    """The zero-phase Butterworth low-pass of the 2D contact forces (``results.Recorder``) along
    axis 0, at the full rate: unchanged when the cutoff is at or above Nyquist."""
    n = rows.shape[0]
    flat = np.ascontiguousarray(rows.reshape(n, -1), dtype=float)
    if n < 2 or not cutoff_hz < 0.5 / dt:
        return flat.reshape(rows.shape).copy()
    sos, zi = design(FILTER_ORDER, cutoff_hz, 1.0 / dt)
    padlen = min(3 * (2 * len(sos) + 1), n - 1)
    return sosfiltfilt_rows(sos, flat, padlen, 1, n, zi).reshape(rows.shape)


def lateral_variables(
    h: Histories3D, output_every: int = 1, force_filter_hz: float = 20.0
) -> tuple[dict[str, Variable], dict[str, Any], dict[str, Any]]:
    """The Dataset variables, coordinates and summary attributes of a 3D run's histories: every
    ``output_every``-th step stored; the wheel forces low-pass filtered at ``force_filter_hz``
    (Butterworth order 4, zero phase, at the full rate: the 2D ``contact_force_filtered``)."""
    every = max(1, int(output_every))
    t_all = np.asarray(h.time, dtype=float)
    n = t_all.size
    dt = float(np.median(np.diff(t_all))) if n > 1 else 1.0
    pick = slice(None, None, every)
    side = SIDE_SIGN[None, None, None, :]
    contact = (
        np.ones(np.shape(h.normal_force), bool) if h.in_contact is None else np.asarray(h.in_contact, bool)
    )
    q, y = wheel_forces(
        np.asarray(h.normal_force, float),
        np.asarray(h.contact_angle, float),
        np.asarray(h.creep_lateral, float),
        np.asarray(h.flange_force, float),
        side,
    )
    # filtered at the full rate (the 2 m means need every step), then stored every ``every`` steps
    qf_full = np.where(contact, _lowpass(q, force_filter_hz, dt), 0.0)  # off the rail: nothing
    yf_full = _lowpass(y, force_filter_hz, dt)
    qf, yf = qf_full[pick], yf_full[pick]
    stored_contact = contact[pick]
    q0 = np.asarray(h.static_wheel_load, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        unloading = np.where(q0 > 0, (q0 - qf) / np.where(q0 > 0, q0, 1.0), np.nan)
    yq = derailment_quotient(yf, qf, stored_contact)
    sy = axle_lateral_force(y)
    # the sum Y of the filtered forces (its peak and 2 m mean): the raw one has a rigid landing's
    # force at single steps
    syf_full = axle_lateral_force(yf_full)
    syf = syf_full[pick]
    flange = np.asarray(h.flange_contact, dtype=bool)
    wheel = ("time", "car", "wheel", "side")
    axle = ("time", "car", "wheel")
    cut = (
        f"Butterworth order {FILTER_ORDER}, zero phase, cutoff {force_filter_hz:g} Hz, at the full step rate"
    )
    v: dict[str, Variable] = {
        "contact_force": (
            wheel,
            q[pick],
            _a("N", "vertical wheel-rail force Q in track axes, compression positive (raw)"),
        ),
        "contact_force_filtered": (wheel, qf, _a("N", f"contact_force low-pass filtered: {cut}")),
        "normal_contact_force": (
            wheel,
            np.asarray(h.normal_force, float)[pick],
            _a("N", "wheel-rail force along the contact normal, compression positive"),
        ),
        "contact_angle": (
            wheel,
            np.asarray(h.contact_angle, float)[pick],
            _a("rad", "angle of the contact normal from the track plane's normal, towards the track centre"),
        ),
        "creep_force": (
            wheel,
            np.asarray(h.creep_longitudinal, float)[pick],
            _a("N", "longitudinal creep force on the wheel, +x forward"),
        ),
        "lateral_creep_force": (
            wheel,
            np.asarray(h.creep_lateral, float)[pick],
            _a("N", "lateral creep force on the wheel, in the contact plane, positive to the left"),
        ),
        "flange_force": (
            wheel,
            np.asarray(h.flange_force, float)[pick],
            _a("N", "flange force on the wheel, towards the track centre (0: flange clear)"),
        ),
        "wheel_lateral_force": (
            wheel,
            y[pick],
            _a(
                "N",
                "lateral wheel-rail force Y in track axes, the wheel on its rail, positive outwards (raw)",
            ),
        ),
        "wheel_lateral_force_filtered": (wheel, yf, _a("N", f"wheel_lateral_force low-pass filtered: {cut}")),
        "derailment_quotient": (
            wheel,
            yq,
            _a(
                "1",
                "Y/Q of the filtered forces, Y positive outwards; NaN where Q <= 0 or the wheel is off "
                "its rail",
            ),
        ),
        "axle_lateral_force": (
            axle,
            sy[pick],
            _a(
                "N",
                "sum of Y of the wheelset in track axes (Y_left - Y_right): its force on the track, "
                "positive left (raw)",
            ),
        ),
        "axle_lateral_force_filtered": (
            axle,
            syf,
            _a("N", f"axle_lateral_force of the filtered Y ({cut}): the run's peak sum Y is read here"),
        ),
        "unloading_ratio": (
            wheel,
            unloading,
            _a("1", "(Q0 - Q) / Q0: Q contact_force_filtered, Q0 the static wheel load (at most 1)"),
        ),
        "static_wheel_load": (
            ("car", "wheel", "side"),
            q0,
            _a("N", "static vertical wheel load Q0 on level track"),
        ),
        "wheel_rail_lateral_displacement": (
            axle,
            np.asarray(h.wheel_rail_lateral, float)[pick],
            _a(
                "m",
                "lateral displacement of the wheelset relative to the track centreline under it, "
                "positive left",
            ),
        ),
        "flange_contact": (
            wheel,
            flange[pick].astype(np.int8),
            _a("1", "1: flange in contact with its rail"),
        ),
        "carbody_ay": (
            ("time", "car"),
            np.asarray(h.carbody_ay, float)[pick],
            _a("m/s^2", "car-body absolute lateral acceleration, positive to the left"),
        ),
        "carbody_roll": (
            ("time", "car"),
            np.asarray(h.carbody_roll, float)[pick],
            _a("rad", "car-body roll from static equilibrium, positive lifting the left side"),
        ),
        "midspan_uy": (
            ("time", "span"),
            np.asarray(h.midspan_uy, float)[pick],
            _a("m", "absolute lateral displacement of the shear centre at midspan, positive left"),
        ),
        "midspan_uy_rel": (
            ("time", "span"),
            np.asarray(h.midspan_uy_rel, float)[pick],
            _a("m", "lateral displacement at midspan relative to the ground under the span"),
        ),
        "midspan_twist": (
            ("time", "span"),
            np.asarray(h.midspan_twist, float)[pick],
            _a("rad", "absolute twist of the deck at midspan, positive lifting the left side"),
        ),
        "midspan_twist_rel": (
            ("time", "span"),
            np.asarray(h.midspan_twist_rel, float)[pick],
            _a("rad", "twist at midspan relative to the ground under the span"),
        ),
    }
    if h.in_contact is not None:
        v["contact_state"] = (
            wheel,
            stored_contact.astype(np.int8),
            _a("1", "1: wheel on its rail, 0: off it"),
        )
    if h.moving:
        s = np.asarray(h.distance, dtype=float)
        yq_full = derailment_quotient(yf_full, qf_full, contact)
        v["derailment_quotient_2m"] = (
            wheel,
            sliding_mean(yq_full, s)[pick],
            _a("1", f"derailment_quotient, sliding mean over {WINDOW_M:g} m of travel (EN 14363)"),
        )
        v["axle_lateral_force_2m"] = (
            axle,
            sliding_mean(syf_full, s)[pick],
            _a(
                "N",
                f"axle_lateral_force of the filtered Y, sliding mean over {WINDOW_M:g} m of travel "
                "(EN 14363)",
            ),
        )
    if h.pier_top_uy is not None:
        v["pier_top_uy"] = (
            ("time", "pier"),
            np.asarray(h.pier_top_uy, float)[pick],
            _a("m", "absolute lateral displacement of the pier top, positive left"),
        )
        v["pier_top_uy_rel"] = (
            ("time", "pier"),
            np.asarray(h.pier_top_uy_rel, float)[pick],
            _a("m", "lateral displacement of the pier top relative to the ground at its base"),
        )
    c, a = q0.shape[:2]
    coords: dict[str, Any] = {
        "time": ("time", t_all[pick], _a("s", "time")),
        "car": ("car", np.arange(1, c + 1)),
        "wheel": ("wheel", np.arange(1, a + 1)),
        "side": ("side", np.array(SIDES, dtype=object)),
        "span": ("span", np.arange(1, np.shape(h.midspan_uy)[1] + 1)),
    }
    if h.pier_top_uy is not None:
        coords["pier"] = ("pier", np.arange(1, np.shape(h.pier_top_uy)[1] + 1))
    attrs = lateral_summary(
        t_all[pick], yq, syf, unloading, np.asarray(h.carbody_ay, float)[pick], t_all, flange, contact
    )
    return v, coords, attrs


def dataset3d(
    h: Histories3D,
    attrs: dict[str, Any] | None = None,
    output_every: int = 1,
    force_filter_hz: float = 20.0,
    base: xr.Dataset | None = None,
) -> xr.Dataset:
    """The results Dataset of a 3D run: the variables of :func:`lateral_variables` (they replace
    those of ``base`` of the same name, e.g. ``contact_force``), the other variables of ``base``
    kept, ``attrs`` and the running-safety summary as attributes."""
    import xarray as xr

    variables, coords, summary = lateral_variables(h, output_every, force_filter_hz)
    ds = xr.Dataset(data_vars=variables, coords=coords)
    if base is not None:
        ds = xr.merge([base.drop_vars([n for n in variables if n in base.variables]), ds], compat="override")
        ds.attrs = dict(base.attrs)
    ds.attrs.update(attrs or {})
    ds.attrs.update(summary)
    return ds


def _where(arr: np.ndarray, t: np.ndarray, prefix: str, out: dict[str, Any], lowest: bool = False) -> None:
    """``<prefix>`` (the value of largest magnitude, signed), ``_time``, ``_car``, ``_wheel`` and, for a
    wheel's array, ``_side`` of the peak of ``arr`` (time, car, wheel[, side]); nothing if all NaN."""
    finite = np.isfinite(arr)
    if not finite.any():
        return
    flat = int(np.argmax(np.where(finite, np.abs(arr), -np.inf)))
    index = np.unravel_index(flat, arr.shape)
    out[prefix] = float(arr[index])
    out[f"{prefix}_time"] = float(t[index[0]])
    out[f"{prefix}_car"] = int(index[1]) + 1
    if arr.ndim > 2:
        out[f"{prefix}_wheel"] = int(index[2]) + 1
    if arr.ndim > 3:
        out[f"{prefix}_side"] = SIDES[int(index[3])]


def lateral_summary(
    t: np.ndarray,
    quotient: np.ndarray,
    axle: np.ndarray,
    unloading: np.ndarray,
    carbody_ay: np.ndarray,
    t_steps: np.ndarray,
    flange: np.ndarray,
    on_rail: np.ndarray,
) -> dict[str, Any]:
    """The running-safety attributes of a 3D run (stored rows ``t``; the flange state at every step
    ``t_steps``): ``peak_derailment_quotient`` (largest Y/Q), ``peak_axle_lateral_force`` (largest
    |ΣY|, signed; ``axle`` the ΣY of the filtered forces, as Y/Q and ΔQ/Q read them: a rigid contact's
    landing or flange closing is a force at single steps, whose raw peak depends on the time step and
    on which steps are stored), ``peak_unloading_ratio``, ``peak_carbody_ay`` (largest |a_y|,
    signed), each with ``_time``, ``_car``, ``_wheel`` (the wheelset) and ``_side``, as they apply;
    ``flange_contacts`` (contacts that begin, over all wheels) with the first one's time, car,
    wheelset and side; ``wheel_lift_offs`` (the wheels that leave their rail, from ``on_rail``, the
    treads' contact state at every step) with the first one's."""
    out: dict[str, Any] = {}
    q = np.where(np.isfinite(quotient), quotient, -np.inf)
    if np.isfinite(q).any():  # the largest Y/Q (outwards), not the largest magnitude
        index = np.unravel_index(int(np.argmax(q)), q.shape)
        out["peak_derailment_quotient"] = float(quotient[index])
        out["peak_derailment_quotient_time"] = float(t[index[0]])
        out["peak_derailment_quotient_car"] = int(index[1]) + 1
        out["peak_derailment_quotient_wheel"] = int(index[2]) + 1
        out["peak_derailment_quotient_side"] = SIDES[int(index[3])]
    _where(axle, t, "peak_axle_lateral_force", out)
    u = np.where(np.isfinite(unloading), unloading, -np.inf)
    if np.isfinite(u).any():
        index = np.unravel_index(int(np.argmax(u)), u.shape)
        out["peak_unloading_ratio"] = float(unloading[index])
        out["peak_unloading_ratio_time"] = float(t[index[0]])
        out["peak_unloading_ratio_car"] = int(index[1]) + 1
        out["peak_unloading_ratio_wheel"] = int(index[2]) + 1
        out["peak_unloading_ratio_side"] = SIDES[int(index[3])]
    _where(carbody_ay, t, "peak_carbody_ay", out)
    _events(np.asarray(flange, dtype=bool), t_steps, "flange_contacts", "flange_contact", out)
    # a wheel off its rail at the start has not lifted off
    _events(~np.asarray(on_rail, dtype=bool), t_steps, "wheel_lift_offs", "wheel_lift_off", out, False)
    return out


def _events(
    on: np.ndarray, t_steps: np.ndarray, count: str, first: str, out: dict[str, Any], at_start: bool = True
) -> None:
    """The events that begin in ``on`` (steps, car, wheel, side; at the first step too with
    ``at_start``) into ``out[count]``, the first one's time, car, wheelset and side into
    ``out[first + "_time"]`` ..."""
    starts = np.zeros_like(on)
    if on.shape[0]:
        starts[0] = on[0] if at_start else False
        starts[1:] = on[1:] & ~on[:-1]
    out[count] = int(starts.sum())
    if starts.any():
        i, c, w, s = np.argwhere(starts)[0]
        out[f"{first}_time"] = float(t_steps[i])
        out[f"{first}_car"] = int(c) + 1
        out[f"{first}_wheel"] = int(w) + 1
        out[f"{first}_side"] = SIDES[int(s)]


def _at(attrs: dict[str, Any], prefix: str) -> str:
    parts = [f"t = {float(attrs[f'{prefix}_time']):.4g} s", f"car {attrs[f'{prefix}_car']}"]
    if f"{prefix}_wheel" in attrs:
        parts.append(f"wheelset {attrs[f'{prefix}_wheel']}")
    if f"{prefix}_side" in attrs:
        parts.append(str(attrs[f"{prefix}_side"]))
    return ", ".join(parts)


def summary_lines(attrs: dict[str, Any]) -> list[str]:
    """The lines ``svbi run`` prints for a 3D run's running safety (none for a 2D run)."""
    if "flange_contacts" not in attrs:
        return []
    lines = []
    if "peak_derailment_quotient" in attrs:
        lines.append(
            f"derailment quotient Y/Q: peak {attrs['peak_derailment_quotient']:.3g} "
            f"({_at(attrs, 'peak_derailment_quotient')})"
        )
    if "peak_axle_lateral_force" in attrs:
        lines.append(
            f"axle lateral force sum Y: peak {1e-3 * attrs['peak_axle_lateral_force']:.4g} kN "
            f"({_at(attrs, 'peak_axle_lateral_force')})"
        )
    if "peak_unloading_ratio_side" in attrs:
        lines.append(
            f"wheel unloading dQ/Q: peak {attrs['peak_unloading_ratio']:.3g} "
            f"({_at(attrs, 'peak_unloading_ratio')})"
        )
    count = int(attrs["flange_contacts"])
    first = (
        f", the first at {_at(attrs, 'flange_contact')}" if count and "flange_contact_time" in attrs else ""
    )
    lines.append(f"flange contacts: {count}{first}")
    if "wheel_lift_offs" in attrs:
        count = int(attrs["wheel_lift_offs"])
        first = f", the first at {_at(attrs, 'wheel_lift_off')}" if count else ""
        check = (
            "; on the rigid contact the indices then converge with the time step only: check them at "
            'half the step (a study over solver.time_step: docs/three-d.md, "Checking the time step")'
            if count
            else ""
        )
        lines.append(f"wheel lift-offs: {count}{first}{check}")
    if "peak_carbody_ay" in attrs:
        lines.append(
            f"car-body lateral acceleration: peak {attrs['peak_carbody_ay']:.3g} m/s^2 "
            f"({_at(attrs, 'peak_carbody_ay')})"
        )
    return lines
