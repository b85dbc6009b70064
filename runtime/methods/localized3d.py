"""localized-dynamic in 3D (docs/three-d.md, "The 3D time step").

The partitioned step of :mod:`svbi.runtime.methods.localized` for the system of
:mod:`svbi.runtime.methods.coupled3d`: the vehicle and the span are solved apart, each with its own
effective matrix factored once, and only the normal contact forces ``P`` (two per wheelset) are
solved together, from a small interface system. The vehicle and span respond linearly to given
forces: ``du = du~ + A_V G_V^T P``, ``u = u~ + S G_B^T P`` (predictors ``du~``, ``u~`` with no
contact force, compliances ``A_V = K^_V^-1``, ``S = K^_B^-1`` inverted once, the forces along the
gap gradients ``G``). The 3D gap is nonlinear in the roll, so the interface is iterated: with
``G`` and the constraint rows ``J`` (of ``g'' + 2 zeta omega g' + omega^2 g`` with Newmark's rates)
at the current iterate ``z^k``,

    (J_V A_V G_V^T + J_B S G_B^T) P = -E(z^k) + J_V (du^k - du~) + J_B (u^k - u~),

until the update is round-off. The converged step satisfies the coupled step's equations (the same
equilibrium and the same constraint rows, ``E = 0``), so both give the same solution to round-off;
the geometric stiffness ``P d2g/dz2``, which the coupled Newton includes, only sets how fast the
interface iteration converges. In the vertical plane the gradients do not change with the state and
one solve is exact. The span's response to the contact forces is ``S`` times the forces at every
iteration (a prototype: the 2D method keeps the flexibility between contact points).
"""

from __future__ import annotations

import numpy as np

from ..model.system3d import System3D
from .coupled3d import NEWTON_ITERATIONS, PER_WHEELSET, Convergence, State3D, _Step3D, block_inverse


class LocalizedDynamic3D(_Step3D):
    """The partitioned 3D step; see the module docstring."""

    name = "localized-dynamic-3d"

    def __init__(
        self,
        system: System3D,
        state: State3D,
        time_step: float,
        kappa: float = 1.0,
        zeta: float = 1.0,
        normal: str = "unilateral",
    ) -> None:
        super().__init__(system, state, time_step, kappa, zeta, normal)
        span, veh, nm, f = system.span, system.vehicle, self.nm, self.asm.free
        # the compliances, inverted once (dense, as the 2D stepper's vehicles), block by decoupled block
        self.A_V = block_inverse(nm.effective(veh.K, veh.C, veh.M))
        self.S_B = block_inverse(nm.effective(span.K, self.CB, span.M)[np.ix_(f, f)])

    def _solve(
        self, t: float, loc: list, hist_V: tuple, hist_B: tuple, fV: np.ndarray, fB: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        st, asm, act = self.state, self.asm, self.active
        f = asm.free
        nm = self.nm
        (PtV, QtV), (PB, QB) = hist_V, hist_B
        # predictors: each subsystem alone, no contact force
        dq0 = self.A_V @ fV
        uf0 = self.S_B @ fB
        nC = asm.nC
        dq = dq0.copy()
        u = self._hold(np.zeros_like(st.u))
        u[f] = uf0
        lam = np.where(act.active, st.forces(), 0.0)
        free = np.flatnonzero(~act.active)
        converged = Convergence()
        for _ in range(NEWTON_ITERATIONS):
            self.iterations += 1
            q = st.q + dq
            qd, qdd = nm.update_increment(dq, PtV, QtV)
            ud, udd = self._span_rates(u, PB, QB)
            rows = self._rows_at(t, loc, q, qd, qdd, u, ud, udd, hessian=False)
            GV, GB = self._directions(rows, loc)  # force directions
            JV = np.zeros((nC, asm.nV))  # constraint rows
            JB = np.zeros((nC, asm.nF))
            E = np.zeros(nC)
            for w, (e, _) in enumerate(loc):
                cols = asm.columns(w, e)
                veh_cols, deck = cols[:4], cols[4:]
                on = deck >= 0
                for k in range(PER_WHEELSET):
                    i = PER_WHEELSET * w + k
                    jac, E[i] = rows[w].row(k, bool(act.landing[i]))
                    JV[i, veh_cols] = jac[:4]
                    JB[i, deck[on] - asm.oB] = jac[4:][on]
            AV = self.A_V @ GV.T  # vehicle response to unit contact forces
            SB = self.S_B @ GB.T  # span response
            interface = JV @ AV + JB @ SB
            rhs = -E + JV @ (dq - dq0) + JB @ (u[f] - uf0)
            # a contact out of the active set carries no force
            interface[free] = 0.0
            interface[free, free] = 1.0
            rhs[free] = 0.0
            lam_new = np.linalg.solve(interface, rhs)
            dq_new = dq0 + AV @ lam_new
            uf_new = uf0 + SB @ lam_new
            change = max(np.abs(dq_new - dq).max(), np.abs(uf_new - u[f]).max())
            dq, lam = dq_new, lam_new
            u[f] = uf_new
            if converged(change, max(np.abs(st.q + dq).max(), np.abs(u).max())):
                break
        return dq, u, lam
