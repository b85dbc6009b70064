"""Unilateral wheel-rail contact: lift-off, flight and landing (docs/method.md section 12).

The paper's contact is bilateral (rigid, Section 2.3). Here the contact state of every wheel at
t_{n+1} solves one linear complementarity problem (LCP) per step, over all wheels together: a
wheel in contact carries ``P_i >= 0`` with its row satisfied; a wheel out of contact carries
``P_i = 0`` with its gap ``w_i >= 0``; never both a tensile force and a closed gap. The gap ``w_i``
of a wheel is its row's residual: for a wheel in contact at t_n, the residual of its stabilised
row (the ``g'' + 2 zeta omega g' + omega^2 g = 0`` of Eq. 22), for a wheel airborne at t_n its
predicted uplift at t_{n+1} (the position-level landing row ``g_{n+1} = 0``, :func:`landing_rows`).
Each row is fixed for the step by the wheel's state at t_n, so the problem is one LCP with a fixed
matrix, and :class:`Pivoting` (block principal pivoting, Murty's least-index rule as its fallback)
finds its solution in a few passes.

A landing wheel then goes through a perfectly plastic impact (:class:`Impact`), itself two LCPs
over the wheels in contact: impulses ``>= 0`` with post-impact relative velocities ``>= 0``, then
the force jump that makes the accelerations consistent, with forces ``>= 0``. A wheel that would
need a tensile impulse or force leaves the rail instead. The steppers of the three methods share
this module, so they take the same decisions on the same numbers; the C loop (``impact.c``,
``localized.c``) follows it pass for pass.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ...codegen.plain_types import GRAVITY
from ..model.contact_rows import ShapeKernel
from ..model.system import Contacts, Model, State
from .substructures import SubstructureCompliance

PIVOT_TRIES = 3
"""Block pivots allowed without fewer infeasible wheels before the single-wheel rule takes over
(Judice & Pires 1994: the block rule is fast but can cycle; Murty's least-index rule cannot, for the
P-matrices of a contact flexibility)."""


class ContactWarning(UserWarning):
    """A bilateral run in which the rail pulls a wheel (tensile filtered contact force)."""


class ActiveSetError(RuntimeError):
    """The contact state of a step did not settle (should not happen; the message names the wheels)."""


def is_unilateral(model: Model) -> bool:
    """True when the run's normal contact is unilateral (and there are wheels to lift)."""
    return model.settings.normal == "unilateral" and not model.train.moving_load


def pass_limit(n: int) -> int:
    """Passes allowed to one complementarity problem of ``n`` wheels before it is reported."""
    return 4 * n + 16


class Pivoting:
    """The pivoting rule of an LCP solved by complementary sets (block principal pivoting).

    Every pass flips all infeasible wheels (a basic one with a negative force, a non-basic one with a
    negative gap) while their number falls; after :data:`PIVOT_TRIES` passes without a new lowest
    count it flips only the lowest-numbered one (Murty's rule), which terminates for P-matrices.
    """

    def __init__(self, n: int) -> None:
        self.n = n
        self.best = n + 1
        self.tries = PIVOT_TRIES
        self.passes = 0

    def flips(self, bad: np.ndarray, t: float, what: str) -> np.ndarray:
        """The wheels to flip this pass (``bad`` the infeasible ones, at least one)."""
        self.passes += 1
        if self.passes > pass_limit(self.n):
            raise ActiveSetError(
                f"the {what} did not settle at t = {t:.6g} s (wheels {np.flatnonzero(bad).tolist()}, "
                f"0-based in train order); please report this run"
            )
        k = int(bad.sum())
        if k < self.best:
            self.best, self.tries = k, PIVOT_TRIES
            return bad
        if self.tries > 0:
            self.tries -= 1
            return bad
        one = np.zeros_like(bad)
        one[np.argmax(bad)] = True
        return one


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
    """The per-wheel contact state and the complementarity problem of one step (module docstring).

    Usage per step::

        act.begin()
        while True:
            ... solve with act.free (P = 0 rows), act.landing (position rows), the other active
                wheels on their stabilised rows ...
            if not act.update(P, act.gap(stabilised, uplift), t): break
        ... act.finish(dropped) after the impact
    """

    def __init__(self, n: int) -> None:
        self.n = n
        self.in_contact = np.ones(n, dtype=bool)
        """State at t_n (after :meth:`finish`: at t_{n+1})."""
        self.active = self.in_contact.copy()
        self.landing = np.zeros(n, dtype=bool)
        self._pivot = Pivoting(n)
        self.all_in = True
        """True when every wheel was in contact at t_n and none changed: the plain bilateral step."""

    def begin(self) -> None:
        self.active[:] = self.in_contact
        self.landing[:] = False
        self._pivot = Pivoting(self.n)
        self.all_in = bool(self.in_contact.all())

    @property
    def free(self) -> np.ndarray:
        return ~self.active

    def gap(self, stabilised: np.ndarray, uplift: np.ndarray) -> np.ndarray:
        """Each wheel's complementarity gap: the residual of its stabilised row (in units of length,
        positive opening) if it was in contact at t_n, its predicted uplift if it was airborne."""
        return np.where(self.in_contact, stabilised, uplift)

    def update(self, P: np.ndarray, gap: np.ndarray | None, t: float) -> bool:
        """Flip the wheels whose state contradicts the solution; True if the step must be re-solved.

        ``P`` the contact forces of the pass, ``gap`` every wheel's gap (:meth:`gap`; only read for
        the free ones, None when no wheel is free). A wheel in the set with ``P < 0`` is released,
        a free one with ``gap < 0`` joins (a wheel airborne at t_n lands: its row is the
        position-level one, :attr:`landing`).
        """
        bad = self.active & (P < 0.0)
        if gap is not None:
            bad |= ~self.active & (gap < 0.0)
        if not bad.any():
            return False
        flip = self._pivot.flips(bad, t, "contact state")
        self.active ^= flip
        np.logical_and(self.active, ~self.in_contact, out=self.landing)
        self.all_in = False
        return True

    def finish(self, dropped: np.ndarray | None = None) -> None:
        """The state at t_{n+1}: the active set, less the wheels the impact let go."""
        self.in_contact[:] = self.active
        if dropped is not None:
            self.in_contact[dropped] = False


def complementary_solve(
    G: np.ndarray, want: np.ndarray, x0: np.ndarray, candidates: np.ndarray, t: float, what: str
) -> tuple[np.ndarray, np.ndarray]:
    """``y`` with ``z = x0 + y >= 0``, ``w = G y - want >= 0``, ``z w = 0`` over the candidates;
    the others keep ``z = 0`` (``y = -x0``). ``G`` symmetric positive definite (a flexibility).

    Returns ``(y, basic)``: ``basic`` the candidates with ``w = 0`` (solved), the rest have ``z = 0``.
    With every candidate basic and feasible, ``y`` is the plain solve ``G_cc y_c = want_c``.
    """
    basic = candidates.copy()
    pivot = Pivoting(int(candidates.sum()))
    y = np.zeros_like(want)
    while True:
        y[:] = np.where(basic, 0.0, -x0)
        b = np.flatnonzero(basic)
        fixed = np.flatnonzero(~basic)
        if b.size:
            rhs = want[b] - G[np.ix_(b, fixed)] @ y[fixed]
            y[b] = np.linalg.solve(G[np.ix_(b, b)], rhs)
        bad = basic & (x0 + y < 0.0)
        out = np.flatnonzero(candidates & ~basic)
        if out.size:
            bad[out] = G[out] @ y - want[out] < 0.0
        if not bad.any():
            return y, basic
        basic ^= pivot.flips(bad, t, what)


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
        self,
        st: State,
        c: Contacts,
        active: np.ndarray,
        landing: np.ndarray,
        aux_is_wheel: bool,
        P_start: np.ndarray,
    ) -> np.ndarray:
        """Impact of the ``landing`` wheels on ``st`` at t_{n+1} (in place). Returns the wheels of
        ``active`` let go: a landing wheel whose consistent force would be tensile (it touches with
        zero relative velocity and leaves at once), or a wheel in contact that the impulses or the
        force jump would have to pull (a neighbour's landing lifts it). ``P_start`` the contact
        forces at t_n (``st.P`` holds those of t_{n+1})."""
        tr = self.model.train
        shapes = self.shapes(c.loc.xi, c.loc.span)
        N0 = shapes[0]
        idx = c.element_dofs()
        G = self._G(c, N0, idx)
        shape = (tr.cars, tr.wheels)

        # velocity jump: landing wheels lose their relative normal velocity, the others keep theirs;
        # impulses >= 0 (a wheel that would need a tensile one leaves the rail with what it has)
        rv, _ = self._rail_rates(st, c, shapes, idx)
        g1 = st.vg - rv
        target = np.where(landing, -g1, 0.0)
        # the step's own impulse (Newmark: the trapezoid of the force): the impact's impulse may
        # take back what the landing step overshot, never more (the total stays compressive)
        step_impulse = np.where(active, 0.5 * self.model.dt * (P_start + st.P), 0.0)
        impulse, on_rail = complementary_solve(G, target, step_impulse, active, st.t, "landing impulse")
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
        # the force jump J: forces P + J >= 0 on the wheels the impulses kept on the rail, the
        # others let go (J = -P); a wheel whose consistent force would be tensile leaves at once
        J, held = complementary_solve(G, want, st.P, on_rail, st.t, "force after a landing")
        dropped = active & ~held
        daV = daV0 + J.reshape(shape) @ self.MinvW.T
        daB = daB0 - self.S_M.field(self._bridge_field(c, N0, idx, J))
        st.aV = st.aV + daV
        st.ag = st.ag + (daV @ tr.W).reshape(-1)
        st.aB = st.aB + daB
        st.P = np.where(held, st.P + J, 0.0)
        if aux_is_wheel:
            st.PV = st.P
        else:
            st.PV = st.P - self.m_g * (st.ag + GRAVITY)
        st.extra["impulse"] = impulse
        return dropped


def predicted_uplift(ug: np.ndarray, c: Contacts, rail_on_bridge: np.ndarray) -> np.ndarray:
    """``u_g - rail`` at t_{n+1}: ``rail = N^T u_B + r`` on the bridge, ``q + r`` off it."""
    return ug - (np.where(c.on, rail_on_bridge, c.q) + c.r)
