"""localized-dynamic: the paper's partitioned method (Sections 2-4, Eq. 36 solved by condensation).

Three subsystems: the vehicles (active mass, Eq. 4), the auxiliary contact points (mass ``a m_w``,
Eq. 14) and the bridge with its support constraints (Eqs. 10, 22-24). Every constraint is imposed at
t_{n+1} as ``g'' + 2 zeta omega g' + omega^2 g = 0`` (Eqs. 17, 20, 22 divided by the constraint mass),
which with Newmark becomes one linear row per constraint (``svbi.codegen.constraints``).

Everything constant is factored once: each car's effective matrix and its wheel flexibility, the aux
compliance, and the bridge compliance with the supports held (``S``) together with the effect of
the support targets (``R``). Each step then solves one small interface system for the contact forces
``P`` (docs/design.md section 4, step 3)::

    (F_B + F*) P = h_B - p~ + W_hat^T u~_B - c_g B d_V

with ``F* = c_g - c_g B c_g`` (the full-vehicle wheel flexibility) and ``F_B = W_hat^T S N`` (the bridge
flexibility between contacts on the same span). It is non-symmetric: the force acts along ``N`` but
the constraint row is ``W_hat``, which carries the convective terms. We solve for forces, not for the
dynamic multipliers, which lose digits (docs/design.md pitfall 7). Sign convention: ``P`` is the
compression in the contact; it pushes the wheel (or aux point) up and the bridge down.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from ...codegen.plain_types import GRAVITY
from ..model.contact_rows import ContactRowKernel, ContactRows, ShapeKernel, point_row
from ..model.system import Contacts, Model, State
from .newmark import Newmark
from .substructures import SubstructureCompliance
from .unilateral import ActiveSet, Impact, is_unilateral, landing_rows, predicted_uplift


def _solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dense LU solve (LAPACK gesv) without NumPy's per-call checks: the interface is tiny."""
    _, _, x, info = _gesv(A, b, overwrite_a=True, overwrite_b=False)
    if info != 0:
        raise np.linalg.LinAlgError(f"singular interface matrix (gesv info {info})")
    return x


_gesv = sla.get_lapack_funcs("gesv", dtype=np.float64)


def bridge_compliance(model: Model, nm: Newmark) -> SubstructureCompliance:
    """``S`` and ``R`` of every substructure: ``u = S f + R q_hat`` solves ``K^ u = f + E R_G``,
    ``E^T u = q_hat`` (``svbi.runtime.methods.substructures``), with the bridge's links."""
    b = model.bridge
    kinds = [b] if b.uniform else b.kinds
    return SubstructureCompliance(b, [nm.effective(k.K, k.C, k.M) for k in kinds])


class LocalizedDynamic:
    """Partitioned stepper; see the module docstring."""

    name = "localized-dynamic"

    def __init__(self, model: Model, state: State) -> None:
        self.model = model
        self.state = state
        s = model.settings
        self.nm = nm = Newmark(s.time_step)
        self.point = point_row(s.time_step, s.kappa, s.zeta)
        b = model.bridge
        self.rows = ContactRowKernel(
            b.contact_element_length, model.speed, s.time_step, s.kappa, s.zeta, model.accelerating
        )
        self.bridge = bridge_compliance(model, nm)
        tr = model.train
        self.moving_load = tr.moving_load
        if not self.moving_load:
            self._vehicle_setup()
        self.contacts: Contacts | None = None
        self.act: ActiveSet | None = None
        if is_unilateral(model):  # docs/method.md section 12
            self.act = ActiveSet(tr.contacts)
            self.impact = Impact(model)
            self.shape = ShapeKernel(b.contact_element_length)
            state.contact_state = self.act.in_contact

    def _vehicle_setup(self) -> None:
        tr, nm = self.model.train, self.nm
        v = tr.vehicle
        k_hat = nm.effective(v.K, v.C, tr.M_active)
        self.k_inv = np.linalg.inv(k_hat)
        self.A = self.k_inv @ tr.W  # ndof x nw
        F_V = tr.W.T @ self.A
        self.m_g = np.tile(tr.aux_masses, tr.cars)
        c_g = 1.0 / (nm.a0 * tr.aux_masses)
        self.c_g = np.tile(c_g, tr.cars)
        self.B = np.linalg.inv(F_V + np.diag(c_g))
        f_star = np.diag(c_g) - c_g[:, None] * self.B * c_g[None, :]
        self.F_star = sla.block_diag(*([f_star] * tr.cars))

    # ----------------------------------------------------------------------------------------------
    def step(self, n: int) -> State:
        """Advance from t_n to t_{n+1} = (n + 1) dt."""
        m, nm, st = self.model, self.nm, self.state
        b, tr = m.bridge, m.train
        t = (n + 1) * m.dt
        c = m.contacts(t)
        rows = self.rows(c.loc.xi, c.loc.span, c.v, c.a)
        self.contacts = c

        # bridge predictor (all contact forces zero), supports at their targets, links closed
        PB, QB = nm.history(st.uB, st.vB, st.aB)
        q, q1, q2 = m.supports(t)
        PS, QS = b.at_supports(PB), b.at_supports(QB)
        q_hat = self.point.target(PS, QS, q, q1, q2)
        fB = b.history_load(PB, QB, q1)
        creep = m.creep
        if creep is not None:  # explicit: the creep force of t_n loads this step (docs/method.md)
            creep.add_bridge_load(fB, st.creep_force, c)
        uB_t = self.bridge.held(fB, q_hat)
        bc = self.bridge
        if bc.nlinks:  # the link gaps follow their own stabilised rows (no ground: target 0)
            uB_t, _ = bc.linked(uB_t, b.links.targets(self.point, PB, QB))

        on = c.on
        span = c.loc.span
        idx = c.element_dofs()
        if self.moving_load:
            P = np.where(on, tr.axle_loads, 0.0)
            uB = uB_t - self.bridge.field(self._bridge_load(c, rows, idx, P))
            self._finish_bridge(uB, PB, QB)
            st.P = tr.axle_loads.copy()
            st.PV = st.P
            st.t = t
            return st

        # vehicle and aux predictors, wheel-aux target h_V
        # The vehicles solve for the increment over the step (Newmark.update_increment): the
        # car-body acceleration is a plotted result and the total form rounds it to a0 eps |u|.
        PtV, QtV = nm.increment_history(st.vV, st.aV)
        PV_, QV_ = nm.total_history(st.uV, PtV, QtV)
        Pg, Qg = nm.history(st.ug, st.vg, st.ag)
        fV = tr.increment_load(st.uV, PtV, QtV)
        if creep is not None:
            fV = fV + creep.vehicle_load(st.creep_force)
        duV_t = fV @ self.k_inv
        uV_t = st.uV + duV_t
        wheel_t = (uV_t @ tr.W).reshape(-1)
        p_t = (Pg - GRAVITY) / nm.a0
        h_V = self.point.wheel_target((PV_ @ tr.W).reshape(-1), (QV_ @ tr.W).reshape(-1), Pg, Qg)
        d_V = wheel_t - p_t - h_V

        # aux-bridge rows: W_hat, h_B (on the bridge), or the ground target (off)
        Pe = PB[span[:, None], idx]
        Qe = QB[span[:, None], idx]
        h_on = rows.h_bridge(Pg, Qg, Pe, Qe, c)
        if on.all():
            h_B = h_on
        else:
            h_off = self.point.off_bridge_target(Pg, Qg, c)
            h_B = np.where(on, h_on, h_off)

        # interface: (F_B + F*) P = rhs
        W_full, N_full = self._placed_rows(c, rows, idx)
        F_B = bc.pair(W_full, N_full, span, on)
        Wu = np.einsum("ij,ij->i", W_full, uB_t[span])
        Bd = (d_V.reshape(tr.cars, tr.wheels) @ self.B.T).reshape(-1)
        rhs = h_B - p_t + Wu - self.c_g * Bd
        if self.act is None:
            P = _solve(self.F_star + F_B, rhs)
        else:
            P = self._active_set_solve(t, c, N_full, uB_t, p_t, d_V, Bd, F_B, rhs)

        # back-substitution
        PV = ((self.c_g * P - d_V).reshape(tr.cars, tr.wheels) @ self.B.T).reshape(-1)
        ug = p_t + self.c_g * (P - PV)
        duV = duV_t + PV.reshape(tr.cars, tr.wheels) @ self.A.T
        uB = uB_t - bc.field(self._bridge_load(c, rows, idx, np.where(on, P, 0.0)))

        st.vV, st.aV = nm.update_increment(duV, PtV, QtV)
        st.uV = st.uV + duV
        st.vg, st.ag = nm.update(ug, Pg, Qg)
        st.ug = ug
        self._finish_bridge(uB, PB, QB)
        P_start = st.P  # the forces of t_n (a landing's impulse, unilateral.Impact)
        st.P, st.PV, st.t = P, PV, t
        if self.act is not None:
            dropped = None
            if self.act.landing.any():  # plastic impact at t_{n+1} (docs/method.md section 12)
                dropped = self.impact.apply(
                    st, c, self.act.active, self.act.landing, aux_is_wheel=False, P_start=P_start
                )
            self.act.finish(dropped)
            st.contact_state = self.act.in_contact
        if creep is not None:
            st.creepage, st.creep_force = creep.evaluate(st, c)
        return st

    def _active_set_solve(
        self,
        t: float,
        c: Contacts,
        N_full: np.ndarray,
        uB_t: np.ndarray,
        p_t: np.ndarray,
        d_V: np.ndarray,
        Bd: np.ndarray,
        F_B: np.ndarray,
        rhs: np.ndarray,
    ) -> np.ndarray:
        """The interface solve with the per-wheel active set (docs/method.md section 12): a free
        wheel's row is ``P_i = 0``, a landing wheel's row the position-level ``g_{n+1} = 0``."""
        act, tr = self.act, self.model.train
        assert act is not None
        act.begin()
        A = self.F_star + F_B
        FNN = Nu = None
        land = None
        while True:
            if act.all_in:
                P = _solve(A.copy(), rhs)
            else:
                A2, r2 = A.copy(), rhs.copy()
                if FNN is None:
                    FNN = self.bridge.pair(N_full, N_full, c.loc.span, c.on)
                    Nu = np.einsum("ij,ij->i", N_full, uB_t[c.loc.span])
                    land = landing_rows(self.model, c, self.shape)
                L = act.landing
                if L.any():
                    A2[L] = self.F_star[L] + FNN[L]
                    r2[L] = land.target[L] - p_t[L] + Nu[L] - self.c_g[L] * Bd[L]
                free = np.flatnonzero(act.free)
                A2[free] = 0.0
                A2[free, free] = 1.0
                r2[free] = 0.0
                P = _solve(A2, r2)
            gap = None
            if not act.active.all():
                if FNN is None:
                    FNN = self.bridge.pair(N_full, N_full, c.loc.span, c.on)
                    Nu = np.einsum("ij,ij->i", N_full, uB_t[c.loc.span])
                    land = landing_rows(self.model, c, self.shape)
                PV = ((self.c_g * P - d_V).reshape(tr.cars, tr.wheels) @ self.B.T).reshape(-1)
                ug = p_t + self.c_g * (P - PV)
                uplift = predicted_uplift(ug, c, Nu - FNN @ P)
                # a wheel in contact at t_n: its stabilised row's residual, ug - (W_hat u_B + h_B)
                gap = act.gap(A @ P - rhs, uplift)
            if not act.update(P, gap, t):
                return P

    # ----------------------------------------------------------------------------------------------
    def _finish_bridge(self, uB: np.ndarray, PB: np.ndarray, QB: np.ndarray) -> None:
        st = self.state
        st.vB, st.aB = self.nm.update(uB, PB, QB)
        st.uB = uB

    def _placed_rows(self, c: Contacts, rows: ContactRows, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``W_hat`` and ``N`` of each contact placed in its span's DOF vector (zero off the bridge)."""
        nd = self.model.bridge.ndof
        n = len(c.on)
        W_full = np.zeros((n, nd))
        N_full = np.zeros((n, nd))
        sel = np.flatnonzero(c.on)
        W_full[sel[:, None], idx[sel]] = rows.W_hat[sel]
        N_full[sel[:, None], idx[sel]] = rows.N0[sel]
        return W_full, N_full

    def _bridge_load(self, c: Contacts, rows: ContactRows, idx: np.ndarray, P: np.ndarray) -> np.ndarray:
        """``sum_i N_i P_i`` per span, shape ``(spans, ndof)``."""
        b = self.model.bridge
        load = np.zeros((b.nsub, b.ndof))
        sel = np.flatnonzero(c.on)
        np.add.at(load, (c.loc.span[sel, None], idx[sel]), rows.N0[sel] * P[sel, None])
        return load
