"""Longitudinal creep forces in the time loop (paper Eqs. 4, 10, 15-16).

Each wheel with a spin DOF (a nonzero column of ``W_T^V``) rolls on the rail and creeps. With the
train speed ``v`` and the state at one instant, the creepage of Eq. (16) (rolling part removed,
``docs/architecture.md``) is::

    xi = (W_T^V' u_V' - rail') / v
    rail' = W_T^B' u_B' + v W_T^B'' u_B    on the bridge   (W_T^B = u - h dw/dx, h = rail height)
    rail' = (d/dt) q_x(t, x(t))             off the bridge  (the rigid ground, moving with the quake)

where ``W_T^B''`` is the x-derivative of the tangential row: ``rail'`` is the rate of the rail-head
longitudinal displacement *following the contact*, as in Eq. (16), and the longitudinal rail
irregularity ``r_T`` is zero (the German spectra describe the vertical profile and the alignment).
The creep force ``F = F_x(xi, N)`` follows Kalker with Shen-Hedrick-Elkins saturation
(:mod:`svbi.runtime.model.creep_law`) under the normal load ``N = P`` (the contact force, compression
positive); it is the force on the wheel, opposite to its slip, so ``F xi <= 0`` and creep only
dissipates. It acts on the vehicle as ``+W_T^V F`` and on the rail as ``-W_T^B F``. (The paper writes
``-W_T^V F_x`` and ``+W_T^B F_x`` with ``F_x = -eps f33 xi``; with the creepage of Eq. (16) those
signs would feed energy in, so here ``F_x`` is read as the force on the wheel.)

**Explicit in time.** The force of step n+1 is evaluated from the state at t_{n+1} (positions,
velocities, contact force) once that step is complete, and enters the *next* step as a known load
(Newmark needs the load at t_{n+2}; we use F at t_{n+1}). So the interface problem of every method is
unchanged, localized and coupled still solve the same discrete equations, and the force is the same
in both. For a wheelset spin (no stiffness) the lagged force is a damper ``k = f33 w_T / v``
(``w_T = W_T^T M^-1 W_T``, ``R^2 / J`` for a wheelset): with Newmark's average acceleration the lag is
stable for ``k dt < 2`` and free of overshoot for ``k dt < 0.34``. :meth:`CreepForces.check_stability`
refuses ``k dt > 1`` at the static wheel load.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from .contact_rows import TangentialKernel
from .creep_law import CreepLaw, CreepParameters
from .ground import GroundAtRest

if TYPE_CHECKING:  # the model builds its creep forces from this module: types only here
    from .system import Contacts, Model, State

STABILITY_LIMIT = 1.0
"""Largest ``k dt`` (creep damping rate of a wheelset spin times the time step, at the static wheel
load) accepted; the explicit force is unstable beyond 2."""


class CreepForces:
    """Creepage and creep force of every contact, and the loads they put on vehicles and bridge."""

    def __init__(self, model: Model, params: CreepParameters) -> None:
        tr, b = model.train, model.bridge
        self.model = model
        self.speed = model.speed
        v = tr.vehicle
        self.W_T = np.asarray(v.W_T, dtype=float)  # ndof x wheels
        rolling = np.abs(self.W_T).sum(axis=0) > 0.0
        self.rolling = np.tile(rolling, tr.cars)
        radii = np.asarray(v.wheel_radii, dtype=float)
        # one law per distinct wheel radius (the Hertz ellipse depends on it)
        self.laws: list[tuple[CreepLaw, np.ndarray]] = []
        for radius in np.unique(radii[rolling]):
            mask = np.tile(rolling & (radii == radius), tr.cars)
            self.laws.append((CreepLaw(replace(params, wheel_radius=float(radius))), mask))
        self.rows = TangentialKernel(b.contact_element_length, b.rail_height)
        self.longitudinal_ground = not _at_rest(model.ground, "longitudinal")
        self._rows_cache: tuple[Contacts, np.ndarray, np.ndarray] | None = None
        self.min_speed = 0.0
        """Below this speed no creep force acts (a train whose speed changes: the explicit creep
        force would be unstable there, ``docs/method.md`` section 14)."""
        if tr.acceleration == 0.0:
            self.check_stability(model.settings.time_step)
        else:
            self.min_speed = self.damping_rate(1.0) * model.settings.time_step / STABILITY_LIMIT

    @staticmethod
    def applies(model: Model) -> bool:
        """Creep needs rolling wheels: a rigid-body vehicle with a spin DOF, moving (v > 0 at some
        time of the run)."""
        tr = model.train
        if tr.moving_load or (model.speed <= 0.0 and tr.acceleration <= 0.0):
            return False
        return bool(np.abs(np.asarray(tr.vehicle.W_T, dtype=float)).sum() > 0.0)

    # ----------------------------------------------------------------------------------------------
    def tangential_rows(self, contacts: Contacts) -> tuple[np.ndarray, np.ndarray]:
        """``W_T^B`` and its x-derivative at every contact, ``(n, 6)`` each (element DOF order)."""
        hit = self._rows_cache
        if hit is None or hit[0] is not contacts:
            vals = self.rows(contacts.loc.xi, contacts.loc.span)
            hit = (contacts, vals[:, :6], vals[:, 6:])
            self._rows_cache = hit
        return hit[1], hit[2]

    def evaluate(self, state: State, contacts: Contacts) -> tuple[np.ndarray, np.ndarray]:
        """Creepage and creep force (N, on the wheel) of every contact at the state's time."""
        m, v = self.model, contacts.v
        tr = m.train
        if v < self.min_speed:  # crawling or standing: no creep force (see check_stability)
            zero = np.zeros(tr.contacts)
            return zero, zero.copy()
        wheel = (state.vV @ self.W_T).reshape(-1)
        WT, WT1 = self.tangential_rows(contacts)
        span, idx = contacts.loc.span, contacts.element_dofs()
        uB = state.uB[span[:, None], idx]
        vB = state.vB[span[:, None], idx]
        rail_on = np.einsum("ij,ij->i", WT, vB) + v * np.einsum("ij,ij->i", WT1, uB)
        if self.longitudinal_ground:
            _, ground, _ = m.ground.under_longitudinal(contacts.t, contacts.loc.x, v, contacts.a)
            rail = np.where(contacts.on, rail_on, ground)
        else:
            rail = np.where(contacts.on, rail_on, 0.0)
        xi = np.where(self.rolling, (wheel - rail) / v, 0.0)
        force = np.zeros(tr.contacts)
        for law, mask in self.laws:
            force = np.where(mask, law.force(xi, state.P), force)
        return xi, force

    def vehicle_load(self, force: np.ndarray) -> np.ndarray:
        """``+W_T^V F`` per car, shape ``(cars, ndof)``."""
        tr = self.model.train
        return force.reshape(tr.cars, tr.wheels) @ self.W_T.T

    def add_bridge_load(self, fB: np.ndarray, force: np.ndarray, contacts: Contacts) -> None:
        """Add ``-W_T^B F`` of the on-bridge contacts to the span load vectors ``fB`` (in place)."""
        sel = np.flatnonzero(contacts.on & (force != 0.0))
        if sel.size == 0:
            return
        WT, _ = self.tangential_rows(contacts)
        idx = contacts.element_dofs()
        np.add.at(fB, (contacts.loc.span[sel, None], idx[sel]), -WT[sel] * force[sel, None])

    # ----------------------------------------------------------------------------------------------
    def damping_rate(self, speed: float | None = None) -> float:
        """Largest ``k = f33(N_static) w_T / v`` (1/s) of the wheels: the lagged force's damper, at
        ``speed`` (default: the run's)."""
        tr = self.model.train
        M_inv = np.linalg.inv(tr.vehicle.M)
        w_T = np.einsum("ij,ik,kj->j", self.W_T, M_inv, self.W_T)
        static = tr.static_loads()[: tr.wheels]
        rate = 0.0
        for law, mask in self.laws:
            sel = mask[: tr.wheels]
            rate = max(rate, float(np.max(law.f33(static[sel]) * w_T[sel])) / (speed or self.speed))
        return rate

    def check_stability(self, time_step: float) -> None:
        """Refuse a time step too large for the explicit creep force (see the module doc)."""
        k = self.damping_rate()
        if k * time_step > STABILITY_LIMIT:
            raise ValueError(
                f"contact.creep: the explicit creep force is unstable with solver.time_step = "
                f"{time_step:g} s at {self.speed:.4g} m/s (creep damping rate {k:.4g} 1/s x time step "
                f"= {k * time_step:.3g} > {STABILITY_LIMIT:g}); use solver.time_step <= "
                f"{STABILITY_LIMIT / k:.3g} s or contact.creep = false"
            )


def _at_rest(ground: object, component: str) -> bool:
    if isinstance(ground, GroundAtRest):
        return True
    comps = getattr(ground, "components", None)
    if isinstance(comps, dict):
        return comps.get(component) is None
    return False
