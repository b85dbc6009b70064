"""Initial state: static start and consistent initial accelerations (docs/design.md pitfall 6).

By default a train that starts off the bridge has its vehicles in static equilibrium on rigid, level
track and the bridge at rest in its dead-load state. Newmark never damps an inconsistent initial
acceleration, so after placing the system we solve the equations of motion together with the
acceleration-level constraints once, at t = 0, for consistent accelerations and contact forces.
For the default start (train off the bridge, excitations with smooth onsets) those accelerations
are zero.

``start="static"`` (the scenario's ``train.initial``, and its default "auto" when a wheel is on the
bridge at t = 0) instead puts the whole train-bridge system in static equilibrium: vehicles resting
on the deflected bridge. A held train (speed 0) then stays exactly still, which is the static check
of the test-suite.

The wheelset spin DOFs have no stiffness and no load: they are rigid modes of the static problem,
which is singular. We find such free modes (the null space of ``[K; W^T]``), check that gravity does
no work on them, and hold them at zero with extra constraints; the bordered systems are regular and
solved by LU with one step of iterative refinement.

The full-system problems (static start, consistent accelerations) are assembled as sparse matrices
from their blocks, one car, one span, one contact or one support at a time, and factored by SuperLU:
set-up memory and work grow linearly with cars and spans (a dense matrix of 100 cars on 1000 spans
would take 23 GB). Only one car's bordered block is ever dense.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps

from ...codegen.plain_types import GRAVITY
from ..model.contact_rows import ShapeKernel
from ..model.system import Model, State
from ..model.vehicle_static import free_modes, refined_solve, vehicle_static_on_rigid_track
from .monolithic import Triplets


def resolved_start(model: Model, start: str) -> str:
    """``start`` with "auto" resolved: "static" when a wheel is on the bridge at t = 0 (a train
    standing or running on the bridge rests on it deflected, not dropped onto it unloaded), else
    "rigid-track"."""
    if start != "auto":
        return start
    return "static" if bool(model.contacts(0.0).on.any()) else "rigid-track"


def initial_state(model: Model, start: str = "auto") -> State:
    """The state at t = 0 (see the module docstring); ``start`` is "auto", "rigid-track" or
    "static" (the scenario's ``train.initial``, :func:`resolved_start`)."""
    b, tr = model.bridge, model.train
    q, q1, _ = model.supports(0.0)
    uB = b.quasi_static(q)
    vB = b.quasi_static(q1)
    c = model.contacts(0.0)
    start = resolved_start(model, start)
    (N0,) = ShapeKernel(b.contact_element_length)(c.loc.xi, c.loc.span)
    idx = c.element_dofs()
    rail = np.where(c.on, np.einsum("ij,ij->i", N0, uB[c.loc.span[:, None], idx]), c.q) + c.r

    if tr.moving_load:
        uV = np.zeros((tr.cars, 0))
        P = tr.axle_loads.copy()
    else:
        if start == "static":
            uV, uB, P = static_on_bridge(model)
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


@dataclass(frozen=True)
class Layout:
    """Numbering of the unknowns of the full-system problems, block by block::

        [car displacements | span displacements | contact forces | support reactions | free modes]

    with the equations in the same order (cars, spans, contact rows, support rows, free-mode rows).
    "Spans" are all substructures (spans, then piers); the support rows are the three support slots
    of every substructure (an inactive slot's row is ``R = 0``), then the links.
    """

    cars: int
    spans: int
    nV: int
    """DOFs per car (0 for moving loads)."""
    nd: int
    ns: int
    nc: int
    """Contact forces among the unknowns (0 for moving loads, whose forces are known)."""
    nz: int
    """Free modes held per car."""
    nl: int = 0
    """Links between substructures."""

    @property
    def oB(self) -> int:
        return self.cars * self.nV

    @property
    def oP(self) -> int:
        return self.oB + self.spans * self.nd

    @property
    def oS(self) -> int:
        return self.oP + self.nc

    @property
    def oZ(self) -> int:
        return self.oS + self.spans * self.ns + self.nl

    @property
    def n(self) -> int:
        return self.oZ + self.cars * self.nz


@dataclass(frozen=True)
class LinearSystem:
    """A full-system problem ``A x = rhs`` (``A`` sparse CSC) and the numbering of its unknowns."""

    A: sps.csc_matrix
    rhs: np.ndarray
    layout: Layout

    def solve(self) -> np.ndarray:
        return refined_solve(self.A, self.rhs)


def _layout(model: Model, nV: int, nc: int, nz: int) -> Layout:
    b, tr = model.bridge, model.train
    if b.uniform:
        return Layout(tr.cars, b.spans, nV, b.ndof, b.nsupport, nc, nz)
    return Layout(tr.cars, b.nsub, nV, b.ndof, 3, nc, nz, len(b.links))


def _repeated(
    T: Triplets, row0: int, rstride: int, col0: int, cstride: int, block: np.ndarray, count: int
) -> None:
    """``count`` copies of ``block`` at rows ``row0 + k rstride``, columns ``col0 + k cstride``."""
    r, c = np.nonzero(block)
    k = np.arange(count)[:, None]
    vals = np.broadcast_to(block[r, c], (count, r.size))
    T.add(row0 + rstride * k + r[None, :], col0 + cstride * k + c[None, :], vals)


def _assemble(
    model: Model, lay: Layout, vehicle_block: np.ndarray | None, span_block: str, Z: np.ndarray
) -> sps.csc_matrix:
    """The bordered matrix of the static problem and of the consistent accelerations.

    Sparse, from the blocks (never a dense full-system matrix): per car ``vehicle_block u_V - W P +
    Z mu``, per span ``span_block u_B + N P - E R``; constraint rows ``W^T u_V - N^T u_B`` (the
    wheel on the rail, Eqs. 18 and 20-21 with the aux point on its wheel; without ``N^T u_B`` off
    the bridge), ``E^T u_B`` (the supports, Eqs. 22-24) and ``Z^T u_V``. Every block row touches one car, one
    span or one element, so the entries, and the sparse LU's fill along the track, grow linearly
    with cars and spans.
    """
    b, tr = model.bridge, model.train
    T = Triplets()
    rct = lay.oS + np.arange(lay.spans * lay.ns).reshape(lay.spans, lay.ns)
    if b.uniform:
        _repeated(T, lay.oB, lay.nd, lay.oB, lay.nd, getattr(b, span_block), lay.spans)
        # supports: -E R in the span rows, E^T u_B in the support rows
        sup = lay.oB + lay.nd * np.arange(lay.spans)[:, None] + b.support_dofs[None, :]
        T.add(sup, rct, np.full(sup.shape, -1.0))
        T.add(rct, sup, np.full(sup.shape, 1.0))
    else:
        for k, members in enumerate(b.kind_members):
            block = getattr(b.kinds[k], span_block)
            for s in members:
                T.dense(lay.oB + lay.nd * s, lay.oB + lay.nd * s, block)
        sup = lay.oB + lay.nd * np.arange(lay.spans)[:, None] + b.support_dof
        act = b.support_active
        T.add(sup[act], rct[act], np.full(int(act.sum()), -1.0))
        T.add(rct[act], sup[act], np.full(int(act.sum()), 1.0))
        T.add(rct[~act], rct[~act], np.ones(int((~act).sum())))
        L = b.links
        rl = lay.oS + lay.spans * lay.ns + np.arange(lay.nl)
        ua, ub = (lay.oB + d for d in L.flat_dofs(lay.nd))
        T.add(ua, rl, np.full(lay.nl, -1.0))  # the link force pulls a and b together
        T.add(ub, rl, np.full(lay.nl, 1.0))
        T.add(rl, ua, np.full(lay.nl, 1.0))
        T.add(rl, ub, np.full(lay.nl, -1.0))
        T.add(rl, rl, L.compliance)  # a bearing spring: u_a - u_b + F / k = 0
    if vehicle_block is not None:
        nV, nw = lay.nV, tr.wheels
        _repeated(T, 0, nV, 0, nV, vehicle_block, lay.cars)
        _repeated(T, 0, nV, lay.oZ, lay.nz, Z, lay.cars)
        _repeated(T, lay.oZ, lay.nz, 0, nV, Z.T, lay.cars)
        _repeated(T, 0, nV, lay.oP, nw, -tr.W, lay.cars)  # -W P
        _repeated(T, lay.oP, nw, 0, nV, tr.W.T, lay.cars)  # W^T u_V
        c = model.contacts(0.0)
        (N0,) = ShapeKernel(b.contact_element_length)(c.loc.xi, c.loc.span)
        on = np.flatnonzero(c.on)
        dofs = lay.oB + lay.nd * c.loc.span[on, None] + c.element_dofs()[on]
        cols = np.broadcast_to(lay.oP + on[:, None], dofs.shape)
        T.add(dofs, cols, N0[on])  # + N P on the bridge
        T.add(cols, dofs, -N0[on])  # ... - N^T u_B
    rows, cols_, vals = T.arrays()
    return sps.csc_matrix((vals, (rows, cols_)), shape=(lay.n, lay.n))


def static_system(model: Model) -> LinearSystem:
    """Static equilibrium of the whole system at t = 0: vehicles on the deflected bridge.

    Unknowns: car displacements from static equilibrium on level track, span displacements, contact
    forces, support reactions and the multipliers holding each car's free modes.
    """
    b, tr = model.bridge, model.train
    c = model.contacts(0.0)
    q, _, _ = model.supports(0.0)
    Z = free_modes(tr)
    lay = _layout(model, tr.ndof, tr.contacts, Z.shape[1])
    rhs = np.zeros(lay.n)
    rhs[: lay.oB] = np.tile(tr.F_full, tr.cars)
    rhs[lay.oP : lay.oS] = c.r + np.where(c.on, 0.0, c.q)
    rhs[lay.oS : lay.oS + q.size] = b.held_values(q)
    return LinearSystem(_assemble(model, lay, tr.vehicle.K, "K", Z), rhs, lay)


def static_on_bridge(model: Model) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``uV, uB, P`` of the static equilibrium of the whole system (:func:`static_system`)."""
    system = static_system(model)
    lay, sol = system.layout, system.solve()
    uV = sol[: lay.oB].reshape(lay.cars, lay.nV)
    uB = sol[lay.oB : lay.oP].reshape(lay.spans, lay.nd)
    return uV, uB, sol[lay.oP : lay.oS]


def acceleration_system(
    model: Model, uV: np.ndarray, vV: np.ndarray, uB: np.ndarray, vB: np.ndarray, P: np.ndarray
) -> LinearSystem:
    """The equations of motion at t = 0 with ``g'' = 0`` on every constraint, full wheel masses.

    Unknowns: car and span accelerations, contact forces (none for moving loads, whose ``P`` loads
    the bridge) and support reactions. The contact rows carry the convective terms of the moving
    contact, ``2 v N' u_B' + v^2 N'' u_B`` and ``v^2 r''``.
    """
    b, tr = model.bridge, model.train
    v = model.speed
    c = model.contacts(0.0)
    _, q1, q2 = model.supports(0.0)
    N0, N1, N2 = ShapeKernel(b.contact_element_length, (0, 1, 2))(c.loc.xi, c.loc.span)
    idx = c.element_dofs()
    span = c.loc.span
    nV = 0 if tr.moving_load else tr.ndof
    lay = _layout(model, nV, 0 if tr.moving_load else tr.contacts, 0)
    rhs = np.zeros(lay.n)
    fB = -b.per_kind(vB - b.quasi_static(q1), "C") - b.per_kind(uB, "K")
    if tr.moving_load:
        on = np.flatnonzero(c.on)
        np.add.at(fB, (span[on, None], idx[on]), -N0[on] * P[on, None])
        A = _assemble(model, lay, None, "M", np.zeros((0, 0)))
    else:
        rhs[: lay.oB] = (tr.F_full[None, :] - vV @ tr.vehicle.C.T - uV @ tr.vehicle.K.T).reshape(-1)
        conv = 2 * v * np.einsum("ij,ij->i", N1, vB[span[:, None], idx]) + v * v * np.einsum(
            "ij,ij->i", N2, uB[span[:, None], idx]
        )
        track = v * v * c.r2
        if c.a != 0.0:  # x'' = a at t = 0 (a train that brakes or accelerates from the start)
            conv = conv + c.a * np.einsum("ij,ij->i", N1, uB[span[:, None], idx])
            track = track + c.a * c.r1
        rhs[lay.oP : lay.oS] = track + np.where(c.on, conv, c.q2)
        A = _assemble(model, lay, tr.vehicle.M, "M", np.zeros((nV, 0)))
    rhs[lay.oB : lay.oP] = fB.reshape(-1)
    rhs[lay.oS : lay.oS + q2.size] = b.held_values(q2)
    return LinearSystem(A, rhs, lay)


def consistent_accelerations(
    model: Model, uV: np.ndarray, vV: np.ndarray, uB: np.ndarray, vB: np.ndarray, P: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Accelerations and contact forces at t = 0 from the equations of motion and ``g'' = 0``
    (:func:`acceleration_system`). ``uV`` from static equilibrium. Returns ``aV, aB, P``."""
    tr = model.train
    system = acceleration_system(model, uV, vV, uB, vB, P)
    lay, sol = system.layout, system.solve()
    aV = sol[: lay.oB].reshape(lay.cars, lay.nV)
    aB = sol[lay.oB : lay.oP].reshape(lay.spans, lay.nd)
    if not tr.moving_load:
        P = sol[lay.oP : lay.oS].copy()
    return aV, aB, P
