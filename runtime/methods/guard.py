"""The divergence guard: a run that goes unstable (NaN or Inf, a runaway gap, an absurd contact
force) stops with a message naming the time, the quantity and the likely cause (docs/method.md
section 12 for how flights are read)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..model.system import Model


class Diverged(RuntimeError):
    """Raised inside the loop; caught by :func:`svbi.runtime.run.simulate.simulate`."""


FORCE_LIMIT_FACTOR = 1.0e3
"""A contact force beyond this multiple of the largest static wheel load stops the run. Joint
impulses give peaks of tens of static loads at dt = 1e-4 s (docs/method.md section 3c)."""


MECHANISM_HZ = 0.05
"""A bridge whose lowest natural frequency is below this (Hz) is reported as nearly a mechanism
when a run diverges (no railway bridge is that soft: the lowest are about 1 Hz)."""


class DivergenceGuard:
    """Stops a run that has gone unstable, with the time, the quantity and the likely cause."""

    def __init__(self, model: Model) -> None:
        self.model = model
        tr = model.train
        static = tr.axle_loads if tr.moving_load else tr.static_loads()
        self.force_limit = FORCE_LIMIT_FACTOR * max(float(np.abs(static).max(initial=0.0)), 1.0)
        self.classic = model.settings.method == "coupled-classic"

    def _cause(self) -> str:
        s = self.model.settings
        if self.classic:
            return (
                "coupled-classic imposes the constraints at acceleration level only, so the gaps drift "
                "(use localized-dynamic or coupled-dynamic)"
            )
        if s.kappa > 2:
            return (
                f"constraint_kappa = {s.kappa:g} > 2 makes the gap correction overshoot and oscillate; "
                "use 0.5 <= kappa <= 2"
            )
        # a bridge that is nearly a mechanism (a bearing or pier of almost no stiffness) drifts
        # away at any time step: look before blaming the step
        try:
            f1 = float(self.model.bridge.natural_frequencies(1)[0])
        except Exception:  # noqa: BLE001 - a diagnosis must not hide the divergence it explains
            f1 = float("nan")
        if f1 < MECHANISM_HZ:
            return (
                f"the bridge is nearly a mechanism: its lowest natural frequency is {f1:.3g} Hz "
                "(supports held); check the stiffness of its bearings and piers"
            )
        return f"the time step ({s.time_step:g} s) may be too large for this model; try a smaller one"

    def check_finite(self, st: Any) -> None:
        total = st.P.sum() + st.uB.sum() + st.uV.sum()
        if not math.isfinite(total):
            which = (
                "contact_force"
                if not np.isfinite(st.P).all()
                else ("bridge displacement" if not np.isfinite(st.uB).all() else "vehicle displacement")
            )
            raise Diverged(
                f"run diverged at t = {st.t:.6g} s: {which} is not finite (NaN or Inf); "
                f"likely cause: {self._cause()}"
            )
        P = max(st.P.max(initial=0.0), -st.P.min(initial=0.0))
        if P > self.force_limit:
            raise Diverged(
                f"run diverged at t = {st.t:.6g} s: contact_force = {P:.4g} N exceeds "
                f"{self.force_limit:.3g} N ({FORCE_LIMIT_FACTOR:g} x the static wheel load); "
                f"likely cause: {self._cause()}"
            )

    def check_gaps(self, st: Any, gaps: Mapping[str, np.ndarray]) -> None:
        """Constraint violations beyond ``solver.max_gap`` stop the run. The bridge gap counts the
        wheels in contact only: an airborne wheel's gap is its uplift, not a violation, and it
        stops the run only when the wheel flies higher than the limit (derailment, reported so)."""
        limit = self.model.settings.max_gap
        state = getattr(st, "contact_state", None)
        for name, g in gaps.items():
            g = np.asarray(g, dtype=float)
            if name == "bridge" and state is not None:
                flying = ~np.asarray(state, dtype=bool).reshape(g.shape)
                uplift = np.where(flying, g, 0.0)
                if not float(uplift.max(initial=0.0)) <= limit:
                    j = int(np.argmax(uplift))
                    car, wheel = divmod(j, self.model.train.wheels)
                    raise Diverged(
                        f"run stopped at t = {st.t:.6g} s: wheel {wheel + 1} of car {car + 1} flies "
                        f"{uplift[j]:.4g} m above its rail (more than solver.max_gap = {limit:g} m): "
                        "derailment is likely; a vertical model cannot follow the wheel off the rail"
                    )
                g = np.where(flying, 0.0, g)
            worst = float(np.abs(g).max(initial=0.0))
            if not worst <= limit:
                raise Diverged(
                    f"run diverged at t = {st.t:.6g} s: |gap_{name}| = {worst:.4g} m exceeds "
                    f"{limit:g} m (solver.max_gap); likely cause: {self._cause()}"
                )
