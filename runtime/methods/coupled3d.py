"""coupled-dynamic in 3D (a prototype; docs/three-d.md, "The 3D time step (prototype)").

The monolithic step of :mod:`svbi.runtime.methods.coupled_dynamic` for a 3D car on one 3D span
(:class:`svbi.runtime.model.system3d.System3D`): the whole system's ``M``, ``C``, ``K`` with the two
normal contacts of each wheelset (:mod:`svbi.codegen.contact3d`) as constraints, each imposed at
t_{n+1} as ``g'' + 2 zeta omega g' + omega^2 g = 0`` with Newmark's relations (``omega = kappa / dt``),
as the 2D rows (docs/method.md section 3). Unknowns per step ``[du_V, u_B, P]``: the vehicle's
increment (the 2D increment form), the span's free DOFs at t_{n+1} and the normal contact forces
(compression positive), acting along the gradients of the gaps. The 3D gap is nonlinear in the roll,
so each step is solved by Newton's method (the contact forces' geometric stiffness ``P d2g/dz2``
included), to round-off.

Differences from the 2D stepper, none of which changes the discrete solution in exact arithmetic:
the wheel-aux and aux-bridge gaps are one gap (no auxiliary point: with both stabilised from zero
the aux point moves with the wheel, so the wheel's whole mass rides on the deck either way); the
contact force is the unknown, not the increment of its dynamic multiplier (``P = D dlambda - H`` is
a one-to-one change of unknown); the span's fork supports are eliminated, not imposed by support
constraints (with a fixed ground those stay at zero).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.system3d import ContactKernel3D, System3D
from .newmark import Newmark

NEWTON_TOLERANCE = 1e-13
"""Newton stops when the update of the displacements is below this share of their size."""
NEWTON_ITERATIONS = 20
STAGNATION = 1e-9
"""Below this share of the displacements, an update that no longer halves is round-off."""


class Convergence:
    """Stop an iteration when its update is below :data:`NEWTON_TOLERANCE` of the displacements, or
    when, already below :data:`STAGNATION` of them, it has stopped shrinking (round-off reached: it
    no longer halves)."""

    def __init__(self) -> None:
        self.last = np.inf

    def __call__(self, change: float, size: float) -> bool:
        size = max(size, 1e-300)
        stalled = change <= STAGNATION * size and change > 0.5 * self.last
        self.last = change
        return change <= NEWTON_TOLERANCE * size or stalled


@dataclass
class State3D:
    """Vehicle and span displacements, rates and accelerations, and the contact forces, at ``t``."""

    t: float
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    u: np.ndarray
    """The span's full DOF vector (zeros at the supports)."""
    ud: np.ndarray
    udd: np.ndarray
    P: np.ndarray
    """Normal contact forces, wheelset by wheelset, left then right (N)."""


class _Assembly:
    """Indices of the unknowns ``[q_V (nV), u_B free (nF), P (2 per wheelset)]``."""

    def __init__(self, system: System3D) -> None:
        self.system = system
        self.nV = len(system.vehicle.dof_names)
        span = system.span
        self.free = span.free
        self.nF = len(self.free)
        self.full_to_free = -np.ones(span.M.shape[0], dtype=int)
        self.full_to_free[self.free] = np.arange(self.nF)
        self.nW = len(system.vehicle.wheelsets)
        self.oB = self.nV
        self.oP = self.nV + self.nF
        self.n = self.oP + 2 * self.nW

    def columns(self, w: int, element: int) -> np.ndarray:
        """Unknown of each of the contact's 16 ``z`` entries (-1: a held span DOF)."""
        ws = self.system.vehicle.wheelsets[w]
        deck = self.full_to_free[self.system.span.element_dofs(element)]
        return np.concatenate([ws.dofs, np.where(deck >= 0, self.oB + deck, -1)])

    def z(self, w: int, element: int, q: np.ndarray, u: np.ndarray) -> np.ndarray:
        ws = self.system.vehicle.wheelsets[w]
        return np.concatenate([q[ws.dofs], u[self.system.span.element_dofs(element)]])

    def add_contact(
        self,
        A: np.ndarray,
        R: np.ndarray,
        w: int,
        cols: np.ndarray,
        P: np.ndarray,
        grad: np.ndarray,
        hess: np.ndarray,
    ) -> None:
        """The contact forces ``P_s grad g_s`` of wheelset ``w`` in the equilibrium rows (residual
        ``R`` holds ``K x - f``, so the forces enter with ``-``) and their Jacobian."""
        keep = cols >= 0
        c = cols[keep]
        for s in range(2):
            R[c] -= P[s] * grad[s, keep]
            A[np.ix_(c, c)] -= P[s] * hess[s][np.ix_(keep, keep)]
            A[c, self.oP + 2 * w + s] -= grad[s, keep]


def static_state(system: System3D, t: float = 0.0) -> State3D:
    """Static equilibrium of the vehicle on the span (gravity and ``system.load``) with the gaps
    closed, by Newton's method; rates and accelerations zero. Gravity alone first: a lateral load
    is held only by the contact forces' geometric stiffness, which needs them loaded."""
    asm = _Assembly(system)
    span = system.span
    le = span.length / span.n_elements
    kernels = [ContactKernel3D(w, system.track, le, 0.0, 0.0, 0.0) for w in system.vehicle.wheelsets]
    q = np.zeros(asm.nV)
    u = np.zeros(span.M.shape[0])
    P = np.zeros(2 * asm.nW)
    loads = [system.vehicle.F, system.vehicle_load()] if system.load is not None else [system.vehicle.F]
    for f in loads:
        _static_newton(system, asm, kernels, t, f, q, u, P)
    z0 = np.zeros_like
    return State3D(t, q, z0(q), z0(q), u, z0(u), z0(u), P)


def _static_newton(
    system: System3D,
    asm: _Assembly,
    kernels: list[ContactKernel3D],
    t: float,
    f: np.ndarray,
    q: np.ndarray,
    u: np.ndarray,
    P: np.ndarray,
) -> None:
    """Newton's method on the static equations from ``(q, u, P)`` (updated in place)."""
    veh, span = system.vehicle, system.span
    loc = system.contact_location(t)
    KB = span.K[np.ix_(asm.free, asm.free)]
    converged = Convergence()
    for _ in range(NEWTON_ITERATIONS):
        A = np.zeros((asm.n, asm.n))
        R = np.zeros(asm.n)
        A[: asm.nV, : asm.nV] = veh.K
        R[: asm.nV] = veh.K @ q - f
        A[asm.oB : asm.oP, asm.oB : asm.oP] = KB
        R[asm.oB : asm.oP] = KB @ u[asm.free]
        for w, (e, xi) in enumerate(loc):
            cols = asm.columns(w, e)
            keep = cols >= 0
            z = asm.z(w, e, q, u)
            k = kernels[w]
            grad = k.gradient(z, xi)
            asm.add_contact(A, R, w, cols, P[2 * w : 2 * w + 2], grad, k.hessian(z, xi))
            gap = k.gap(z, xi)
            for s in range(2):
                row = asm.oP + 2 * w + s
                A[row, cols[keep]] = grad[s, keep]
                R[row] = gap[s]
        dx = np.linalg.solve(A, -R)
        q += dx[: asm.nV]
        u[asm.free] += dx[asm.oB : asm.oP]
        P += dx[asm.oP :]
        if converged(np.abs(dx[: asm.oP]).max(), max(np.abs(q).max(), np.abs(u).max())):
            return
    raise RuntimeError(f"the static state did not converge in {NEWTON_ITERATIONS} Newton iterations")


class _Step3D:
    """What both 3D steps share: the Newmark set-up, the contact kernels, the histories and loads
    of a step, the commit of its solution and the gaps."""

    def __init__(
        self, system: System3D, state: State3D, time_step: float, kappa: float = 1.0, zeta: float = 1.0
    ) -> None:
        self.system = system
        self.state = state
        self.dt = time_step
        self.nm = Newmark(time_step)
        omega = kappa / time_step
        self.asm = _Assembly(system)
        span = system.span
        le = span.length / span.n_elements
        self.kernels = [
            ContactKernel3D(w, system.track, le, system.speed, 2 * zeta * omega, omega * omega)
            for w in system.vehicle.wheelsets
        ]
        self.CB = np.zeros_like(span.M) if system.bridge_damping is None else system.bridge_damping
        self.iterations = 0

    def _loads(self, n: int) -> tuple[float, tuple, tuple, np.ndarray, np.ndarray]:
        """t_{n+1}, the vehicle's and the span's Newmark histories, and their effective loads."""
        sys_, st, nm = self.system, self.state, self.nm
        veh, span = sys_.vehicle, sys_.span
        PtV, QtV = nm.increment_history(st.qd, st.qdd)
        fV = sys_.vehicle_load() - veh.K @ st.q + veh.M @ PtV + veh.C @ QtV
        PB, QB = nm.history(st.u, st.ud, st.udd)
        fB = (span.M @ PB + self.CB @ QB)[self.asm.free]
        return (n + 1) * self.dt, (PtV, QtV), (PB, QB), fV, fB

    def _commit(
        self, t: float, dq: np.ndarray, u: np.ndarray, P: np.ndarray, hist_V: tuple, hist_B: tuple
    ) -> State3D:
        """The state at t_{n+1} from the vehicle's increment, the span's displacements and P."""
        st, nm = self.state, self.nm
        st.qd, st.qdd = nm.update_increment(dq, *hist_V)
        st.q = st.q + dq
        st.ud, st.udd = nm.update(u, *hist_B)
        st.u = u
        st.P = P
        st.t = t
        return st

    def gaps(self) -> np.ndarray:
        """Normal gaps of every contact at the state's time (m), wheelset by wheelset."""
        st, asm = self.state, self.asm
        out = []
        for w, (e, xi) in enumerate(self.system.contact_location(st.t)):
            out.extend(self.kernels[w].gap(asm.z(w, e, st.q, st.u), xi))
        return np.array(out)


class CoupledDynamic3D(_Step3D):
    """The monolithic 3D step; see the module docstring."""

    name = "coupled-dynamic-3d"

    def __init__(
        self, system: System3D, state: State3D, time_step: float, kappa: float = 1.0, zeta: float = 1.0
    ) -> None:
        super().__init__(system, state, time_step, kappa, zeta)
        veh, span, nm = system.vehicle, system.span, self.nm
        self.k_hat_V = nm.effective(veh.K, veh.C, veh.M)
        self.k_hat_B = nm.effective(span.K, self.CB, span.M)[np.ix_(self.asm.free, self.asm.free)]

    def step(self, n: int) -> State3D:
        """Advance from t_n to t_{n+1} = (n + 1) dt."""
        sys_, st, asm = self.system, self.state, self.asm
        f = asm.free
        nm = self.nm
        t, hist_V, hist_B, fV, fB = self._loads(n)
        (PtV, QtV), (PB, QB) = hist_V, hist_B
        loc = sys_.contact_location(t)
        dq = np.zeros(asm.nV)
        u = st.u.copy()
        P = st.P.copy()
        self.iterations = 0
        converged = Convergence()
        for _ in range(NEWTON_ITERATIONS):
            self.iterations += 1
            q = st.q + dq
            qd, qdd = nm.update_increment(dq, PtV, QtV)
            ud, udd = nm.update(u, PB, QB)
            A = np.zeros((asm.n, asm.n))
            R = np.zeros(asm.n)
            A[: asm.nV, : asm.nV] = self.k_hat_V
            R[: asm.nV] = self.k_hat_V @ dq - fV
            A[asm.oB : asm.oP, asm.oB : asm.oP] = self.k_hat_B
            R[asm.oB : asm.oP] = self.k_hat_B @ u[f] - fB
            for w, (e, xi) in enumerate(loc):
                k = self.kernels[w]
                cols = asm.columns(w, e)
                keep = cols >= 0
                z, zd, zdd = (asm.z(w, e, a, b) for a, b in ((q, u), (qd, ud), (qdd, udd)))
                asm.add_contact(A, R, w, cols, P[2 * w : 2 * w + 2], k.gradient(z, xi), k.hessian(z, xi))
                jac = k.residual_jacobian(z, zd, zdd, xi, nm.a1, nm.a0)
                res = k.residual(z, zd, zdd, xi)
                for s in range(2):
                    row = asm.oP + 2 * w + s
                    A[row, cols[keep]] = jac[s, keep]
                    R[row] = res[s]
            dx = np.linalg.solve(A, -R)
            dq += dx[: asm.nV]
            u[f] += dx[asm.oB : asm.oP]
            P += dx[asm.oP :]
            if converged(np.abs(dx[: asm.oP]).max(), max(np.abs(q).max(), np.abs(u).max())):
                break
        return self._commit(t, dq, u, P, hist_V, hist_B)
