"""Ground motion at the bridge supports and under the approach track: q, q', q'' (paper Eqs. 22-24).

:class:`GroundMotion` answers ``motion(component, t, x) -> (q, qd, qdd)`` for the components
``"vertical"`` and ``"longitudinal"`` (and ``"lateral"``, the transverse component of 3D
scenarios: positive to the left of the train, docs/three-d.md), broadcasting t against the
positions x (support positions, or wheel positions on the approach ground). Three spatial models:

* **synchronous** (the paper's case): every x moves with q(t);
* **wave passage**: the motion at x is q(t - (x - x_ref)/c_app), a wave with apparent velocity
  c_app that reaches ``x_ref`` (default 0, the first support) at the arrival time. An infinite
  velocity gives the synchronous motion exactly (the delay is 0.0);
* **one record per support**: ``records`` is a list, one per support position; x must be one of
  those positions. A ``"none"`` in the list is a support that stays at rest.

A component given as ``"none"`` is identically zero. Every history starts with q = q' = q'' = 0 (the
records' tapers, see :mod:`~svbi.runtime.excitation.processing`), and is at rest after it ends.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .processing import MotionHistory, Processing, process_record
from .records import Record, RecordError, read_record
from .synthetic import DEFAULT_SEED, synthetic_motion, synthetic_record

COMPONENTS = ("vertical", "longitudinal")
"""The components of the 2D model (the vertical plane)."""
COMPONENTS_3D = (*COMPONENTS, "lateral")
"""With the transverse component of 3D scenarios."""
Triple = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
Source = str | Path | Record
"""A component's source: ``"none"``, ``"synthetic"``, a record file path, or a :class:`Record`."""


@dataclass(frozen=True, eq=False)
class ComponentMotion:
    """The motion of one component: a single history, or one history per support position."""

    histories: tuple[MotionHistory, ...]
    positions: NDArray[np.float64] | None = None
    """Support positions (m) of the histories when there is one per support; None otherwise."""

    @property
    def end_time(self) -> float:
        """Latest end of the histories (s, simulation time, before any wave-passage delay)."""
        return max(h.end_time for h in self.histories)


@dataclass(frozen=True, eq=False)
class GroundMotion:
    """Support and approach-ground motion of a run (see the module doc)."""

    vertical: ComponentMotion | None = None
    longitudinal: ComponentMotion | None = None
    apparent_velocity: float | None = None
    """Wave-passage apparent velocity (m/s); None (or inf) is synchronous."""
    reference_position: float = 0.0
    """Where the wave passes at the arrival time (m)."""
    lateral: ComponentMotion | None = None
    """The transverse component (3D scenarios); None at rest."""

    def __post_init__(self) -> None:
        c = self.apparent_velocity
        if c is not None and (math.isnan(c) or c == 0.0):
            raise ValueError(f"earthquake.apparent_velocity must be nonzero (got {c} m/s)")
        for name in COMPONENTS_3D:
            comp = getattr(self, name)
            if comp is not None and comp.positions is not None and c is not None and math.isfinite(c):
                raise ValueError(
                    f"earthquake.{name}: one record per support and a wave-passage apparent velocity "
                    "cannot be combined; give one or the other"
                )

    def component(self, name: str) -> ComponentMotion | None:
        """The motion of a component, None when it is ``"none"``."""
        if name not in COMPONENTS_3D:
            raise ValueError(f"unknown ground-motion component {name!r} (expected one of {COMPONENTS_3D})")
        return getattr(self, name)

    def is_active(self, name: str) -> bool:
        """Whether a component moves at all."""
        return self.component(name) is not None

    @property
    def end_time(self) -> float:
        """Simulation time after which every active component is at rest at x_ref (0 if none)."""
        ends = [c.end_time for c in (self.vertical, self.longitudinal, self.lateral) if c is not None]
        return max(ends, default=0.0)

    def delay(self, x: ArrayLike) -> NDArray[np.float64]:
        """Wave-passage delay (x - x_ref)/c_app (s); zeros when synchronous."""
        xa = np.asarray(x, dtype=float)
        c = self.apparent_velocity
        if c is None:
            return np.zeros_like(xa)
        return (xa - self.reference_position) / c

    def motion(self, name: str, t: ArrayLike, x: ArrayLike = 0.0) -> Triple:
        """q, q', q'' (m, m/s, m/s²) of component ``name`` at times t and positions x (broadcast)."""
        comp = self.component(name)
        ta = np.asarray(t, dtype=float)
        xa = np.asarray(x, dtype=float)
        shape = np.broadcast_shapes(ta.shape, xa.shape)
        if comp is None:
            zero = np.zeros(shape)
            return zero, zero.copy(), zero.copy()
        if comp.positions is None:
            history = comp.histories[0]
            if self.apparent_velocity is None:
                q = history.evaluate(ta)
                return tuple(np.broadcast_to(v, shape).copy() for v in q)  # type: ignore[return-value]
            delay = self.delay(xa)
            early = history.arrival + delay < 0.0
            if np.any(early):
                bad = xa[early]
                raise ValueError(
                    f"earthquake.{name}: with apparent velocity {self.apparent_velocity} m/s the wave "
                    f"reaches x = {bad.min():.2f} m before t = 0 (arrival {history.arrival} s); "
                    "increase earthquake.arrival so that the motion starts after t = 0 everywhere"
                )
            return history.evaluate(ta - delay)
        return _per_support(name, comp, ta, xa, shape)


def _per_support(name: str, comp: ComponentMotion, t: NDArray, x: NDArray, shape: tuple) -> Triple:
    assert comp.positions is not None
    xb = np.broadcast_to(x, shape)
    tb = np.broadcast_to(t, shape)
    index = np.full(shape, -1, dtype=np.intp)
    for k, pos in enumerate(comp.positions):
        index[np.isclose(xb, pos, rtol=0.0, atol=1e-9)] = k
    if np.any(index < 0):
        bad = np.unique(xb[index < 0])
        raise ValueError(
            f"earthquake.{name}: one record per support is given at x = {list(comp.positions)} m, "
            f"but the motion was asked at x = {list(bad[:5])} m"
        )
    out = [np.zeros(shape), np.zeros(shape), np.zeros(shape)]
    for k, history in enumerate(comp.histories):
        sel = index == k
        if np.any(sel):
            q = history.evaluate(tb[sel])
            for o, v in zip(out, q, strict=True):
                o[sel] = v
    return out[0], out[1], out[2]


MAX_PEAK = 50.0 * 9.81
"""Largest ground acceleration accepted after scaling (m/s², 50 g; ``runtime.limits.MAX_PGA``)."""


def _checked(history: MotionHistory, component: str) -> MotionHistory:
    """The history, if its scaled peak acceleration is a ground motion at all: a larger one is a
    scale slip and would make the run diverge with a misleading hint about the time step."""
    peak = float(np.max(np.abs(history.accel))) if history.accel.size else 0.0
    if not peak <= MAX_PEAK:
        raise ValueError(
            f"earthquake.scale / earthquake.{component}_scale: the scaled record {history.name} peaks "
            f"at {peak:.3g} m/s², above the limit of 50 g ({MAX_PEAK:g} m/s²)"
        )
    return history


def _history(
    source: Source,
    component: str,
    *,
    scale: float,
    arrival: float,
    seed: int,
    dt: float | None,
    options: Processing | None,
    target_pga: float | None = None,
) -> MotionHistory:
    if isinstance(source, Record):
        return process_record(source, scale=scale, target_pga=target_pga, arrival=arrival, options=options)
    if str(source) == "synthetic":
        if target_pga is None:
            return synthetic_motion(component, seed, scale=scale, arrival=arrival, options=options)
        return process_record(
            synthetic_record(component, seed),
            scale=scale,
            target_pga=target_pga,
            arrival=arrival,
            options=options,
        )
    path = Path(source)
    if not path.is_file():
        raise ValueError(
            f"earthquake.{component} = {str(source)!r}: expected 'none', 'synthetic' or the path of "
            "an existing record file"
        )
    try:
        record = read_record(path, dt=dt)
    except RecordError as exc:  # the message has file and line; add the key that named the file
        raise RecordError(f"earthquake.{component}: {exc}") from None
    return process_record(record, scale=scale, target_pga=target_pga, arrival=arrival, options=options)


def _is_none(source: Source) -> bool:
    return not isinstance(source, Record) and str(source) == "none"


def _at_rest(arrival: float) -> MotionHistory:
    """The history of a support listed as ``"none"`` among per-support records: it stays at rest."""
    zero = np.zeros(2)
    return MotionHistory(
        name="none", source="none", dt=1.0, accel=zero, vel=zero.copy(), disp=zero.copy(), arrival=arrival
    )


def _source_names(spec: Source | Sequence[Source]) -> list[str]:
    specs = [spec] if isinstance(spec, str | Path | Record) else list(spec)
    out = []
    for s in specs:
        if isinstance(s, Record):
            out.append(s.name)
        elif str(s) != "none":
            out.append(str(s))
    return out


def ground_motion(
    *,
    vertical: Source | Sequence[Source] = "none",
    longitudinal: Source | Sequence[Source] = "none",
    scale: float = 1.0,
    arrival: float = 0.0,
    apparent_velocity: float | None = None,
    support_positions: Sequence[float] | None = None,
    duration: float | None = None,
    seed: int = DEFAULT_SEED,
    dt: float | None = None,
    options: Processing | None = None,
    target_pga: float | None = None,
    vertical_scale: float = 1.0,
    longitudinal_scale: float = 1.0,
    lateral: Source | Sequence[Source] = "none",
    lateral_scale: float = 1.0,
) -> GroundMotion:
    """Build the :class:`GroundMotion` of a scenario's ``[earthquake]`` table.

    Each component is ``"none"``, ``"synthetic"``, a record path (AT2 or text; ``dt`` for
    one-column files), a :class:`Record`, or a list of those, one per entry of
    ``support_positions``. Each record is first brought to ``target_pga`` (m/s², if given; the
    synthetic one otherwise to its documented PGA), then multiplied by ``scale`` and by the
    component's ``vertical_scale``, ``longitudinal_scale`` or ``lateral_scale``. ``lateral`` is the
    transverse component of 3D scenarios, built as the other two (records, per-support lists, the
    wave-passage delay). ``arrival`` (s, >= 0) is the
    simulation time of record time 0.

    ``duration`` (s), the length of the run, enables two checks: an arrival at or after the end of
    the run is an error (the earthquake would never act), and a record that ends before the run
    does gives a warning (the ground then stays at rest at its final displacement).
    """
    if not (math.isfinite(arrival) and arrival >= 0.0):
        raise ValueError(
            f"earthquake.arrival = {arrival} s must be >= 0: a negative arrival would start the run "
            "in the middle of the record, and the train starts in static equilibrium at t = 0"
        )
    if duration is not None and arrival >= duration:
        names = (
            ", ".join(_source_names(vertical) + _source_names(longitudinal) + _source_names(lateral))
            or "none"
        )
        raise ValueError(
            f"earthquake.arrival = {arrival} s: the record ({names}) would start at or after the end "
            f"of the run ({duration} s), so the earthquake would never act; lower the arrival or "
            "lengthen solver.duration"
        )
    if apparent_velocity is not None and math.isinf(apparent_velocity):
        apparent_velocity = None
    comps: dict[str, ComponentMotion | None] = {}
    factors = {"vertical": vertical_scale, "longitudinal": longitudinal_scale, "lateral": lateral_scale}
    for name, spec in (("vertical", vertical), ("longitudinal", longitudinal), ("lateral", lateral)):
        kwargs = dict(
            scale=scale * factors[name],
            arrival=arrival,
            seed=seed,
            dt=dt,
            options=options,
            target_pga=target_pga,
        )
        if isinstance(spec, (str, Path, Record)):
            if str(spec) == "none" and not isinstance(spec, Record):
                comps[name] = None
                continue
            comps[name] = ComponentMotion((_checked(_history(spec, name, **kwargs), name),))
            continue
        specs = list(spec)
        if support_positions is None or len(specs) != len(support_positions):
            n_pos = "no" if support_positions is None else len(support_positions)
            raise ValueError(
                f"earthquake.{name}: {len(specs)} records given for {n_pos} support positions; "
                "one record per support needs support_positions of the same length"
            )
        histories = tuple(
            _at_rest(arrival) if _is_none(s) else _checked(_history(s, name, **kwargs), name) for s in specs
        )
        comps[name] = ComponentMotion(histories, np.asarray(support_positions, dtype=float))
    motion = GroundMotion(
        vertical=comps["vertical"],
        longitudinal=comps["longitudinal"],
        apparent_velocity=apparent_velocity,
        lateral=comps["lateral"],
    )
    if duration is not None:
        for name in COMPONENTS_3D:
            comp = motion.component(name)
            if comp is not None and comp.end_time < duration:
                names = ", ".join(sorted({h.source if h.source else h.name for h in comp.histories}))
                warnings.warn(
                    f"earthquake.{name} ({names}) ends at t = {comp.end_time:.2f} s, before the run "
                    f"ends at {duration:.2f} s; the ground then stays at rest at its final displacement",
                    UserWarning,
                    stacklevel=2,
                )
    return motion
