"""The ground as the solver sees it: the motion of every support constraint and under the wheels on
the approach track (paper Eqs. 22-24). :class:`Ground` is the ground at rest and the interface;
:class:`RecordGround` adapts the processed records of ``svbi.runtime.excitation.ground`` (built from a
scenario's ``[earthquake]`` by :func:`ground_from_scenario`); :class:`FunctionGround` takes
analytic functions (tests, studies)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..excitation.ground import COMPONENTS_3D, ComponentMotion, GroundMotion, Source, ground_motion
from .bridge import LONGITUDINAL, VERTICAL, Bridge

Triple = tuple[np.ndarray, np.ndarray, np.ndarray]


def seen_moving(
    q: np.ndarray, q1: np.ndarray, q2: np.ndarray, c: float | None, speed: float, acceleration: float = 0.0
) -> Triple:
    """A ground motion ``q(t - x/c)`` (``c`` None: uniform) and its total time derivatives at points
    moving with ``x' = speed``, ``x'' = acceleration``: ``(1 - v/c) q'`` and
    ``(1 - v/c)^2 q'' - (a/c) q'``; ``q1``, ``q2`` are the partial time derivatives at fixed x."""
    if c:
        f = 1.0 - speed / c
        if acceleration:
            return q, f * q1, f * f * q2 - (acceleration / c) * q1
        return q, f * q1, f * f * q2
    return q, q1, q2


class Ground:
    """Ground motion as seen by the solver. The base class is the ground at rest.

    ``motion(t, x)`` returns the vertical and longitudinal ground displacement, velocity and
    acceleration at time t and positions x (partial time derivatives at fixed x), as two triples.
    ``apparent_velocity`` (m/s) is set for a travelling (asynchronous) motion ``q(t - x/c)``.
    """

    apparent_velocity: float | None = None
    uniform: bool = True

    def motion(self, t: float, x: np.ndarray) -> tuple[Triple, Triple]:
        z = np.zeros_like(np.asarray(x, dtype=float))
        return (z, z, z), (z, z, z)

    def supports(self, t: float, bridge: Bridge) -> Triple:
        """Targets ``q, q', q''`` of every support constraint, shape ``(spans, nsupport)`` (the
        paper's bridge) or ``(nsub, 3)`` (``Bridge.support_component``; a pier base does not
        rotate)."""
        if not bridge.uniform:
            x = bridge.support_x_all
            comp = bridge.support_component
            vert, lon = self.motion(t, x.reshape(-1))
            return tuple(  # type: ignore[return-value]
                np.where(
                    comp == VERTICAL,
                    v.reshape(x.shape),
                    np.where(comp == LONGITUDINAL, h.reshape(x.shape), 0.0),
                )
                for v, h in zip(vert, lon, strict=True)
            )
        x = bridge.support_x
        vert, lon = self.motion(t, x.reshape(-1))
        mask = bridge.support_vertical[None, :]
        return tuple(  # type: ignore[return-value]
            np.where(mask, v.reshape(x.shape), h.reshape(x.shape)) for v, h in zip(vert, lon, strict=True)
        )

    def under(self, t: float, x: np.ndarray, speed: float, acceleration: float = 0.0) -> Triple:
        """Vertical ground motion under points moving at ``speed`` (total time derivatives).

        For a travelling motion ``q(t - x/c)`` seen from a point with ``x' = v``, ``x'' = a``, d/dt
        carries the factor ``(1 - v/c)`` and d2/dt2 adds ``-(a/c) q'``; a uniform motion has none.
        """
        (q, q1, q2), _ = self.motion(t, x)
        return seen_moving(q, q1, q2, self.apparent_velocity, speed, acceleration)

    def under_longitudinal(self, t: float, x: np.ndarray, speed: float, acceleration: float = 0.0) -> Triple:
        """Longitudinal ground motion under points moving at ``speed`` (total time derivatives):
        the rigid approach track the off-bridge wheels creep against."""
        _, (q, q1, q2) = self.motion(t, x)
        return seen_moving(q, q1, q2, self.apparent_velocity, speed, acceleration)

    def lateral(self, t: float, x: np.ndarray) -> Triple:
        """The transverse component (3D models, positive left) at fixed points ``x``: q, q', q''
        (zero here: the ground at rest)."""
        z = np.zeros_like(np.asarray(x, dtype=float))
        return z, z, z

    def motions(self, component: str, times: np.ndarray, x: np.ndarray) -> Triple:
        """``(q, q', q'')`` of ``component`` (``vertical``, ``longitudinal`` or ``lateral``; partial
        time derivatives at fixed x), each ``(len(times), m)``: at each of ``times``, at the fixed
        points ``x`` (``(m,)``) or at points that differ from time to time (``x`` ``(len(times),
        m)``). What a run evaluates of many steps at once (the recording of a 3D run, the excitation
        of a chunk of the 3D C loop). Here :meth:`motion` or :meth:`lateral` once per time;
        :class:`RecordGround` evaluates its records at all the times at once, to the same numbers."""
        times = np.atleast_1d(np.asarray(times, dtype=float))
        x = np.broadcast_to(np.asarray(x, dtype=float), (times.size, np.shape(x)[-1]))
        out = (np.zeros(x.shape), np.zeros(x.shape), np.zeros(x.shape))
        for i, t in enumerate(times):
            if component == "lateral":
                values = self.lateral(float(t), x[i])
            else:
                vertical, longitudinal = self.motion(float(t), x[i])
                values = vertical if component == "vertical" else longitudinal
            for o, v in zip(out, values, strict=True):
                o[i] = v
        return out

    def displacements(self, component: str, times: np.ndarray, x: np.ndarray) -> np.ndarray:
        """``(len(times), m)``: the displacement ``q`` of :meth:`motions` (what a run records of
        many steps at once)."""
        return self.motions(component, times, x)[0]

    def recorded(self, t: float, bridge: Bridge) -> tuple[np.ndarray, np.ndarray]:
        """``ground_uz`` and ``ground_ux`` of the results: at x = 0 when uniform, else at every
        support constraint (``bridge.support_x``, span by span)."""
        if self.uniform:
            (qz, _, _), (qx, _, _) = self.motion(t, np.zeros(1))
            return qz[0], qx[0]
        (qz, _, _), (qx, _, _) = self.motion(t, bridge.support_table.x)
        return qz, qx


class GroundAtRest(Ground):
    """No earthquake: every target is zero (cached, the loop asks at every step)."""

    def __init__(self) -> None:
        self._zeros: dict[tuple[int, ...], Triple] = {}

    def _z(self, shape: tuple[int, ...]) -> Triple:
        if shape not in self._zeros:
            z = np.zeros(shape)
            z.flags.writeable = False
            self._zeros[shape] = (z, z, z)
        return self._zeros[shape]

    def motion(self, t: float, x: np.ndarray) -> tuple[Triple, Triple]:
        z = self._z(np.shape(x))
        return z, z

    def supports(self, t: float, bridge: Bridge) -> Triple:
        return self._z(bridge.support_x_all.shape)

    def under(self, t: float, x: np.ndarray, speed: float, acceleration: float = 0.0) -> Triple:
        return self._z(np.shape(x))

    def under_longitudinal(self, t: float, x: np.ndarray, speed: float, acceleration: float = 0.0) -> Triple:
        return self._z(np.shape(x))


class FunctionGround(Ground):
    """Ground motion from functions ``f(t, x) -> (q, q', q'')`` (vertical, longitudinal and, for
    3D models, ``lateral``)."""

    def __init__(
        self,
        vertical: Any = None,
        longitudinal: Any = None,
        apparent_velocity: float | None = None,
        *,
        lateral: Any = None,
    ) -> None:
        self._v, self._h, self._y = vertical, longitudinal, lateral
        self.apparent_velocity = apparent_velocity
        self.uniform = apparent_velocity is None

    def lateral(self, t: float, x: np.ndarray) -> Triple:
        x = np.asarray(x, dtype=float)
        if self._y is None:
            z = np.zeros_like(x)
            return z, z, z
        return tuple(np.broadcast_to(a, x.shape).astype(float) for a in self._y(t, x))  # type: ignore[return-value]

    def motion(self, t: float, x: np.ndarray) -> tuple[Triple, Triple]:
        x = np.asarray(x, dtype=float)
        zero = np.zeros_like(x)
        vert = (
            tuple(np.broadcast_to(a, x.shape).astype(float) for a in self._v(t, x))
            if self._v
            else (zero, zero, zero)
        )
        lon = (
            tuple(np.broadcast_to(a, x.shape).astype(float) for a in self._h(t, x))
            if self._h
            else (zero, zero, zero)
        )
        return vert, lon  # type: ignore[return-value]


def ground_from_scenario(scenario: Any, duration: float | None = None) -> Any:
    """The runtime's ``Ground`` (:class:`RecordGround`) for a scenario's ``[earthquake]``.

    Record paths are resolved against the scenario's folder (``scenario.resolve_path``). A component
    given as a list has one record per support line: the abutments and piers at the span ends
    (``x = j L``, ``j = 0 .. spans`` for the shorthand bridge). ``duration`` (default
    ``solver.duration``) enables the checks of :func:`ground_motion`.
    """
    eq = scenario.earthquake
    piers = np.array(scenario.bridge.line_positions())

    def source(value: str) -> Source:
        return value if value in ("none", "synthetic") else scenario.resolve_path(value)

    def spec(component: str) -> Source | list[Source]:
        value = getattr(eq, component)
        if isinstance(value, list):
            return [source(v) for v in value]
        return source(value)

    per_support = any(isinstance(getattr(eq, c), list) for c in eq.components)
    lateral = (
        {} if eq.lateral is None else {"lateral": spec("lateral"), "lateral_scale": eq.lateral_scale or 1.0}
    )
    motion = ground_motion(
        vertical=spec("vertical"),
        longitudinal=spec("longitudinal"),
        scale=eq.scale,
        vertical_scale=eq.vertical_scale,
        longitudinal_scale=eq.longitudinal_scale,
        target_pga=eq.target_pga,
        arrival=eq.arrival,
        apparent_velocity=eq.apparent_velocity,
        support_positions=list(piers) if per_support else None,
        duration=duration if duration is not None else scenario.solver.duration,
        seed=eq.seed,
        dt=eq.record_dt,
        **lateral,
    )
    return RecordGround(motion)


class RecordGround(Ground):
    """A :class:`GroundMotion` as the solver sees it (``svbi.runtime.model.system.Ground``).

    Every component is a processed record, i.e. a C2 piecewise cubic in t
    (:meth:`MotionHistory.table`), evaluated at ``t`` (synchronous), at ``t - (x - x_ref)/c``
    (wave passage), or per support line (one record per abutment or pier). With one record per
    support, a point takes the motion of the *nearest* support line: the approach track before the
    bridge follows the first abutment, the track after it the last one (on the bridge the value is
    never used for the wheels; the supports sit exactly on their lines).

    ``source`` is the :class:`GroundMotion` (the C backend reads its tables from it).
    """

    def __init__(self, motion: GroundMotion) -> None:
        self.source = motion
        self.apparent_velocity = motion.apparent_velocity
        self.reference_position = motion.reference_position
        self.components = {name: motion.component(name) for name in COMPONENTS_3D}
        self.per_support = any(c is not None and c.positions is not None for c in self.components.values())
        self.uniform = self.apparent_velocity is None and not self.per_support
        self._cache: dict[str, tuple[float, tuple[float, float, float]]] = {}
        self._supports: tuple[float, Any, Triple] | None = None

    # ----------------------------------------------------------------------------------------------
    def component(self, name: str, t: float, x: NDArray) -> Triple:
        """q, q', q'' (partial time derivatives at fixed x) of one component, shaped like x."""
        comp = self.components[name]
        x = np.asarray(x, dtype=float)
        if comp is None:
            z = np.zeros(x.shape)
            return z, z, z
        if comp.positions is None:
            history = comp.histories[0]
            if self.apparent_velocity is None:
                return tuple(np.full(x.shape, v) for v in self._uniform(name, t))  # type: ignore[return-value]
            return history.evaluate(t - (x - self.reference_position) / self.apparent_velocity)
        index = self.nearest_support(comp, x)
        out = (np.zeros(x.shape), np.zeros(x.shape), np.zeros(x.shape))
        for k in np.unique(index):
            sel = index == k
            q = comp.histories[int(k)].evaluate(np.full(int(sel.sum()), t))
            for o, v in zip(out, q, strict=True):
                o[sel] = v
        return out

    def _uniform(self, name: str, t: float) -> tuple[float, float, float]:
        """q, q', q'' of a synchronous component at t (0 when "none"); the loop asks several times
        per step, so the last time is cached."""
        hit = self._cache.get(name)
        if hit is None or hit[0] != t:
            comp = self.components[name]
            if comp is None:
                values = (0.0, 0.0, 0.0)
            else:
                q = comp.histories[0].evaluate(np.asarray(t, dtype=float))
                values = (float(q[0]), float(q[1]), float(q[2]))
            hit = (t, values)
            self._cache[name] = hit
        return hit[1]

    def supports(self, t: float, bridge: Any) -> Triple:
        if not (self.uniform and bridge.uniform):
            return super().supports(t, bridge)
        hit = self._supports
        if hit is None or hit[0] != t or hit[1] is not bridge:
            vert, lon = self._uniform("vertical", t), self._uniform("longitudinal", t)
            mask = bridge.support_vertical
            shape = bridge.support_x.shape
            values = tuple(
                np.broadcast_to(np.where(mask, v, h), shape) for v, h in zip(vert, lon, strict=True)
            )
            hit = self._supports = (t, bridge, values)
        return hit[2]  # type: ignore[return-value]

    def recorded(self, t: float, bridge: Any) -> tuple[Any, Any]:
        if self.uniform:
            return self._uniform("vertical", t)[0], self._uniform("longitudinal", t)[0]
        return super().recorded(t, bridge)

    @staticmethod
    def nearest_support(comp: ComponentMotion, x: NDArray) -> NDArray[np.intp]:
        """Index of the support line nearest to each x (ties go to the one ahead)."""
        assert comp.positions is not None
        mids = 0.5 * (comp.positions[1:] + comp.positions[:-1])
        return np.searchsorted(mids, x, side="right")

    def motion(self, t: float, x: NDArray) -> tuple[Triple, Triple]:
        return self.component("vertical", t, x), self.component("longitudinal", t, x)

    def _moving(self, name: str, t: float, x: NDArray, speed: float, acceleration: float) -> Triple:
        q, q1, q2 = self.component(name, t, x)
        return seen_moving(q, q1, q2, self.apparent_velocity, speed, acceleration)

    def under(self, t: float, x: NDArray, speed: float, acceleration: float = 0.0) -> Triple:
        """Vertical ground motion under points moving at ``speed`` (total time derivatives)."""
        return self._moving("vertical", t, x, speed, acceleration)

    def under_longitudinal(self, t: float, x: NDArray, speed: float, acceleration: float = 0.0) -> Triple:
        """Longitudinal ground motion under points moving at ``speed`` (total time derivatives)."""
        return self._moving("longitudinal", t, x, speed, acceleration)

    def lateral(self, t: float, x: NDArray) -> Triple:
        """The transverse component (3D scenarios) at fixed points ``x``: q, q', q''."""
        return self.component("lateral", t, x)

    def motions(self, component: str, times: np.ndarray, x: np.ndarray) -> Triple:
        """:meth:`Ground.motions`: each record evaluated once at all ``times``, element by element
        the operations of :meth:`component` at each time (the same numbers, bit for bit)."""
        comp = self.components[component]
        t = np.atleast_1d(np.asarray(times, dtype=float))
        x = np.broadcast_to(np.asarray(x, dtype=float), (t.size, np.shape(x)[-1]))
        if comp is None:
            return np.zeros(x.shape), np.zeros(x.shape), np.zeros(x.shape)
        if comp.positions is None:
            history = comp.histories[0]
            if self.apparent_velocity is None:  # one value a time, the same at every point
                q = history.evaluate(t)
                return tuple(np.broadcast_to(v[:, None], x.shape).copy() for v in q)  # type: ignore[return-value]
            return history.evaluate(t[:, None] - (x - self.reference_position) / self.apparent_velocity)
        index = self.nearest_support(comp, x)
        out = (np.zeros(x.shape), np.zeros(x.shape), np.zeros(x.shape))
        tt = np.broadcast_to(t[:, None], x.shape)
        for k in np.unique(index):
            sel = index == k
            for o, v in zip(out, comp.histories[int(k)].evaluate(tt[sel]), strict=True):
                o[sel] = v
        return out

    def under_lateral(self, t: float, x: NDArray, speed: float, acceleration: float = 0.0) -> Triple:
        """Transverse ground motion under points moving at ``speed`` (total time derivatives)."""
        return self._moving("lateral", t, x, speed, acceleration)

    def check_start(self, x: NDArray) -> None:
        """A travelling wave must not have reached any of the points ``x`` (m) at t = 0."""
        c = self.apparent_velocity
        if c is None:
            return
        x = np.asarray(x, dtype=float)
        for name, comp in self.components.items():
            if comp is None:
                continue
            arrival = comp.histories[0].arrival
            early = arrival + (x - self.reference_position) / c < 0.0
            if np.any(early):
                needed = -(x.min() - self.reference_position) / c
                raise ValueError(
                    f"earthquake.{name}: with apparent velocity {c} m/s the wave reaches "
                    f"x = {x[early].min():.2f} m before t = 0 (earthquake.arrival = {arrival} s), so "
                    "that point would already move when the train starts in static equilibrium; "
                    f"increase earthquake.arrival to at least {needed:.4g} s"
                )
