"""coupled-dynamic: the paper's monolithic system, Eq. (36), refactored every step.

Unknowns ``[u_V, u_B, lambda_V, lambda_B, u_g, lambda_G]``: vehicle and bridge DOFs, the dynamic
multipliers of the wheel-aux, aux-bridge and support constraints, and the aux points. Each force is a
dynamic multiplier through its constraint ODE (Eqs. 7, 12, 13)::

    P = mbar lambda'' + cbar lambda' + kbar lambda = D dlambda - H,
    D = mbar (a0 + 2 zeta omega a1 + omega^2),
    H = mbar (P~[lambda] + 2 zeta omega Q~[lambda] - omega^2 lambda_n)

with ``cbar = 2 zeta omega mbar``, ``kbar = omega^2 mbar`` and the constraint masses ``mbar`` of
Eqs. (25)-(35) from ``svbi.codegen.constraints`` (Eq. 27 with the active vehicle mass, Eq. 31 with the
element holding the contact, so it changes as the wheel moves, Eq. 34). Each constraint row is the
discrete constraint multiplied by ``D`` (Eqs. 19, 20, 24). The system is sparse and non-symmetric; it
is assembled and LU-factored (``scipy.sparse.linalg.splu``) every step, which is what the
localized method avoids. In exact arithmetic both solve the same discrete equations.

The multiplier unknowns are the increments ``dlambda = lambda_{n+1} - lambda_n`` with the increment
histories ``P~``, ``Q~`` of ``Newmark.increment_history`` (like the vehicles): in the total form
``D lambda - H`` both terms grow like ``a0 |lambda|``, and with ``kappa = 0`` lambda grows like t^2
(docs/design.md pitfall 7), so the force lost digits with every step.

Sign convention: ``lambda`` has the sign of the force it generates (compression positive).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...codegen.plain_types import GRAVITY
from ..model.contact_rows import BridgeConstraintMass, vehicle_constraint_masses
from ..model.system import Contacts, Model, State
from .monolithic import Monolithic, Triplets, solve_sparse
from .reactions import constraint_forces
from .unilateral import ActiveSet, Impact, is_unilateral


class CoupledDynamic(Monolithic):
    """Monolithic stepper with dynamic multipliers; see the module docstring."""

    name = "coupled-dynamic"

    def __init__(self, model: Model, state: State) -> None:
        s = model.settings
        self._layout(model, state, s.kappa, s.zeta)
        b, tr = model.bridge, model.train
        omega = s.kappa / s.time_step
        self.c2 = 2 * s.zeta * omega
        self.w2 = omega * omega
        self.d = self.point.d
        self.oLV = self.oB + self.NB
        self.oLB = self.oLV + self.nc
        self.oG = self.oLB + self.nc
        self.oLG = self.oG + self.nc
        self.n = self.oLG + self.NS
        self.mG = self.support_masses
        self.DG = self.d * self.mG
        # multipliers start consistent with the initial forces (docs/method.md)
        c0 = model.contacts(0.0)
        RG0 = constraint_forces(model, state, c0, np.where(c0.on, state.P, 0.0))
        self.lamG = self._initial_lambda(RG0, self.mG)
        if not self.moving_load:
            self.m_g = np.tile(tr.aux_masses, tr.cars)
            self.mV = np.tile(
                vehicle_constraint_masses(tr.topology_name, tr.parameter_values, s.split), tr.cars
            )
            self.DV = self.d * self.mV
            self.mB_kernel = BridgeConstraintMass(b.contact_element_length, b.span_mass, tr.aux_masses[0])
            self.lamV = self._initial_lambda(state.PV, self.mV)
            self.lamB = self._initial_lambda(state.P, self._mB(c0))
        self.const = self._constant_part()
        self.act: ActiveSet | None = None
        if is_unilateral(model):  # docs/method.md section 12
            self.act = ActiveSet(tr.contacts)
            self.impact = Impact(model)
            state.contact_state = self.act.in_contact

    # ----------------------------------------------------------------------------------------------
    def _initial_lambda(self, force: np.ndarray, mbar: np.ndarray) -> list[np.ndarray]:
        z = np.zeros_like(force)
        if self.w2 > 0:
            return [force / (self.w2 * mbar), z.copy(), z.copy()]
        return [z.copy(), z.copy(), force / mbar]

    def _mB(self, c: Contacts) -> np.ndarray:
        """Eq. (31) on the bridge; off it the constraint touches only the aux point (mbar = m_g)."""
        tr = self.model.train
        m_g = np.tile(tr.aux_masses, tr.cars)
        return np.where(c.on, self.mB_kernel(c.loc.xi, c.loc.span), m_g)

    def _force(self, lam: list[np.ndarray], D: np.ndarray, mbar: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``H`` of the force ``D dlambda - H`` (module docstring), and ``D``."""
        Pt, Qt = self.nm.increment_history(lam[1], lam[2])
        H = mbar * (Pt + self.c2 * Qt - self.w2 * lam[0])
        return H, D

    def _constant_part(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        m, nm = self.model, self.nm
        tr = m.train
        T = Triplets()
        self._bridge_blocks(T, self.oLG, self.DG)
        if not self.moving_load:
            v = tr.vehicle
            k_hat_V = nm.effective(v.K, v.C, tr.M_active)
            nV, nw = self.nV, tr.wheels
            for k in range(tr.cars):
                o = k * nV
                T.dense(o, o, k_hat_V)
                lv = self.oLV + k * nw + np.arange(nw)
                DV = self.DV[k * nw : (k + 1) * nw]
                T.dense(o, self.oLV + k * nw, -tr.W * DV[None, :])
                T.dense(self.oLV + k * nw, o, (tr.W * DV[None, :]).T)
                T.add(lv, self.oG + k * nw + np.arange(nw), -DV)
                T.add(self.oG + k * nw + np.arange(nw), lv, DV)
            g = self.oG + np.arange(self.nc)
            T.add(g, g, nm.a0 * self.m_g)
        return T.arrays()

    # ----------------------------------------------------------------------------------------------
    def step(self, n: int) -> State:
        m, nm, st = self.model, self.nm, self.state
        tr = m.train
        t = (n + 1) * m.dt
        c = m.contacts(t)
        self.contacts = c
        rows = self.rows(c.loc.xi, c.loc.span, c.v, c.a)
        rhs = np.zeros(self.n)
        T = Triplets()

        bs = self._bridge_step(t)
        PB, QB, fB = bs.PB, bs.QB, bs.fB
        HG, _ = self._force(self.lamG, self.DG, self.mG)
        self._constraint_load(fB, HG)
        q_hat = bs.q_hat
        b = m.bridge
        if not b.uniform and b.links.spring.any():  # a spring's force D dlambda - H = -k (u_a - u_b)
            q_hat = q_hat.copy()
            links = slice(3 * b.nsub, None)
            q_hat[links] = np.where(b.links.spring, b.links.compliance * HG[links], q_hat[links])
        rhs[self.oLG : self.oLG + self.NS] = self.DG * q_hat

        if self.moving_load:
            self._moving_loads(bs, c, rows.N0, rhs)
            x = solve_sparse(self.const, T, self.n, rhs)
            self._finish_bridge(x, PB, QB)
            self._update_lambda(self.lamG, x[self.oLG :])
            st.P = tr.axle_loads.copy()
            st.PV = st.P
            st.t = t
            return st

        cd = self._contact_dofs(c)
        on, sel, span, idx, gdofs = cd.on, cd.sel, cd.span, cd.idx, cd.gdofs
        # vehicle unknowns are the increments over the step (Newmark.update_increment)
        PtV, QtV = nm.increment_history(st.vV, st.aV)
        PV_, QV_ = nm.total_history(st.uV, PtV, QtV)
        Pg, Qg = nm.history(st.ug, st.vg, st.ag)
        mB = self._mB(c)
        DB = self.d * mB
        HV, _ = self._force(self.lamV, self.DV, self.mV)
        HB, _ = self._force(self.lamB, DB, mB)

        # vehicle rows (the creep force of t_n is an explicit load, docs/method.md)
        creep = m.creep
        fV = tr.increment_load(st.uV, PtV, QtV)
        fV -= HV.reshape(tr.cars, tr.wheels) @ tr.W.T
        if creep is not None:
            fV += creep.vehicle_load(st.creep_force)
            creep.add_bridge_load(fB, st.creep_force, c)
        rhs[: self.NV] = fV.reshape(-1)
        # bridge rows: + N D_B lambda_B on the left, + N H_B on the right
        np.add.at(fB, (span[sel, None], idx[sel]), rows.N0[sel] * HB[sel, None])
        rhs[self.oB : self.oB + self.NB] = fB.reshape(-1)
        T.add(gdofs[sel], np.repeat(self.oLB + sel, 6), rows.N0[sel] * DB[sel, None])
        # wheel-aux rows
        h_V = self.point.wheel_target((PV_ @ tr.W).reshape(-1), (QV_ @ tr.W).reshape(-1), Pg, Qg)
        rhs[self.oLV : self.oLV + self.nc] = self.DV * (h_V - (st.uV @ tr.W).reshape(-1))
        # aux-bridge rows
        Pe = PB[span[:, None], idx]
        Qe = QB[span[:, None], idx]
        h_on = rows.h_bridge(Pg, Qg, Pe, Qe, c)
        h_off = self.point.off_bridge_target(Pg, Qg, c)
        h_B = np.where(on, h_on, h_off)
        lb = self.oLB + np.arange(self.nc)
        # aux rows
        T.add(self.oG + np.arange(self.nc), lb, -DB)
        rhs[self.oG : self.oG + self.nc] = self.m_g * (Pg - GRAVITY) - HB + HV
        if self.act is None:
            T.add(lb, self.oG + np.arange(self.nc), DB)
            T.add(np.repeat(self.oLB + sel, 6), gdofs[sel], -rows.W_hat[sel] * DB[sel, None])
            rhs[lb] = DB * h_B
            x = solve_sparse(self.const, T, self.n, rhs)
        else:
            x = self._active_set_solve(t, c, rows, gdofs, DB, HB, h_B, T, rhs)

        duV = x[: self.NV].reshape(tr.cars, self.nV)
        st.vV, st.aV = nm.update_increment(duV, PtV, QtV)
        st.uV = st.uV + duV
        ug = x[self.oG : self.oG + self.nc]
        st.vg, st.ag = nm.update(ug, Pg, Qg)
        st.ug = ug
        self._finish_bridge(x, PB, QB)
        dlamV = x[self.oLV : self.oLV + self.nc]
        dlamB = x[self.oLB : self.oLB + self.nc]
        st.PV = self.DV * dlamV - HV
        P_start = st.P  # the forces of t_n (a landing's impulse, unilateral.Impact)
        st.P = DB * dlamB - HB
        self._update_lambda(self.lamV, dlamV)
        self._update_lambda(self.lamB, dlamB)
        self._update_lambda(self.lamG, x[self.oLG :])
        st.t = t
        if self.act is not None:
            self._contact_events(st, c, mB, P_start)
        if creep is not None:
            st.creepage, st.creep_force = creep.evaluate(st, c)
        return st

    # ----------------------------------------------------------------------------------------------
    def _active_set_solve(
        self,
        t: float,
        c: Contacts,
        rows: Any,
        gdofs: np.ndarray,
        DB: np.ndarray,
        HB: np.ndarray,
        h_B: np.ndarray,
        T: Triplets,
        rhs: np.ndarray,
    ) -> np.ndarray:
        """Aux-bridge rows by the per-wheel active set (docs/method.md section 12): a contact in
        contact keeps its stabilised row, a landing one gets ``g_{n+1} = 0`` (``N`` in place of
        ``W_hat``, the rail height as target), a free one ``D dlambda = H``, i.e. ``P = 0``."""
        act, nc = self.act, self.nc
        assert act is not None
        act.begin()
        on = c.on
        lb = self.oLB + np.arange(nc)
        og = self.oG + np.arange(nc)
        span, idx = c.loc.span, c.element_dofs()
        target = np.where(on, c.r, c.q + c.r)
        while True:
            Tp = Triplets()
            Tp.rows, Tp.cols, Tp.vals = list(T.rows), list(T.cols), list(T.vals)
            r = rhs.copy()
            held = act.active
            land = act.landing
            stab = held & ~land
            s_on = np.flatnonzero(stab & on)
            l_on = np.flatnonzero(land & on)
            Tp.add(lb[held], og[held], DB[held])
            Tp.add(np.repeat(lb[s_on], 6), gdofs[s_on], -rows.W_hat[s_on] * DB[s_on, None])
            Tp.add(np.repeat(lb[l_on], 6), gdofs[l_on], -rows.N0[l_on] * DB[l_on, None])
            r[lb] = np.where(land, DB * target, DB * h_B)
            free = ~held
            Tp.add(lb[free], lb[free], DB[free])
            r[lb[free]] = HB[free]
            x = solve_sparse(self.const, Tp, self.n, r)
            P = DB * x[self.oLB : self.oLB + nc] - HB
            gap = None
            if free.any():
                uB = x[self.oB : self.oB + self.NB].reshape(self.model.bridge.nsub, -1)
                ue = uB[span[:, None], idx]
                ug = x[self.oG : self.oG + nc]
                rail = np.where(on, np.einsum("ij,ij->i", rows.N0, ue), c.q) + c.r
                # a wheel in contact at t_n: its stabilised row's residual, ug - (W_hat u_B + h_B)
                stab = ug - np.where(on, np.einsum("ij,ij->i", rows.W_hat, ue), 0.0) - h_B
                gap = act.gap(stab, ug - rail)
            if not act.update(P, gap, t):
                return x

    def _contact_events(self, st: State, c: Contacts, mB: np.ndarray, P_start: np.ndarray) -> None:
        """Free wheels carry ``P = 0`` exactly; landing wheels go through the plastic impact, and
        the multipliers of every force the impact changed restart from it (section 5's initial
        form: ``lambda = P/kbar``): a multiplier only parametrises its force, ``dlambda`` is free."""
        act = self.act
        assert act is not None
        free = ~act.active
        st.P[free] = 0.0
        dropped = None
        if act.landing.any():
            P0, PV0 = st.P.copy(), st.PV.copy()
            dropped = self.impact.apply(st, c, act.active, act.landing, aux_is_wheel=False, P_start=P_start)
            changed = (st.P != P0) | (st.PV != PV0)
            lamB = self._initial_lambda(st.P, mB)
            lamV = self._initial_lambda(st.PV, self.mV)
            for k in range(3):
                self.lamB[k][changed] = lamB[k][changed]
                self.lamV[k][changed] = lamV[k][changed]
        act.finish(dropped)
        out = ~act.in_contact
        for k in range(3):  # a free wheel's force is zero: so is its multiplier
            self.lamB[k][out] = 0.0
        st.contact_state = act.in_contact

    def _update_lambda(self, lam: list[np.ndarray], delta: np.ndarray) -> None:
        Pt, Qt = self.nm.increment_history(lam[1], lam[2])
        v, a = self.nm.update_increment(delta, Pt, Qt)
        lam[0], lam[1], lam[2] = lam[0] + delta, v, a
