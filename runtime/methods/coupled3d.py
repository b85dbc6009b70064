"""coupled-dynamic in 3D (docs/three-d.md, "The 3D time step").

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
import scipy.sparse as sps
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import connected_components

from ..model.system import newmark_targets, support_hat
from ..model.system3d import GROUND, ContactKernel3D, FlangeCreepKernel3D, System3D
from .newmark import Newmark
from .unilateral import ActiveSet, complementary_solve

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


NORMAL_CONTACT = ("unilateral", "bilateral")
"""The steps' normal contact: ``unilateral`` (lift-off and landing, the default) or ``bilateral``."""
PER_WHEELSET = 4
"""Constraints per wheelset: normal left, normal right, flange left, flange right."""
CREEP_STABILITY = 1.0
"""Largest ``k dt`` of the explicit creep forces (``k`` a wheelset's creep damping rate), as in 2D."""
STATIC_PASSES = 16
"""Flange contact states tried by :func:`static_state` before it gives up."""


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
    flange: np.ndarray | None = None
    """Flange forces, wheelset by wheelset, left then right (N, compression positive; None: 0)."""
    contact: np.ndarray | None = None
    """Which constraints are closed, 4 per wheelset (normal left, right, flange left, right; None:
    the normal contacts closed, the flanges open)."""
    creep: np.ndarray | None = None
    """Creep forces ``[F_x, F_y, M_sp]`` of each contact (wheelsets x 2 x 3, contact frame, on the
    wheel) at ``t``; their loads act in the next step."""
    creep_V: np.ndarray | None = None
    """The creep forces' generalised load on the vehicle DOFs at ``t``."""
    creep_B: np.ndarray | None = None
    """Their load on the span's DOFs (full vector) at ``t``."""

    def forces(self) -> np.ndarray:
        """All constraint forces, 4 per wheelset (normal left, right, flange left, right)."""
        nW = len(self.P) // 2
        flange = np.zeros(2 * nW) if self.flange is None else self.flange
        return np.stack([self.P.reshape(nW, 2), flange.reshape(nW, 2)], axis=1).reshape(-1)


class _Assembly:
    """Indices of the unknowns ``[q_V (nV), u_B free (nF), forces (4 per wheelset)]``."""

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
        self.nC = PER_WHEELSET * self.nW
        self.n = self.oP + self.nC

    def columns(self, w: int, element: int) -> np.ndarray:
        """Unknown of each of the contact's 16 ``z`` entries (-1: a held span DOF or the ground)."""
        ws = self.system.vehicle.wheelsets[w]
        if element == GROUND:
            return np.concatenate([ws.dofs, -np.ones(12, dtype=int)])
        deck = self.full_to_free[self.system.span.element_dofs(element)]
        return np.concatenate([ws.dofs, np.where(deck >= 0, self.oB + deck, -1)])

    def z(
        self, w: int, element: int, q: np.ndarray, u: np.ndarray, ground: np.ndarray | None = None
    ) -> np.ndarray:
        """The contact's ``z`` (or a rate of it): the wheelset's four DOFs and the element's 12, or,
        on the approach track, the ground's rigid "element" (``ground[w]``, of
        :meth:`System3D.ground_under`; None: at rest)."""
        ws = self.system.vehicle.wheelsets[w]
        if element == GROUND:
            deck = np.zeros(12) if ground is None else ground[w]
        else:
            deck = u[self.system.span.element_dofs(element)]
        return np.concatenate([q[ws.dofs], deck])

    def add_forces(
        self, A: np.ndarray, R: np.ndarray, w: int, cols: np.ndarray, lam: np.ndarray, rows: _Rows
    ) -> None:
        """The constraint forces ``lam_k grad g_k`` of wheelset ``w`` in the equilibrium rows
        (residual ``R`` holds ``K x - f``, so the forces enter with ``-``) and their Jacobian."""
        keep = cols >= 0
        c = cols[keep]
        for k in range(PER_WHEELSET):
            R[c] -= lam[k] * rows.grad[k, keep]
            if k < 2:  # the flange gaps are linear: no geometric stiffness
                A[np.ix_(c, c)] -= lam[k] * rows.hess[k][np.ix_(keep, keep)]
            A[c, self.oP + PER_WHEELSET * w + k] -= rows.grad[k, keep]


@dataclass
class _Rows:
    """The four constraints of one wheelset at a state: gradients (4 x 16), Hessians of the normal
    gaps (2 x 16 x 16), the discrete residuals ``E = g'' + c1 g' + c0 g`` and their Jacobians along
    ``z_{n+1}``, and the gaps (normal left, right, flange left, right)."""

    grad: np.ndarray
    hess: np.ndarray
    res: np.ndarray
    jac: np.ndarray
    gap: np.ndarray

    def row(self, k: int, landing: bool) -> tuple[np.ndarray, float]:
        """The row of constraint ``k``: the position-level ``g = 0`` of a landing (closing) contact,
        else the stabilised one."""
        return (self.grad[k], self.gap[k]) if landing else (self.jac[k], self.res[k])


def _kernels(
    system: System3D, speed: float, c1: float, c0: float
) -> list[tuple[ContactKernel3D, FlangeCreepKernel3D]]:
    # each kernel takes the length of the element under its wheelset, set before it is evaluated
    # (_place); the approach track's until then
    le = system.ground_element_length
    out = []
    for w in system.vehicle.wheelsets:
        # one contact kernel per wheelset, its flange and creep included (one irregularity argument)
        k = ContactKernel3D(
            w, system.track, le, speed, c1, c0, flange_clearance=system.track.flange_clearance
        )
        out.append((k, FlangeCreepKernel3D(w, system.track, le, speed, c1, c0, system.creep, contact=k)))
    return out


def _place(
    system: System3D, loc: list, *kernel_sets: list[tuple[ContactKernel3D, FlangeCreepKernel3D]]
) -> None:
    """Set each wheelset's contact kernels (of every set in ``kernel_sets``; the flange and creep
    kernels share them) to the length of the element under it, ``loc`` (the ``(element, xi)`` of
    :meth:`System3D.contact_location`): a deck of spans of different lengths has elements of
    different lengths."""
    for w, (e, _) in enumerate(loc):
        le = system.element_length_at(e)
        for kernels in kernel_sets:
            kernels[w][0].element_length = le


def _rows(
    kernels: tuple[ContactKernel3D, FlangeCreepKernel3D],
    z: np.ndarray,
    zd: np.ndarray,
    zdd: np.ndarray,
    xi: float,
    a1: float,
    a0: float,
    hessian: bool = True,
) -> _Rows:
    k, f = kernels
    grad = np.vstack([k.gradient(z, xi), f.flange_gradient(z, xi)])
    hess = k.hessian(z, xi) if hessian else np.zeros((2, 16, 16))
    res = np.concatenate([k.residual(z, zd, zdd, xi), f.flange_residual(z, zd, zdd, xi)])
    jac = np.vstack(
        [k.residual_jacobian(z, zd, zdd, xi, a1, a0), f.flange_residual_jacobian(z, zd, zdd, xi, a1, a0)]
    )
    gap = np.concatenate([k.gap(z, xi), f.flange_gap(z, xi)])
    return _Rows(grad, hess, res, jac, gap)


def static_state(system: System3D, t: float = 0.0) -> State3D:
    """Static equilibrium of the vehicle on the span (gravity and ``system.load``) with the normal
    gaps closed, by Newton's method; rates and accelerations zero. Gravity alone first: a lateral
    load is held only by the contact forces' geometric stiffness, which needs them loaded. A flange
    whose gap would close is closed (``g_F = 0``, its force ``>= 0``: the flange contact's
    complementarity, solved by trying contact states). Creep forces are those of the state
    (:class:`_Step3D` evaluates them)."""
    asm = _Assembly(system)
    span = system.span
    kernels = _kernels(system, 0.0, 0.0, 0.0)
    q = np.zeros(asm.nV)
    u = np.zeros(span.M.shape[0])
    if system.ground is not None:  # the supports where the ground is at t (exact values)
        u[span.support_dofs] = _support_values(system, t)[0]
    lam = np.zeros(asm.nC)
    closed = np.tile([True, True, False, False], asm.nW)
    loads = [system.vehicle.F, system.vehicle_load()] if system.load is not None else [system.vehicle.F]
    for f in loads:
        for _ in range(STATIC_PASSES):
            gaps = _static_newton(system, asm, kernels, t, f, q, u, lam, closed)
            flip = (closed & (lam < 0.0)) | (~closed & (gaps < 0.0))
            flip[0::4] = flip[1::4] = False  # the normal contacts stay closed
            if not flip.any():
                break
            closed ^= flip
        else:
            raise RuntimeError(f"the static flange contact did not settle in {STATIC_PASSES} passes")
    z0 = np.zeros_like
    nW = asm.nW
    normal, flange = lam.reshape(nW, 4)[:, :2].reshape(-1), lam.reshape(nW, 4)[:, 2:].reshape(-1)
    return State3D(t, q, z0(q), z0(q), u, z0(u), z0(u), normal.copy(), flange.copy(), closed.copy())


def _static_newton(
    system: System3D,
    asm: _Assembly,
    kernels: list[tuple[ContactKernel3D, FlangeCreepKernel3D]],
    t: float,
    f: np.ndarray,
    q: np.ndarray,
    u: np.ndarray,
    lam: np.ndarray,
    closed: np.ndarray,
) -> np.ndarray:
    """Newton's method on the static equations from ``(q, u, lam)`` (updated in place) with the
    ``closed`` constraints at ``g = 0`` and the others free of force; returns the gaps."""
    veh, span = system.vehicle, system.span
    loc = system.contact_location(t)
    _place(system, loc, kernels)
    KB = span.K[np.ix_(asm.free, asm.free)]
    held = None
    if system.ground is not None:  # the supports' static load on the free DOFs
        s = span.support_dofs
        held = span.K[np.ix_(asm.free, s)] @ u[s]
    ground = system.ground_under(t)[0]
    lam[~closed] = 0.0
    converged = Convergence()
    zero = np.zeros(16)
    # the matrix is sparse (the vehicle's and the span's stiffness, 16 columns per contact): its
    # constant blocks once as triplets, the contacts' entries per iteration, one sparse LU each
    KV, KBs = sps.coo_matrix(veh.K), sps.coo_matrix(KB)
    fixed_r = np.concatenate([KV.row, asm.oB + KBs.row])
    fixed_c = np.concatenate([KV.col, asm.oB + KBs.col])
    fixed_v = np.concatenate([KV.data, KBs.data])
    for _ in range(NEWTON_ITERATIONS):
        ar: list[np.ndarray] = [fixed_r]
        ac: list[np.ndarray] = [fixed_c]
        av: list[np.ndarray] = [fixed_v]
        R = np.zeros(asm.n)
        R[: asm.nV] = veh.K @ q - f
        R[asm.oB : asm.oP] = KB @ u[asm.free]
        if held is not None:
            R[asm.oB : asm.oP] += held
        gaps = np.zeros(asm.nC)
        for w, (e, xi) in enumerate(loc):
            cols = asm.columns(w, e)
            keep = cols >= 0
            c = cols[keep]
            z = asm.z(w, e, q, u, ground)
            rows = _rows(kernels[w], z, zero, zero, xi, 0.0, 0.0)
            r = slice(PER_WHEELSET * w, PER_WHEELSET * (w + 1))
            lw = lam[r]
            g = rows.grad[:, keep]
            # the constraint forces lam_k grad g_k (residual K x - f: they enter with -), the
            # normal gaps' geometric stiffness, and the forces' columns (_Assembly.add_forces)
            R[c] -= lw @ g
            h = -(lw[0] * rows.hess[0] + lw[1] * rows.hess[1])[np.ix_(keep, keep)]
            ar.append(np.repeat(c, c.size))
            ac.append(np.tile(c, c.size))
            av.append(h.ravel())
            force_cols = asm.oP + PER_WHEELSET * w + np.arange(PER_WHEELSET)
            ar.append(np.tile(c, PER_WHEELSET))
            ac.append(np.repeat(force_cols, c.size))
            av.append(-g.ravel())
            gaps[r] = rows.gap
            for k in range(PER_WHEELSET):
                i = PER_WHEELSET * w + k
                row = asm.oP + i
                if closed[i]:
                    ar.append(np.full(c.size, row))
                    ac.append(c)
                    av.append(g[k])
                    R[row] = rows.gap[k]
                else:
                    ar.append(np.array([row]))
                    ac.append(np.array([row]))
                    av.append(np.array([1.0]))
                    R[row] = lam[i]
        A = sps.csc_matrix(
            (np.concatenate(av), (np.concatenate(ar), np.concatenate(ac))), shape=(asm.n, asm.n)
        )
        try:
            dx = spla.splu(A).solve(-R)
        except RuntimeError:  # exactly singular: a DOF without static stiffness (a lone wheelset's
            # yaw), which the dense LU's round-off pivot leaves where it is, as before
            dx = np.linalg.solve(A.toarray(), -R)
        q += dx[: asm.nV]
        u[asm.free] += dx[asm.oB : asm.oP]
        lam += dx[asm.oP :]
        lam[~closed] = 0.0  # the open constraints' rows, lam = 0: exact, not to the solve's round-off
        if converged(np.abs(dx[: asm.oP]).max(), max(np.abs(q).max(), np.abs(u).max())):
            for w, (e, xi) in enumerate(loc):
                z = asm.z(w, e, q, u, ground)
                k, fk = kernels[w]
                gaps[PER_WHEELSET * w : PER_WHEELSET * (w + 1)] = [*k.gap(z, xi), *fk.flange_gap(z, xi)]
            return gaps
    raise RuntimeError(f"the static state did not converge in {NEWTON_ITERATIONS} Newton iterations")


def _support_values(system: System3D, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(q, q', q'')`` of every support of the deck (``span.supports``) at ``t``: the ground's
    ``(x, y, z)`` motion at every support line, taken by ``span.support_motion``."""
    span = system.span
    lines = system.ground_motion(t, np.asarray(span.line_x, dtype=float))
    return tuple(span.support_motion(m) for m in lines)  # type: ignore[return-value]


def block_inverse(a: np.ndarray) -> np.ndarray:
    """The dense inverse of ``a`` from the inverses of its decoupled blocks: the connected
    components of its sparsity graph (a 3D vehicle's mass or stiffness splits into its cars, a deck
    of simply supported spans into its spans and their decoupled axial, lateral, vertical and
    torsional fields). The same inverse as ``np.linalg.inv(a)`` (its entries between blocks are
    zero), to round-off, at the cost of the blocks."""
    a = np.asarray(a, dtype=float)
    n = a.shape[0]
    count, label = connected_components(sps.csr_matrix(a != 0.0), directed=False)
    if count <= 1:
        return np.linalg.inv(a)
    out = np.zeros((n, n))
    order = np.argsort(label, kind="stable")
    bounds = np.searchsorted(label[order], np.arange(count + 1))
    for b in range(count):
        idx = order[bounds[b] : bounds[b + 1]]
        ix = np.ix_(idx, idx)
        out[ix] = np.linalg.inv(a[ix])
    return out


class _Step3D:
    """What both 3D steps share: the Newmark set-up, the contact kernels, the histories and loads
    of a step (the creep loads of t_n included), the contact state (an LCP over every normal and
    flange contact, :class:`svbi.runtime.methods.unilateral.ActiveSet`), the plastic impact of a
    landing or a flange closing, the commit of a step and the gaps."""

    def __init__(
        self,
        system: System3D,
        state: State3D,
        time_step: float,
        kappa: float = 1.0,
        zeta: float = 1.0,
        normal: str = "unilateral",
    ) -> None:
        if normal not in NORMAL_CONTACT:
            raise ValueError(f"normal contact must be one of {NORMAL_CONTACT}, got {normal!r}")
        self.system = system
        self.state = state
        self.dt = time_step
        self.nm = Newmark(time_step)
        omega = kappa / time_step
        self.asm = _Assembly(system)
        span, veh = system.span, system.vehicle
        self.c1, self.c0 = 2 * zeta * omega, omega * omega
        self.pairs = _kernels(system, system.speed, self.c1, self.c0)
        self.kernels = [k for k, _ in self.pairs]
        # g'' (c1 = c0 = 0) and g'' + g' (c1 = 1): the gap rates of the impact
        self.rates_tt = _kernels(system, system.speed, 0.0, 0.0)
        self.rates_t = _kernels(system, system.speed, 1.0, 0.0)
        self.CB = np.zeros_like(span.M) if system.bridge_damping is None else system.bridge_damping
        self.bilateral = normal == "bilateral"
        self.scale = self.nm.a0 + self.c1 * self.nm.a1 + self.c0
        """``dE/dg_{n+1}``: a stabilised residual over this is a gap (m)."""
        f = self.asm.free
        self.MV_inv = block_inverse(veh.M)
        self.MB_inv = block_inverse(span.M[np.ix_(f, f)])
        nW, nC = self.asm.nW, self.asm.nC
        if state.flange is None:
            state.flange = np.zeros(2 * nW)
        if state.contact is None:
            state.contact = np.tile([True, True, False, False], nW)
        self.active = ActiveSet(nC)
        self.active.in_contact[:] = state.contact
        self.quake = system.ground is not None
        """Whether the supports move (the ground motion of ``system.ground``)."""
        self._hat: dict[int, np.ndarray] = {}
        self.next_support: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        if self.quake:
            s = span.support_dofs
            self.held = s
            k_hat = self.nm.effective(span.K, self.CB, span.M)
            self.k_hat_fs = k_hat[np.ix_(f, s)]
            self.CT = (self.CB @ span.T)[f]
            Q = self.support_targets(state.t)
            for a, v in zip((state.u, state.ud, state.udd), Q, strict=True):
                a[s] = v
        if system.creep is not None:
            self._check_creep_stability()
        if state.creep is None:
            self._creep(state)
        self.iterations = 0
        self.passes = 0

    def set_irregularity(self, level: np.ndarray) -> None:
        """The rail's irregularity argument under each wheelset (``(wheelsets, 9)``: ``[r_v, r_a,
        r_c]``, their slopes and curvatures) for every kernel of the step: the rows, the flange and
        creep (which share each wheelset's contact kernel) and the impact's gap rates."""
        for w, r in enumerate(np.asarray(level, dtype=float)):
            for kernel in (self.pairs[w][0], self.rates_tt[w][0], self.rates_t[w][0]):
                kernel.irregularity = r

    def _located(self, t: float) -> list[tuple[int, float]]:
        """``(element, xi)`` under each wheelset at ``t`` (:meth:`System3D.contact_location`), every
        kernel of the step (rows, flange and creep, the impact's gap rates) set to the length of
        its wheelset's element."""
        loc = self.system.contact_location(t)
        _place(self.system, loc, self.pairs, self.rates_tt, self.rates_t)
        return loc

    def _check_creep_stability(self) -> None:
        """Refuse a time step at which the explicit creep forces would be unstable. Lagged by one
        step, the creep force of a wheelset is a damper of rate ``k`` (lateral ``2 f22 / (m v)``,
        yaw ``2 f11 b^2 / (I_z v)`` under the state's wheel loads), and Newmark's average
        acceleration with a one-step lag is stable for ``k dt < 2``: as in 2D (docs/method.md
        section 3b), ``k dt`` must stay below :data:`CREEP_STABILITY`."""
        sys_, st = self.system, self.state
        veh = sys_.vehicle
        if sys_.speed <= 0.0:
            return
        for w, ws in enumerate(veh.wheelsets):
            load = max(float(np.mean(st.P[2 * w : 2 * w + 2])), 0.0)
            if load <= 0.0:
                continue
            f11, f22, _ = self.pairs[w][1].coefficients(load)
            y, psi = ws.dofs[0], ws.dofs[3]
            rates = {
                "lateral": 2 * f22 / (veh.M[y, y] * sys_.speed),
                "yaw": 2 * f11 * ws.half_gauge**2 / (veh.M[psi, psi] * sys_.speed),
            }
            for what, k in rates.items():
                if k * self.dt > CREEP_STABILITY:
                    raise ValueError(
                        f"the explicit creep forces of wheelset {ws.name!r} are unstable at "
                        f"dt = {self.dt:g} s "
                        f"({what} creep damping rate {k:.4g} 1/s, k dt = {k * self.dt:.3g} > "
                        f"{CREEP_STABILITY:g}): take dt <= {CREEP_STABILITY / k:.3g} s"
                    )

    # ----------------------------------------------------------------------------------------------
    def _loads(self, n: int) -> tuple[float, tuple, tuple, np.ndarray, np.ndarray]:
        """t_{n+1}, the vehicle's and the span's Newmark histories, and their effective loads (the
        creep loads of t_n included: explicit)."""
        sys_, st, nm = self.system, self.state, self.nm
        veh, span = sys_.vehicle, sys_.span
        PtV, QtV = nm.increment_history(st.qd, st.qdd)
        fV = sys_.vehicle_load() - veh.K @ st.q + veh.M @ PtV + veh.C @ QtV + st.creep_V
        PB, QB = nm.history(st.u, st.ud, st.udd)
        fB = (span.M @ PB + self.CB @ QB + st.creep_B)[self.asm.free]
        t = (n + 1) * self.dt
        if self.quake:
            # the supports at their targets of t_{n+1}: their share of the effective load moves to
            # the right-hand side, and the damping acts on the motion relative to the ground
            Q = self.next_support = self.support_targets(t)
            fB = fB - self.k_hat_fs @ Q[0] + self.CT @ Q[1]
        return t, (PtV, QtV), (PB, QB), fV, fB

    def support_targets(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Newmark-consistent targets ``(Q, Q', Q'')`` of every support at ``t`` (a step time), as
        the 2D supports' (:func:`svbi.runtime.model.system.newmark_targets` of ``h = q - dt^2/4
        q''`` at ``t - dt``, ``t``, ``t + dt``; docs/method.md, "Support targets")."""
        dt = self.dt
        n = round(t / dt)
        for k in (n - 1, n, n + 1):
            if k not in self._hat:
                q, _, q2 = _support_values(self.system, k * dt)
                self._hat[k] = support_hat(q, q2, dt)
        for k in [k for k in self._hat if abs(k - n) > 1]:
            del self._hat[k]
        return newmark_targets(self._hat[n - 1], self._hat[n], self._hat[n + 1], dt)

    def _hold(self, u: np.ndarray) -> np.ndarray:
        """``u`` (full vector, in place) with the supports at their targets of the step."""
        if self.next_support is not None:
            u[self.held] = self.next_support[0]
        return u

    def _span_rates(self, u: np.ndarray, PB: np.ndarray, QB: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The span's Newmark rates at t_{n+1}; the supports' are their targets' (the same values in
        exact arithmetic: the targets satisfy Newmark's relations)."""
        ud, udd = self.nm.update(u, PB, QB)
        if self.next_support is not None:
            ud[self.held] = self.next_support[1]
            udd[self.held] = self.next_support[2]
        return ud, udd

    def _creep(self, st: State3D) -> None:
        """The creep forces at the state's time and their loads (zero where a wheel is off its rail
        or carries no load; all zero without ``system.creep``)."""
        asm = self.asm
        st.creep = np.zeros((asm.nW, 2, 3))
        st.creep_V = np.zeros(asm.nV)
        st.creep_B = np.zeros_like(st.u)
        if self.system.creep is None:
            return
        loc = self._located(st.t)
        g, g1, _ = self.system.ground_under(st.t)
        closed = st.contact.reshape(asm.nW, PER_WHEELSET)[:, :2]
        for w, (e, xi) in enumerate(loc):
            z, zd = asm.z(w, e, st.q, st.u, g), asm.z(w, e, st.qd, st.ud, g1)
            load = np.where(closed[w], st.P[2 * w : 2 * w + 2], 0.0)
            forces, gen = self.pairs[w][1].creep(z, zd, xi, load)
            st.creep[w] = forces
            ws = self.system.vehicle.wheelsets[w]
            st.creep_V[ws.dofs] += gen[:4]
            if e != GROUND:  # the rigid approach track takes its creep forces
                np.add.at(st.creep_B, self.system.span.element_dofs(e), gen[4:])

    def _rows_at(
        self,
        t: float,
        loc: list,
        q: np.ndarray,
        qd: np.ndarray,
        qdd: np.ndarray,
        u: np.ndarray,
        ud: np.ndarray,
        udd: np.ndarray,
        hessian: bool,
    ) -> list[_Rows]:
        asm, nm = self.asm, self.nm
        ground = self.system.ground_under(t)
        out = []
        for w, (e, xi) in enumerate(loc):
            z, zd, zdd = (
                asm.z(w, e, a, b, g) for a, b, g in zip((q, qd, qdd), (u, ud, udd), ground, strict=True)
            )
            out.append(_rows(self.pairs[w], z, zd, zdd, xi, nm.a1, nm.a0, hessian))
        return out

    def _solve(
        self, t: float, loc: list, hist_V: tuple, hist_B: tuple, fV: np.ndarray, fB: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The step with the current contact state: ``(dq, u, forces)``."""
        raise NotImplementedError

    def step(self, n: int) -> State3D:
        """Advance from t_n to t_{n+1} = (n + 1) dt."""
        st, act = self.state, self.active
        t, hist_V, hist_B, fV, fB = self._loads(n)
        loc = self._located(t)
        (PtV, QtV), (PB, QB) = hist_V, hist_B
        start = st.forces()
        act.begin()
        self.iterations = self.passes = 0
        while True:
            self.passes += 1
            dq, u, lam = self._solve(t, loc, hist_V, hist_B, fV, fB)
            q = st.q + dq
            qd, qdd = self.nm.update_increment(dq, PtV, QtV)
            ud, udd = self._span_rates(u, PB, QB)
            rows = self._rows_at(t, loc, q, qd, qdd, u, ud, udd, hessian=False)
            stabilised = np.concatenate([r.res for r in rows]) / self.scale
            uplift = np.concatenate([r.gap for r in rows])
            force = lam.copy()
            if self.bilateral:  # the normal contacts hold whatever their force
                force[0::4] = force[1::4] = np.abs(force[0::4]) + 1.0
            if not act.update(force, act.gap(stabilised, uplift), t):
                break
        new = self._commit(t, dq, u, lam, hist_V, hist_B)
        dropped = self._impact(new, loc, start) if act.landing.any() else None
        act.finish(dropped)
        new.contact = act.in_contact.copy()
        self._creep(new)
        return new

    # ----------------------------------------------------------------------------------------------
    def _directions(self, rows: list[_Rows], loc: list) -> tuple[np.ndarray, np.ndarray]:
        """``G_V`` (nC x nV) and ``G_B`` (nC x nF): the constraint forces' directions."""
        asm = self.asm
        GV = np.zeros((asm.nC, asm.nV))
        GB = np.zeros((asm.nC, asm.nF))
        for w, (e, _) in enumerate(loc):
            cols = asm.columns(w, e)
            veh_cols, deck = cols[:4], cols[4:]
            on = deck >= 0
            r = slice(PER_WHEELSET * w, PER_WHEELSET * (w + 1))
            GV[r, veh_cols] = rows[w].grad[:, :4]
            GB[r, deck[on] - asm.oB] = rows[w].grad[:, 4:][:, on]
        return GV, GB

    def _gap_rates(self, st: State3D, loc: list) -> tuple[np.ndarray, np.ndarray]:
        """``g'`` and ``g''`` of every constraint at the state (exact, convective terms included)."""
        asm = self.asm
        gt, gtt = np.zeros(asm.nC), np.zeros(asm.nC)
        ground = self.system.ground_under(st.t)
        for w, (e, xi) in enumerate(loc):
            z, zd, zdd = (
                asm.z(w, e, a, b, g)
                for a, b, g in zip((st.q, st.qd, st.qdd), (st.u, st.ud, st.udd), ground, strict=True)
            )
            r = slice(PER_WHEELSET * w, PER_WHEELSET * (w + 1))
            k0, f0 = self.rates_tt[w]
            k1, f1 = self.rates_t[w]
            tt = np.concatenate([k0.residual(z, zd, zdd, xi), f0.flange_residual(z, zd, zdd, xi)])
            t1 = np.concatenate([k1.residual(z, zd, zdd, xi), f1.flange_residual(z, zd, zdd, xi)])
            gtt[r], gt[r] = tt, t1 - tt
        return gt, gtt

    def _impact(self, st: State3D, loc: list, start: np.ndarray) -> np.ndarray:
        """Perfectly plastic impact of the landing (closing) contacts at t_{n+1}, as in 2D
        (docs/method.md section 12, step 4): impulses ``>= 0`` over the closed contacts with the mass
        flexibility ``G M^-1 G^T`` that stop the landing ones (relative normal velocity zero), then
        the force jump that makes the accelerations consistent (``g'' = 0`` for the landing ones,
        unchanged for the others), forces ``>= 0``. Returns the contacts let go."""
        act, f = self.active, self.asm.free
        rows = self._rows_at(st.t, loc, st.q, st.qd, st.qdd, st.u, st.ud, st.udd, hessian=False)
        GV, GB = self._directions(rows, loc)
        AV, AB = self.MV_inv @ GV.T, self.MB_inv @ GB.T
        G = GV @ AV + GB @ AB
        active, landing = act.active.copy(), act.landing.copy()
        lam = st.forces()
        gt, gtt = self._gap_rates(st, loc)
        step_impulse = np.where(active, 0.5 * self.dt * (start + lam), 0.0)
        impulse, on_rail = complementary_solve(
            G, np.where(landing, -gt, 0.0), step_impulse, active, st.t, "landing impulse"
        )
        dqd, dud = AV @ impulse, AB @ impulse
        st.qd = st.qd + dqd
        st.ud = st.ud.copy()
        st.ud[f] += dud
        st.qdd = st.qdd - self.MV_inv @ (self.system.vehicle.C @ dqd)
        st.udd = st.udd.copy()
        st.udd[f] -= self.MB_inv @ (self.CB[np.ix_(f, f)] @ dud)
        _, gtt_new = self._gap_rates(st, loc)
        want = np.where(landing, -gtt_new, -(gtt_new - gtt))
        jump, held = complementary_solve(G, want, lam, on_rail, st.t, "force after a landing")
        st.qdd = st.qdd + AV @ jump
        st.udd[f] += AB @ jump
        lam = np.where(held, lam + jump, 0.0)
        self._set_forces(st, lam)
        return active & ~held

    def _set_forces(self, st: State3D, lam: np.ndarray) -> None:
        per = lam.reshape(self.asm.nW, PER_WHEELSET)
        st.P = per[:, :2].reshape(-1).copy()
        st.flange = per[:, 2:].reshape(-1).copy()

    def _commit(
        self, t: float, dq: np.ndarray, u: np.ndarray, lam: np.ndarray, hist_V: tuple, hist_B: tuple
    ) -> State3D:
        """The state at t_{n+1} from the vehicle's increment, the span's displacements and the
        constraint forces."""
        st, nm = self.state, self.nm
        st.qd, st.qdd = nm.update_increment(dq, *hist_V)
        st.q = st.q + dq
        st.ud, st.udd = self._span_rates(u, *hist_B)
        st.u = u
        self._set_forces(st, lam)
        st.t = t
        return st

    def gaps(self) -> np.ndarray:
        """Normal gaps of every contact at the state's time (m), wheelset by wheelset."""
        st, asm = self.state, self.asm
        ground = self.system.ground_under(st.t)[0]
        out = []
        for w, (e, xi) in enumerate(self._located(st.t)):
            out.extend(self.kernels[w].gap(asm.z(w, e, st.q, st.u, ground), xi))
        return np.array(out)

    def flange_gaps(self) -> np.ndarray:
        """Flange gaps of every wheelset at the state's time (m), left then right."""
        st, asm = self.state, self.asm
        ground = self.system.ground_under(st.t)[0]
        out = []
        for w, (e, xi) in enumerate(self._located(st.t)):
            out.extend(self.pairs[w][1].flange_gap(asm.z(w, e, st.q, st.u, ground), xi))
        return np.array(out)


class CoupledDynamic3D(_Step3D):
    """The monolithic 3D step; see the module docstring."""

    name = "coupled-dynamic-3d"

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
        veh, span, nm = system.vehicle, system.span, self.nm
        self.k_hat_V = nm.effective(veh.K, veh.C, veh.M)
        self.k_hat_B = nm.effective(span.K, self.CB, span.M)[np.ix_(self.asm.free, self.asm.free)]

    def _solve(
        self, t: float, loc: list, hist_V: tuple, hist_B: tuple, fV: np.ndarray, fB: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        st, asm, act = self.state, self.asm, self.active
        f = asm.free
        nm = self.nm
        (PtV, QtV), (PB, QB) = hist_V, hist_B
        dq = np.zeros(asm.nV)
        u = self._hold(st.u.copy())
        lam = np.where(act.active, st.forces(), 0.0)
        converged = Convergence()
        for _ in range(NEWTON_ITERATIONS):
            self.iterations += 1
            q = st.q + dq
            qd, qdd = nm.update_increment(dq, PtV, QtV)
            ud, udd = self._span_rates(u, PB, QB)
            A = np.zeros((asm.n, asm.n))
            R = np.zeros(asm.n)
            A[: asm.nV, : asm.nV] = self.k_hat_V
            R[: asm.nV] = self.k_hat_V @ dq - fV
            A[asm.oB : asm.oP, asm.oB : asm.oP] = self.k_hat_B
            R[asm.oB : asm.oP] = self.k_hat_B @ u[f] - fB
            rows = self._rows_at(t, loc, q, qd, qdd, u, ud, udd, hessian=True)
            for w, (e, _) in enumerate(loc):
                cols = asm.columns(w, e)
                keep = cols >= 0
                asm.add_forces(A, R, w, cols, lam[PER_WHEELSET * w : PER_WHEELSET * (w + 1)], rows[w])
                for k in range(PER_WHEELSET):
                    i = PER_WHEELSET * w + k
                    row = asm.oP + i
                    if act.active[i]:
                        jac, res = rows[w].row(k, bool(act.landing[i]))
                        A[row, cols[keep]] = jac[keep]
                        R[row] = res
                    else:
                        A[row, row] = 1.0
                        R[row] = lam[i]
            dx = np.linalg.solve(A, -R)
            dq += dx[: asm.nV]
            u[f] += dx[asm.oB : asm.oP]
            lam += dx[asm.oP :]
            if converged(np.abs(dx[: asm.oP]).max(), max(np.abs(q).max(), np.abs(u).max())):
                break
        return dq, u, lam
