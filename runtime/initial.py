"""Initial state: static start and consistent initial accelerations (method-notes pitfall 6).

DESIGN.md section 2: the vehicles start in static equilibrium on rigid, level track and the bridge at
rest in its dead-load state. Newmark never damps an inconsistent initial acceleration, so after
placing the system we solve the equations of motion together with the acceleration-level
constraints once, at t = 0, for consistent accelerations and contact forces. For the default start
(train off the bridge, excitations with smooth onsets) those accelerations are zero.

``start="static"`` (Python API) instead puts the whole train-bridge system in static equilibrium:
vehicles resting on the deflected bridge. A held train (speed 0) then stays exactly still, which is
the static check of the test-suite.

The wheelset spin DOFs have no stiffness and no load: they are rigid modes of the static problem,
which is singular. We find such free modes (the null space of ``[K; W^T]``), check that gravity does
no work on them, and hold them at zero with extra constraints; the bordered systems are regular and
solved by LU with one step of iterative refinement.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
from svbi.codegen.plain_types import GRAVITY
from svbi.runtime.model import Model, State
from svbi.runtime.numeric import ShapeKernel
from svbi.runtime.train import Train


class StaticEquilibriumError(RuntimeError):
    """The static problem has no solution (a rigid mode carries a load)."""


def free_modes(train: Train) -> np.ndarray:
    """Vehicle motions with no stiffness and no contact (e.g. wheelset spins), as columns.

    They are rigid modes of the static problem; we hold them at zero, which is only right if gravity
    does no work on them.
    """
    v = train.vehicle
    Z = sla.null_space(np.vstack([v.K, train.W.T]))
    if Z.size and np.abs(Z.T @ v.F_gravity).max() > 1e-9 * max(np.abs(v.F_gravity).max(), 1.0):
        raise StaticEquilibriumError(
            "the vehicle has a free (rigid-body) mode loaded by gravity: "
            "it has no static equilibrium on the track"
        )
    return Z


def _solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """LU solve with one step of iterative refinement (the blocks span ~12 orders of magnitude)."""
    lu = sla.lu_factor(A)
    x = sla.lu_solve(lu, b)
    return x + sla.lu_solve(lu, b - A @ x)


def vehicle_static_on_rigid_track(train: Train, z_track: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Static state of cars with their wheels held at heights ``z_track`` (cars x wheels).

    Full wheel masses (no aux split), gravity only: ``K u - W P = F``, ``W^T u = z``. Returns the car
    displacements (cars x ndof) and the wheel loads P (cars x wheels, compression positive).
    """
    n, nw = train.ndof, train.wheels
    W = train.W
    Z = free_modes(train)
    nz = Z.shape[1]
    A = np.block(
        [
            [train.vehicle.K, -W, Z],
            [W.T, np.zeros((nw, nw + nz))],
            [Z.T, np.zeros((nz, nw + nz))],
        ]
    )
    z_track = np.atleast_2d(np.asarray(z_track, dtype=float))
    cars = z_track.shape[0]
    rhs = np.concatenate(
        [
            np.repeat(train.vehicle.F_gravity[:, None], cars, axis=1),
            z_track.T,
            np.zeros((nz, cars)),
        ],
        axis=0,
    )
    sol = _solve(A, rhs)
    return sol[:n].T.copy(), sol[n : n + nw].T.copy()


def initial_state(model: Model, start: str = "rigid-track") -> State:
    """The state at t = 0 (see the module docstring); ``start`` is "rigid-track" or "static"."""
    b, tr = model.bridge, model.train
    q, q1, _ = model.supports(0.0)
    uB = q @ b.T.T
    vB = q1 @ b.T.T
    c = model.contacts(0.0)
    shapes = ShapeKernel(b.element_length, (0, 1, 2))
    N0, _, _ = shapes(c.loc.xi)
    idx = c.element_dofs()
    rail = np.where(c.on, np.einsum("ij,ij->i", N0, uB[c.loc.span[:, None], idx]), c.q) + c.r

    if tr.moving_load:
        uV = np.zeros((tr.cars, 0))
        P = tr.axle_loads.copy()
    else:
        if start == "static":
            uV, uB, P = _static_on_bridge(model, N0, idx, q)
        else:
            uV, Pc = vehicle_static_on_rigid_track(tr, rail.reshape(tr.cars, tr.wheels))
            P = Pc.reshape(-1)
            uV = uV - tr.u_static[None, :]  # the state holds displacements from static equilibrium
    vV = np.zeros_like(uV)
    aV, aB, P = consistent_accelerations(model, uV, vV, uB, vB, P)
    if tr.moving_load:
        ug = np.zeros(tr.contacts)
        vg = np.zeros(tr.contacts)
        ag = np.zeros(tr.contacts)
        PV = P.copy()
    else:
        ug = (uV @ tr.W).reshape(-1)
        vg = (vV @ tr.W).reshape(-1)
        ag = (aV @ tr.W).reshape(-1)
        m_g = np.tile(tr.aux_masses, tr.cars)
        PV = P - m_g * (ag + GRAVITY)
    state = State(0.0, uV, vV, aV, uB, vB, aB, ug, vg, ag, P, PV)
    creep = model.creep
    if creep is not None:  # the explicit creep force that loads the first step
        state.creepage, state.creep_force = creep.evaluate(state, model.contacts(0.0))
    return state


def _static_on_bridge(model: Model, N0: np.ndarray, idx: np.ndarray, q: np.ndarray):  # noqa: ANN202
    """Static equilibrium of the whole system: vehicles on the deflected bridge (dense, once)."""
    b, tr = model.bridge, model.train
    c = model.contacts(0.0)
    nV, nd, ns = tr.ndof, b.ndof, b.nsupport
    NV, NB = tr.cars * nV, b.spans * nd
    nc, NS = tr.contacts, b.spans * ns
    Z = free_modes(tr)
    nz = Z.shape[1]
    n = NV + NB + nc + NS + tr.cars * nz
    A = np.zeros((n, n))
    rhs = np.zeros(n)
    for k in range(tr.cars):
        sl = slice(k * nV, (k + 1) * nV)
        A[sl, sl] = tr.vehicle.K
        rhs[sl] = tr.F_full  # unknowns: displacements from static equilibrium on level track
        zs = slice(NV + NB + nc + NS + k * nz, NV + NB + nc + NS + (k + 1) * nz)
        A[sl, zs] = Z
        A[zs, sl] = Z.T
    for s in range(b.spans):
        sl = slice(NV + s * nd, NV + (s + 1) * nd)
        A[sl, sl] = b.K
        rows = NV + s * nd + b.support_dofs
        cols = NV + NB + nc + s * ns + np.arange(ns)
        A[rows, cols] = -1.0  # -E R
        A[cols, rows] = 1.0  # E^T u = q
        rhs[cols] = q[s]
    for i in range(nc):
        car, w = divmod(i, tr.wheels)
        col = NV + NB + i
        A[car * nV : (car + 1) * nV, col] = -tr.W[:, w]  # -W P
        A[col, car * nV : (car + 1) * nV] = tr.W[:, w]  # W^T u ...
        rhs[col] = c.r[i]
        if c.on[i]:
            dofs = NV + c.loc.span[i] * nd + idx[i]
            A[dofs, col] += N0[i]  # + N P on the bridge
            A[col, dofs] -= N0[i]  # ... - N^T u_B = r
        else:
            rhs[col] += c.q[i]
    sol = _solve(A, rhs)
    uV = sol[:NV].reshape(tr.cars, nV)
    uB = sol[NV : NV + NB].reshape(b.spans, nd)
    P = sol[NV + NB : NV + NB + nc]
    return uV, uB, P


def consistent_accelerations(
    model: Model, uV: np.ndarray, vV: np.ndarray, uB: np.ndarray, vB: np.ndarray, P: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Accelerations and contact forces at t = 0 from the equations of motion and ``g'' = 0``.

    Full wheel masses (an aux point moves with its wheel); ``uV`` from static equilibrium.
    Returns ``aV, aB, P``.
    """
    b, tr = model.bridge, model.train
    v = model.speed
    c = model.contacts(0.0)
    q, q1, q2 = model.supports(0.0)
    N0, N1, N2 = ShapeKernel(b.element_length, (0, 1, 2))(c.loc.xi)
    idx = c.element_dofs()
    nd, ns = b.ndof, b.nsupport
    NB, NS = b.spans * nd, b.spans * ns
    nV = 0 if tr.moving_load else tr.ndof
    NV = tr.cars * nV
    nc = 0 if tr.moving_load else tr.contacts
    n = NV + NB + nc + NS
    A = np.zeros((n, n))
    rhs = np.zeros(n)
    fB = -(vB - q1 @ b.T.T) @ b.C - uB @ b.K
    for k in range(tr.cars if nV else 0):
        sl = slice(k * nV, (k + 1) * nV)
        A[sl, sl] = tr.vehicle.M
        rhs[sl] = tr.F_full - tr.vehicle.C @ vV[k] - tr.vehicle.K @ uV[k]
    for s in range(b.spans):
        sl = slice(NV + s * nd, NV + (s + 1) * nd)
        A[sl, sl] = b.M
        rhs[sl] = fB[s]
        rows = NV + s * nd + b.support_dofs
        cols = NV + NB + nc + s * ns + np.arange(ns)
        A[rows, cols] = -1.0
        A[cols, rows] = 1.0
        rhs[cols] = q2[s]
    if tr.moving_load:
        for i in np.flatnonzero(c.on):
            rhs[NV + c.loc.span[i] * nd + idx[i]] -= N0[i] * P[i]
    else:
        for i in range(nc):
            car, w = divmod(i, tr.wheels)
            col = NV + NB + i
            A[car * nV : (car + 1) * nV, col] = -tr.W[:, w]
            A[col, car * nV : (car + 1) * nV] = tr.W[:, w]
            rhs[col] = v * v * c.r2[i]
            if c.on[i]:
                dofs = NV + c.loc.span[i] * nd + idx[i]
                s = c.loc.span[i]
                A[dofs, col] += N0[i]
                A[col, dofs] -= N0[i]
                rhs[col] += 2 * v * N1[i] @ vB[s, idx[i]] + v * v * N2[i] @ uB[s, idx[i]]
            else:
                rhs[col] += c.q2[i]
    sol = _solve(A, rhs)
    aV = sol[:NV].reshape(tr.cars, nV)
    aB = sol[NV : NV + NB].reshape(b.spans, nd)
    if not tr.moving_load:
        P = sol[NV + NB : NV + NB + nc].copy()
    return aV, aB, P
