"""coupled-classic: monolithic system with classic, acceleration-level (index-1) multipliers.

No auxiliary points: the wheel (full mass) touches the rail directly. Unknowns
``[u_V, u_B, P, R_G]``. Each constraint is imposed as ``g'' = 0`` at t_{n+1`` — the discrete row of the
dynamic methods with ``kappa = 0`` (``omega = 0``), convective terms included. The multipliers are
the forces themselves. Nothing pulls a gap back once it has opened, so the gaps drift, mostly at
the slope kinks of span joints and bridge ends (docs/method.md); that drift is the point of
offering this method. Position-level (index-3) multipliers diverge with this Newmark scheme and are
not offered.

Rows and multiplier columns are scaled by ``a0 m_ref`` (docs/design.md pitfall 11): otherwise the
constraint rows are ~1 against ~a0 M in the dynamic rows and the LU pivots badly.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..model.system import Contacts, Model, State
from .monolithic import Monolithic, Triplets, solve_sparse
from .unilateral import ActiveSet, Impact, is_unilateral


class CoupledClassic(Monolithic):
    """Index-1 monolithic stepper; see the module docstring."""

    name = "coupled-classic"

    def __init__(self, model: Model, state: State) -> None:
        self._layout(model, state, 0.0, 0.0)  # kappa = zeta = 0: the acceleration-level rows
        tr = model.train
        nm = self.nm
        self.oP = self.oB + self.NB
        self.oR = self.oP + self.nc
        self.n = self.oR + self.NS
        self.sG = nm.a0 * self.support_masses
        self.sC = nm.a0 * float(np.mean(tr.wheel_masses)) if not self.moving_load else 1.0
        if not self.moving_load:
            # an index-1 contact carries the wheel with it: the wheel and its aux point are one body
            state.ug = (state.uV @ tr.W).reshape(-1)
            state.PV = state.P.copy()
        self.const = self._constant_part()
        self.act: ActiveSet | None = None
        if is_unilateral(model):  # docs/method.md section 12
            self.act = ActiveSet(tr.contacts)
            self.impact = Impact(model)
            state.contact_state = self.act.in_contact
            # the contact rows' vehicle entries apart, to drop the rows of free wheels
            r, c, v = self.const
            is_row = (r >= self.oP) & (r < self.oP + self.nc) & (c < self.NV)
            self.const_base = (r[~is_row], c[~is_row], v[~is_row])
            self.const_rows = (r[is_row], c[is_row], v[is_row])

    def _constant_part(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        m, nm = self.model, self.nm
        tr = m.train
        T = Triplets()
        self._bridge_blocks(T, self.oR, self.sG)
        if not self.moving_load:
            v = tr.vehicle
            k_hat_V = nm.effective(v.K, v.C, v.M)
            nV, nw = self.nV, tr.wheels
            for k in range(tr.cars):
                o = k * nV
                T.dense(o, o, k_hat_V)
                T.dense(o, self.oP + k * nw, -self.sC * tr.W)
                T.dense(self.oP + k * nw, o, self.sC * tr.W.T)
        return T.arrays()

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
        rhs[self.oR :] = self.sG * bs.q_hat

        if self.moving_load:
            self._moving_loads(bs, c, rows.N0, rhs)
            x = solve_sparse(self.const, T, self.n, rhs)
            self._finish_bridge(x, PB, QB)
            st.P = tr.axle_loads.copy()
            st.PV = st.P
            st.t = t
            return st

        cd = self._contact_dofs(c)
        on, sel, span, idx, gdofs = cd.on, cd.sel, cd.span, cd.idx, cd.gdofs
        # vehicle unknowns are the increments over the step (Newmark.update_increment)
        PtV, QtV = nm.increment_history(st.vV, st.aV)
        PV_, QV_ = nm.total_history(st.uV, PtV, QtV)
        fV = tr.increment_load(st.uV, PtV, QtV, full_mass=True)
        creep = m.creep
        if creep is not None:  # explicit: the creep force of t_n loads this step (docs/method.md)
            fV += creep.vehicle_load(st.creep_force)
            creep.add_bridge_load(fB, st.creep_force, c)
        rhs[: self.NV] = fV.reshape(-1)
        rhs[self.oB : self.oB + self.NB] = fB.reshape(-1)
        # bridge rows: + N P
        T.add(gdofs[sel], np.repeat(self.oP + sel, 6), rows.N0[sel] * self.sC)
        # contact rows: wheel - W_hat^T u_B = h (wheel histories in place of the aux point's)
        Pw = (PV_ @ tr.W).reshape(-1)
        Qw = (QV_ @ tr.W).reshape(-1)
        Pe = PB[span[:, None], idx]
        Qe = QB[span[:, None], idx]
        h_on = rows.h_bridge(Pw, Qw, Pe, Qe, c)
        h_off = self.point.off_bridge_target(Pw, Qw, c)
        wheel_n = (st.uV @ tr.W).reshape(-1)
        h = np.where(on, h_on, h_off)
        if self.act is None:
            rhs[self.oP : self.oP + self.nc] = self.sC * (h - wheel_n)
            T.add(np.repeat(self.oP + sel, 6), gdofs[sel], -self.sC * rows.W_hat[sel])
            x = solve_sparse(self.const, T, self.n, rhs)
        else:
            x = self._active_set_solve(t, c, rows, gdofs, h, wheel_n, T, rhs)
        duV = x[: self.NV].reshape(tr.cars, self.nV)
        st.vV, st.aV = nm.update_increment(duV, PtV, QtV)
        uV = st.uV = st.uV + duV
        self._finish_bridge(x, PB, QB)
        P_start = st.P  # the forces of t_n (a landing's impulse, unilateral.Impact)
        st.P = self.sC * x[self.oP : self.oP + self.nc]
        st.PV = st.P
        st.ug = (uV @ tr.W).reshape(-1)
        st.vg = (st.vV @ tr.W).reshape(-1)
        st.ag = (st.aV @ tr.W).reshape(-1)
        st.t = t
        if self.act is not None:
            act = self.act
            st.P[~act.active] = 0.0
            dropped = None
            if act.landing.any():  # plastic impact at t_{n+1} (docs/method.md section 12)
                dropped = self.impact.apply(
                    st, c, act.active, act.landing, aux_is_wheel=True, P_start=P_start
                )
            act.finish(dropped)
            st.contact_state = act.in_contact
        if creep is not None:
            st.creepage, st.creep_force = creep.evaluate(st, c)
        return st

    def _active_set_solve(
        self,
        t: float,
        c: Contacts,
        rows: Any,
        gdofs: np.ndarray,
        h: np.ndarray,
        wheel_n: np.ndarray,
        T: Triplets,
        rhs: np.ndarray,
    ) -> np.ndarray:
        """Contact rows by the per-wheel active set (docs/method.md section 12): in contact, the
        acceleration-level row; landing, the position-level ``g_{n+1} = 0``; free, ``P = 0``."""
        act, nc, sC = self.act, self.nc, self.sC
        assert act is not None
        act.begin()
        on = c.on
        oP = self.oP + np.arange(nc)
        span, idx = c.loc.span, c.element_dofs()
        target = np.where(on, c.r, c.q + c.r)
        tr = self.model.train
        while True:
            held, land = act.active, act.landing
            if act.all_in:
                const = self.const
            else:
                r, cc, v = self.const_rows
                keep = held[r - self.oP]
                b = self.const_base
                const = (
                    np.concatenate([b[0], r[keep]]),
                    np.concatenate([b[1], cc[keep]]),
                    np.concatenate([b[2], v[keep]]),
                )
            Tp = Triplets()
            Tp.rows, Tp.cols, Tp.vals = list(T.rows), list(T.cols), list(T.vals)
            rr = rhs.copy()
            s_on = np.flatnonzero(held & ~land & on)
            l_on = np.flatnonzero(land & on)
            Tp.add(np.repeat(oP[s_on], 6), gdofs[s_on], -sC * rows.W_hat[s_on])
            Tp.add(np.repeat(oP[l_on], 6), gdofs[l_on], -sC * rows.N0[l_on])
            rr[oP] = sC * (np.where(land, target, h) - wheel_n)
            free = ~held
            Tp.add(oP[free], oP[free], np.full(int(free.sum()), sC))
            rr[oP[free]] = 0.0
            x = solve_sparse(const, Tp, self.n, rr)
            P = sC * x[self.oP : self.oP + nc]
            gap = None
            if free.any():
                uB = x[self.oB : self.oB + self.NB].reshape(self.model.bridge.nsub, -1)
                ue = uB[span[:, None], idx]
                duV = x[: self.NV].reshape(tr.cars, self.nV)
                wheel = ((self.state.uV + duV) @ tr.W).reshape(-1)
                rail_on = np.einsum("ij,ij->i", rows.N0, ue)
                uplift = wheel - (np.where(on, rail_on, c.q) + c.r)
                # a wheel in contact at t_n: its contact row's residual, wheel - (W_hat u_B + h)
                stab = wheel - np.where(on, np.einsum("ij,ij->i", rows.W_hat, ue), 0.0) - h
                gap = act.gap(stab, uplift)
            if not act.update(P, gap, t):
                return x
