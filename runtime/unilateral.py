"""Unilateral wheel-rail contact: lift-off, flight and landing (docs/method.md section 12).

The paper's contact is bilateral (rigid, Section 2.3). Here a wheel whose contact force would become
tensile at t_{n+1} is released: its aux-bridge (wheel-rail) row is replaced by ``P_i = 0`` and the
wheel, with its auxiliary point rigidly on it, flies under its own dynamics. A free wheel whose
predicted uplift at t_{n+1} is ``<= 0`` lands: for that step its row is the position-level
``g_{n+1} = 0`` (:func:`landing_rows`), and after the Newmark update a perfectly plastic impact
(:class:`Impact`) removes its relative normal velocity and makes the accelerations at t_{n+1}
consistent with the wheel staying on the rail. The steppers of the three methods share this module,
so they take the same decisions on the same numbers.

The active set is per wheel: each step starts from the wheels in contact at t_n; a pass that flips a
wheel (a release or a landing) re-solves the step. When nothing separates, the only work is the
sign test of ``P``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from svbi.codegen.plain_types import GRAVITY
from svbi.runtime.assembly import Contacts, Model, State
from svbi.runtime.contact_rows import ShapeKernel
from svbi.runtime.substructures import SubstructureCompliance


class ContactWarning(UserWarning):
    """A bilateral run in which the rail pulls a wheel (tensile filtered contact force)."""


class ActiveSetError(RuntimeError):
    """The active set of a step did not settle (should not happen; the message names the wheels)."""


def is_unilateral(model: Model) -> bool:
    """True when the run's normal contact is unilateral (and there are wheels to lift)."""
    return model.settings.normal == "unilateral" and not model.train.moving_load


@dataclass
class Landing:
    """Rows of the position-level constraint ``g_{n+1} = 0`` of the landing wheels.

    ``N0`` replaces ``W_hat`` (on the bridge), ``target`` replaces ``h_B``: the rail height at
    t_{n+1}, ``r`` on the bridge (the deck enters through ``N0^T u_B``) and ``q + r`` off it.
    """

    N0: np.ndarray
    target: np.ndarray


def landing_rows(model: Model, contacts: Contacts, shape: ShapeKernel) -> Landing:
    """The landing rows of every contact at the step's locations (used for the landing ones)."""
    (N0,) = shape(contacts.loc.xi, contacts.loc.span)
    c = contacts
    return Landing(N0, np.where(c.on, c.r, c.q + c.r))


class ActiveSet:
    """The per-wheel contact state and the iteration of one step's active set.

    Usage per step::

        act.begin()
        while True:
            ... solve with act.free (P = 0 rows) and act.landing (position rows) ...
            if not act.update(P, uplift): break
        ... act.finish() after the impact
    """

    def __init__(self, n: int) -> None:
        self.n = n
        self.in_contact = np.ones(n, dtype=bool)
        """State at t_n (after :meth:`finish`: at t_{n+1})."""
        self.active = self.in_contact.copy()
        self.landing = np.zeros(n, dtype=bool)
        self._released = np.zeros(n, dtype=bool)
        self._twice = np.zeros(n, dtype=bool)
        self._passes = 0
        self.all_in = True
        """True when every wheel was in contact at t_n and none changed: the plain bilateral step."""

    def begin(self) -> None:
        self.active[:] = self.in_contact
        self.landing[:] = False
        self._released[:] = False
        self._twice[:] = False
        self._passes = 0
        self.all_in = bool(self.in_contact.all())

    @property
    def free(self) -> np.ndarray:
        return ~self.active

    def update(self, P: np.ndarray, uplift: np.ndarray | None, t: float) -> bool:
        """Flip the wheels whose state contradicts the solution; True if the step must be re-solved.

        ``P`` the contact forces of the pass, ``uplift`` the predicted uplift at t_{n+1} of every
        wheel (only read for the free ones; None when no wheel is free).
        """
        release = self.active & (P < 0.0)
        land = np.zeros(self.n, dtype=bool)
        if uplift is not None:
            # a wheel released in this pass whose gap is still closed (the stabilised row's residual
            # at a slope kink) gets one landing try with the position-level row; released twice,
            # it stays free for the step (the iteration ends)
            land = ~self.active & ~self._twice & (uplift <= 0.0)
        if not (release.any() or land.any()):
            return False
        self._passes += 1
        if self._passes > 2 * self.n + 2:
            raise ActiveSetError(
                f"the contact active set did not settle at t = {t:.6g} s (wheels "
                f"{np.flatnonzero(release | land).tolist()})"
            )
        self.active[release] = False
        self.landing[release] = False
        self._twice |= release & self._released
        self._released |= release
        self.active[land] = True
        self.landing[land] = True
        self.all_in = False
        return True

    def finish(self, dropped: np.ndarray | None = None) -> None:
        """The state at t_{n+1}: the active set, less landing wheels the impact let go."""
        self.in_contact[:] = self.active
        if dropped is not None:
            self.in_contact[dropped] = False


class Impact:
    """Perfectly plastic impact of landing wheels at t_{n+1} (docs/method.md section 12, step 4).

    Mass (impact) flexibility at the contacts: ``G = W^T M_V^-1 W`` per car (full vehicle mass: the
    aux point is rigidly on its wheel during the impact) plus ``N^T S_M N`` for contacts on the same
    span, ``S_M`` the bridge mass compliance with the supports held (the bearings follow the
    ground through the impact).
    """

    def __init__(self, model: Model) -> None:
        tr, b = model.train, model.bridge
        v = tr.vehicle
        self.model = model
        self.MinvW = np.linalg.solve(v.M, tr.W)  # ndof x nw
        self.MinvC = np.linalg.solve(v.M, v.C)
        self.GV = tr.W.T @ self.MinvW
        kinds = [b] if b.uniform else b.kinds
        self.S_M = SubstructureCompliance(b, [k.M for k in kinds], cholesky=False, springs=False)
        """Mass compliance of the substructures, supports held, links imposed."""
        self.shapes = ShapeKernel(b.contact_element_length, (0, 1, 2))
        self.m_g = np.tile(tr.aux_masses, tr.cars)

    # ----------------------------------------------------------------------------------------------
    def _G(self, c: Contacts, N0: np.ndarray, idx: np.ndarray) -> np.ndarray:
        tr, b = self.model.train, self.model.bridge
        G = sla.block_diag(*([self.GV] * tr.cars))
        on, span = c.on, c.loc.span
        sel = np.flatnonzero(on)
        if sel.size:  # N_j^T S_M N_k for contacts on the same span
            Nf = np.zeros((tr.contacts, b.ndof))
            Nf[sel[:, None], idx[sel]] = N0[sel]
            G += self.S_M.pair(Nf, Nf, span, on)
        return G

    def _bridge_field(self, c: Contacts, N0: np.ndarray, idx: np.ndarray, f: np.ndarray) -> np.ndarray:
        """``sum_i N_i f_i`` per span, ``(spans, ndof)``."""
        b = self.model.bridge
        load = np.zeros((b.nsub, b.ndof))
        sel = np.flatnonzero(c.on)
        np.add.at(load, (c.loc.span[sel, None], idx[sel]), N0[sel] * f[sel, None])
        return load

    def _rail_rates(
        self, st: State, c: Contacts, shapes: tuple[np.ndarray, ...], idx: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Velocity and acceleration of the rail point under each wheel (total time derivatives)."""
        v, a = c.v, c.a
        N0, N1, N2 = shapes
        span = c.loc.span
        ue, ve, ae = (x[span[:, None], idx] for x in (st.uB, st.vB, st.aB))
        dot = lambda A, B: np.einsum("ij,ij->i", A, B)  # noqa: E731
        on_v = dot(N0, ve) + v * dot(N1, ue)
        on_a = dot(N0, ae) + 2 * v * dot(N1, ve) + v * v * dot(N2, ue)
        rv = np.where(c.on, on_v, c.q1) + v * c.r1
        ra = np.where(c.on, on_a, c.q2) + v * v * c.r2
        if a != 0.0:  # x'' = a: the convective term of the train's acceleration
            ra = ra + a * (np.where(c.on, dot(N1, ue), 0.0) + c.r1)
        return rv, ra

    def apply(
        self, st: State, c: Contacts, active: np.ndarray, landing: np.ndarray, aux_is_wheel: bool
    ) -> np.ndarray:
        """Impact of the ``landing`` wheels on ``st`` at t_{n+1} (in place). Returns the landing
        wheels let go again (consistent force tensile: they touch with zero relative velocity and
        leave at once)."""
        tr = self.model.train
        shapes = self.shapes(c.loc.xi, c.loc.span)
        N0 = shapes[0]
        idx = c.element_dofs()
        G = self._G(c, N0, idx)
        act = np.flatnonzero(active)
        shape = (tr.cars, tr.wheels)

        # velocity jump: landing wheels lose their relative normal velocity, the others keep theirs
        rv, _ = self._rail_rates(st, c, shapes, idx)
        g1 = st.vg - rv
        target = np.where(landing, -g1, 0.0)
        impulse = np.zeros(tr.contacts)
        impulse[act] = np.linalg.solve(G[np.ix_(act, act)], target[act])
        dvV = impulse.reshape(shape) @ self.MinvW.T
        dvB = -self.S_M.field(self._bridge_field(c, N0, idx, impulse))
        st.vV = st.vV + dvV
        st.vg = st.vg + (dvV @ tr.W).reshape(-1)
        st.vB = st.vB + dvB

        # accelerations consistent with the post-impact state (landing wheels: g'' = 0)
        _, ra = self._rail_rates(st, c, shapes, idx)
        g2 = st.ag - ra
        daV0 = -(dvV @ self.MinvC.T)  # the damping force follows the velocity jump
        daB0 = -self.S_M.field(self.model.bridge.per_kind(dvB, "C"))
        N0ue = lambda X: np.einsum("ij,ij->i", N0, X[c.loc.span[:, None], idx])  # noqa: E731
        dg0 = (daV0 @ tr.W).reshape(-1) - np.where(c.on, N0ue(daB0), 0.0)
        want = np.where(landing, -g2, 0.0) - dg0
        dropped = np.zeros(tr.contacts, dtype=bool)
        J = np.zeros(tr.contacts)
        for _ in range(tr.contacts + 1):
            unknown = active & ~dropped
            fixed = dropped  # let go: the force at t_{n+1} returns to 0
            J[:] = 0.0
            J[fixed] = -st.P[fixed]
            u = np.flatnonzero(unknown)
            rhs = want[u] - G[np.ix_(u, np.flatnonzero(fixed))] @ J[fixed]
            if u.size:
                J[u] = np.linalg.solve(G[np.ix_(u, u)], rhs)
            bad = landing & ~dropped & (st.P + J < 0.0)
            if not bad.any():
                break
            dropped |= bad
        daV = daV0 + J.reshape(shape) @ self.MinvW.T
        daB = daB0 - self.S_M.field(self._bridge_field(c, N0, idx, J))
        st.aV = st.aV + daV
        st.ag = st.ag + (daV @ tr.W).reshape(-1)
        st.aB = st.aB + daB
        st.P = st.P + J
        st.P[dropped] = 0.0
        if aux_is_wheel:
            st.PV = st.P
        else:
            st.PV = st.P - self.m_g * (st.ag + GRAVITY)
        st.extra["impulse"] = impulse
        return dropped


def predicted_uplift(ug: np.ndarray, c: Contacts, rail_on_bridge: np.ndarray) -> np.ndarray:
    """``u_g - rail`` at t_{n+1}: ``rail = N^T u_B + r`` on the bridge, ``q + r`` off it."""
    return ug - (np.where(c.on, rail_on_bridge, c.q) + c.r)
