"""Numeric model assembly: bridge + train + excitations + solver settings, and the state they share.

The methods (``localized``, ``coupled``, ``classic``) step a :class:`State`; everything they need
about the world at a time ``t`` comes from :meth:`Model.contacts` (where each wheel is, the rail
irregularity under it, the ground under off-bridge wheels) and :meth:`Model.supports` (the ground
motion the bearings follow). Excitations plug in through two tiny interfaces, so the loop does not
change when new ones arrive:

* irregularity: ``evaluate(x) -> (r, dr/dx, d2r/dx2)`` (``svbi.runtime.excitation.irregularity``);
* ground: :class:`Ground` (``supports``, ``under``, ``under_longitudinal`` for creep off the bridge,
  ``recorded`` for the output), adapting a ground-motion object
  (``svbi.runtime.excitation.ground.RecordGround``).

Creep forces (``[contact]``) are the :class:`~svbi.runtime.model.wheel_creep.CreepForces` of
:attr:`Model.creep`, explicit loads of the next step (``docs/method.md`` section 3b).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from .bridge import Bridge, Location
from .creep_law import CreepParameters
from .ground import FunctionGround, Ground, GroundAtRest, Triple
from .train import Train
from .wheel_creep import CreepForces

__all__ = ["Contacts", "FunctionGround", "Ground", "GroundAtRest", "Model", "Settings", "State"]
"""The ground classes are re-exported: :class:`Model` holds a :class:`Ground`."""


class IrregularityLike(Protocol):
    def evaluate(self, x: np.ndarray) -> Triple: ...


class FlatTrack:
    """Perfect track: r = 0."""

    def __init__(self) -> None:
        self._zeros: dict[tuple[int, ...], np.ndarray] = {}

    def evaluate(self, x: np.ndarray) -> Triple:
        shape = np.shape(x)
        z = self._zeros.get(shape)
        if z is None:
            z = self._zeros[shape] = np.zeros(shape)
            z.flags.writeable = False
        return z, z, z


@dataclass
class Contacts:
    """The contact points at one instant: location, irregularity and ground under each."""

    t: float
    loc: Location
    r: np.ndarray
    r1: np.ndarray
    r2: np.ndarray
    q: np.ndarray
    q1: np.ndarray
    q2: np.ndarray
    v: float = 0.0
    """The train's speed at ``t``."""
    a: float = 0.0
    """The train's acceleration at ``t``."""

    @property
    def on(self) -> np.ndarray:
        return self.loc.on

    def element_dofs(self) -> np.ndarray:
        """Span-local DOF indices of the element of each contact, ``(n, 6)``."""
        return self.loc.first_dof[:, None] + np.arange(6)[None, :]


@dataclass
class State:
    """Positions, velocities, accelerations and forces at one time (see docs/method.md)."""

    t: float
    uV: np.ndarray
    vV: np.ndarray
    aV: np.ndarray
    uB: np.ndarray
    vB: np.ndarray
    aB: np.ndarray
    ug: np.ndarray
    vg: np.ndarray
    ag: np.ndarray
    P: np.ndarray
    """Wheel-rail (aux-bridge) contact force, N, compression positive."""
    PV: np.ndarray
    """Wheel-aux force, N, compression positive (equals ``P`` less the aux point's inertia)."""
    extra: dict[str, Any] = field(default_factory=dict)
    creepage: np.ndarray | None = None
    """Longitudinal creepage of every contact at ``t`` (None: no creep in this run)."""
    creep_force: np.ndarray | None = None
    """Creep force on every wheel at ``t``, N (explicit: it loads the *next* step)."""
    contact_state: np.ndarray | None = None
    """Unilateral contact: True for every wheel on its rail at ``t`` (None: bilateral run)."""

    def copy(self) -> State:
        return State(
            self.t,
            *(
                np.array(getattr(self, k))
                for k in ("uV", "vV", "aV", "uB", "vB", "aB", "ug", "vg", "ag", "P", "PV")
            ),
            extra=dict(self.extra),
            creepage=None if self.creepage is None else np.array(self.creepage),
            creep_force=None if self.creep_force is None else np.array(self.creep_force),
            contact_state=None if self.contact_state is None else np.array(self.contact_state),
        )


@dataclass
class Settings:
    """Solver settings of one run."""

    method: str = "localized-dynamic"
    backend: str = "numpy"
    time_step: float = 1.0e-4
    steps: int = 1
    output_every: int = 1
    kappa: float = 1.0
    zeta: float = 1.0
    split: float = 0.5
    force_filter_hz: float = 20.0
    max_gap: float = 1.0
    normal: str = "unilateral"
    """``"unilateral"`` (wheels may lift off, docs/method.md section 12) or ``"bilateral"``."""


class Model:
    """Everything one run needs, in numbers."""

    def __init__(
        self,
        bridge: Bridge,
        train: Train,
        settings: Settings,
        irregularity: IrregularityLike | None = None,
        ground: Ground | None = None,
        creep: CreepParameters | None = None,
    ) -> None:
        self.bridge = bridge
        self.train = train
        self.settings = settings
        self.irregularity = irregularity or FlatTrack()
        self.ground = ground or GroundAtRest()
        self.creep_parameters = creep
        """Wheel-rail creep (``[contact]``); None: no creep forces."""
        self._creep: Any = None
        self._targets: dict[str, Any] = {}

    @property
    def creep(self) -> Any:
        """The :class:`~svbi.runtime.model.wheel_creep.CreepForces` of this run, or None (no creep: not
        asked for, a moving load, a held train, or no wheel spin DOF in the vehicle)."""
        if self._creep is None and self.creep_parameters is not None:
            self._creep = CreepForces(self, self.creep_parameters) if CreepForces.applies(self) else False
        return self._creep or None

    @property
    def dt(self) -> float:
        return self.settings.time_step

    @property
    def speed(self) -> float:
        return self.train.speed

    @property
    def accelerating(self) -> bool:
        """The train's speed changes during the run (``[train] acceleration``)."""
        return self.train.acceleration != 0.0

    def contacts(self, t: float) -> Contacts:
        tr = self.train
        x = tr.positions(t)
        loc = self.bridge.locate(x)
        r, r1, r2 = self.irregularity.evaluate(x)
        if tr.acceleration == 0.0:
            q, q1, q2 = self.ground.under(t, x, tr.speed)
            return Contacts(t, loc, r, r1, r2, q, q1, q2, tr.speed, 0.0)
        v, a = tr.speed_at(t), tr.acceleration_at(t)
        q, q1, q2 = self.ground.under(t, x, v, a)
        return Contacts(t, loc, r, r1, r2, q, q1, q2, v, a)

    def supports(self, t: float) -> Triple:
        """Newmark-consistent targets ``Q, Q', Q''`` of every support constraint at ``t``, shape
        ``(spans, nsupport)``: :func:`newmark_targets` of the ground motion (see its doc)."""
        ground = self.ground
        if isinstance(ground, GroundAtRest):
            return ground.supports(t, self.bridge)
        dt = self.dt
        cache = self._targets
        if cache.get("ground") is not ground or cache.get("dt") != dt:
            cache.clear()
            cache.update(ground=ground, dt=dt, hat={})
        n = round(t / dt)
        if abs(t - n * dt) > 1e-9 * dt:  # off the step grid: nothing to share with other calls
            return newmark_targets(*(self._support_hat(t + k * dt) for k in (-1, 0, 1)), dt)
        hat: dict[int, np.ndarray] = cache["hat"]
        for k in (n - 1, n, n + 1):
            if k not in hat:
                hat[k] = self._support_hat(k * dt)
        for k in [k for k in hat if abs(k - n) > 1]:  # the loop asks at t_1, t_2, ... in order
            del hat[k]
        return newmark_targets(hat[n - 1], hat[n], hat[n + 1], dt)

    def _support_hat(self, t: float) -> np.ndarray:
        """``q - dt^2/4 q''`` of the ground at every support constraint at ``t``."""
        q, _, q2 = self.ground.supports(t, self.bridge)
        return support_hat(q, q2, self.dt)


def support_hat(q: np.ndarray, q2: np.ndarray, dt: float) -> np.ndarray:
    """``h = q - dt^2/4 q''``: the sequence whose three-point combination is the support target
    (:func:`newmark_targets`). The C loop evaluates the same expression (``support_target``)."""
    return q - (0.25 * dt * dt) * q2


def newmark_targets(h0: np.ndarray, h1: np.ndarray, h2: np.ndarray, dt: float) -> Triple:
    """Newmark-consistent support targets at t_n from ``h = q - dt^2/4 q''`` at t_{n-1}, t_n, t_{n+1}.

    ``Q = (h0 + 2 h1 + h2) / 4``, ``Q' = (h2 - h0) / (2 dt)``, ``Q'' = (h2 - 2 h1 + h0) / dt^2``.
    Whatever the sequence h, these satisfy Newmark's two relations (gamma = 1/2, beta = 1/4) between
    consecutive steps exactly, so the stabilised gap equation of the supports (Eq. 22) has no
    forcing left and a support that starts on its target follows it to round-off. With
    ``h = q - dt^2/4 q''`` the targets differ from the ground's q, q', q'' only by Newmark's own
    truncation: O(dt^4 q'''') where q is smooth, O(dt^3) times the jump of q''' next to a record
    sample (docs/method.md, "Support targets").
    """
    return 0.25 * (h0 + 2.0 * h1 + h2), (h2 - h0) / (2.0 * dt), (h2 - 2.0 * h1 + h0) / (dt * dt)


def crossing_duration(bridge: Bridge, train: Train) -> float:
    """Time until the last axle leaves the last span (docs/scenario.md, solver.duration)."""
    if train.speed <= 0 and train.acceleration <= 0:
        return math.inf
    return train.time_to_travel(max(bridge.length + train.length - train.start_position, 0.0))
