"""What the two monolithic methods share (coupled-dynamic, coupled-classic; paper Eq. 36).

Both solve one sparse system per step whose unknowns start with the vehicle DOFs and the bridge
DOFs of every span, ``[u_V, u_B, ...]``, followed by their own multiplier unknowns. This module
holds the parts that do not depend on how the constraints are imposed: the layout of those first
unknowns, the bridge's Newmark histories and support targets at t_{n+1}, the constant bridge
blocks with their support rows, where each contact's element sits in the unknowns, and the final
Newmark update of the bridge. The steppers add their own rows (dynamic or classic multipliers).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from ..model.contact_rows import ContactRowKernel, point_row, support_constraint_masses
from ..model.system import Contacts, Model, State
from .newmark import Newmark


class Triplets:
    """COO entries of a sparse matrix, collected from blocks."""

    def __init__(self) -> None:
        self.rows: list[np.ndarray] = []
        self.cols: list[np.ndarray] = []
        self.vals: list[np.ndarray] = []

    def dense(self, r0: int, c0: int, block: np.ndarray) -> None:
        nz = np.nonzero(block)
        self.add(nz[0] + r0, nz[1] + c0, block[nz])

    def add(self, r: np.ndarray, c: np.ndarray, v: np.ndarray) -> None:
        self.rows.append(np.asarray(r, dtype=np.intp).ravel())
        self.cols.append(np.asarray(c, dtype=np.intp).ravel())
        self.vals.append(np.asarray(v, dtype=float).ravel())

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if not self.rows:
            e = np.zeros(0)
            return e.astype(np.intp), e.astype(np.intp), e
        return np.concatenate(self.rows), np.concatenate(self.cols), np.concatenate(self.vals)


def solve_sparse(
    const: tuple[np.ndarray, np.ndarray, np.ndarray], step: Triplets, n: int, rhs: np.ndarray
) -> np.ndarray:
    """Assemble constant + per-step entries into CSC and solve with a sparse LU (SuperLU).

    The entries are unique by construction, so we sort them into CSC ourselves (scipy's COO
    conversion, which also sums duplicates, costs more than the factorisation on small systems).
    """
    r1, c1, v1 = const
    r2, c2, v2 = step.arrays()
    rows = np.concatenate([r1, r2])
    cols = np.concatenate([c1, c2])
    vals = np.concatenate([v1, v2])
    key = cols * n + rows
    order = np.argsort(key)
    if np.any(np.diff(key[order]) == 0):  # pragma: no cover - a duplicate slipped in: sum it
        A = sps.csc_matrix((vals, (rows, cols)), shape=(n, n))
    else:
        indptr = np.zeros(n + 1, dtype=np.int32)
        np.cumsum(np.bincount(cols, minlength=n), out=indptr[1:])
        A = sps.csc_matrix((n, n))
        A.data, A.indices, A.indptr = vals[order], rows[order].astype(np.int32), indptr
        A.has_sorted_indices = True
    return spla.splu(A).solve(rhs)


@dataclass
class BridgeStep:
    """The bridge's part of one step: Newmark histories, support targets and load vector."""

    PB: np.ndarray
    QB: np.ndarray
    q_hat: np.ndarray
    """Support targets of the discrete support rows (point row of ``svbi.codegen.constraints``)."""
    fB: np.ndarray
    """Right-hand side of the bridge rows, spans x span DOFs: ``M P + C Q + C T q'``."""


@dataclass
class ContactDofs:
    """Where each contact's element is: on the bridge or not, and its global bridge unknowns."""

    on: np.ndarray
    sel: np.ndarray
    """Indices of the contacts on the bridge."""
    span: np.ndarray
    idx: np.ndarray
    """Span-local DOFs of the element under each contact (contacts x 6)."""
    gdofs: np.ndarray
    """Global unknowns of those DOFs (contacts x 6)."""


class Monolithic:
    """Base of the monolithic steppers: unknowns ``[u_V (cars x nV), u_B (spans x nd), ...]``."""

    def _layout(self, model: Model, state: State, kappa: float, zeta: float) -> None:
        """Sizes and offsets of the vehicle and bridge unknowns, the Newmark coefficients, the point
        and contact rows (``kappa = zeta = 0``: classic multipliers) and the support masses."""
        self.model = model
        self.state = state
        s = model.settings
        b, tr = model.bridge, model.train
        self.nm = Newmark(s.time_step)
        self.point = point_row(s.time_step, kappa, zeta)
        self.rows = ContactRowKernel(
            b.contact_element_length, model.speed, s.time_step, kappa, zeta, model.accelerating
        )
        self.moving_load = tr.moving_load
        self.nV = 0 if self.moving_load else tr.ndof
        self.NV = tr.cars * self.nV
        self.NB = b.nsub * b.ndof
        self.nc = 0 if self.moving_load else tr.contacts
        self.oB = self.NV
        subs = np.repeat(np.arange(b.nsub), 3)
        if b.uniform:
            self.NS = b.spans * b.nsupport
            self.support_masses = self._dof_mass(subs, np.tile(b.support_dofs, b.spans))
            """Eq. (34): the constraint mass of every support constraint, span by span."""
        else:  # three support slots per substructure (inactive ones hold a zero unknown), then links
            self.NS = 3 * b.nsub + len(b.links)
            L = b.links
            ma, mb = self._dof_mass(L.a_sub, L.a_dof), self._dof_mass(L.b_sub, L.b_dof)
            # a link: the reduced mass of its two ends, the dynamic multiplier's scale
            self.support_masses = np.concatenate(
                [self._dof_mass(subs, b.support_dof.ravel()), ma * mb / (ma + mb)]
            )
        self.contacts: Contacts | None = None

    def _dof_mass(self, sub: np.ndarray, dof: np.ndarray) -> np.ndarray:
        """Eq. (34) for a constraint on one substructure DOF (an end node's): the consistent mass
        of the element at that DOF (a pier column's global u is its element's transverse DOF, w
        its axial)."""
        b = self.model.bridge
        per_kind = [
            support_constraint_masses(k.element_length, k.section.mass_per_length, list(range(6)))
            for k in b.kinds
        ]
        node, comp = np.divmod(np.asarray(dof, dtype=np.intp), 3)
        pier = np.array([b.kinds[k].pier for k in b.kind[sub]], dtype=bool)
        comp = np.where(pier, np.array([1, 0, 2])[comp], comp)
        local = np.where(node == 0, comp, 3 + comp)
        return np.array([per_kind[k][j] for k, j in zip(b.kind[sub], local, strict=True)], dtype=float)

    def _bridge_blocks(self, T: Triplets, support_col: int, coupling: np.ndarray) -> None:
        """The effective bridge matrix of every span, with its support constraints: column
        ``support_col + k`` of constraint k enters the bridge rows with ``-coupling[k]`` and its
        own row with ``+coupling[k]`` on the support DOF."""
        b = self.model.bridge
        nd = b.ndof
        if b.uniform:
            k_hat_B = self.nm.effective(b.K, b.C, b.M)
            ns = b.nsupport
            for s in range(b.spans):
                o = self.oB + s * nd
                T.dense(o, o, k_hat_B)
                rows = o + b.support_dofs
                cols = support_col + s * ns + np.arange(ns)
                T.add(rows, cols, -coupling[s * ns : (s + 1) * ns])
                T.add(cols, rows, coupling[s * ns : (s + 1) * ns])
            return
        for k, members in enumerate(b.kind_members):
            kind = b.kinds[k]
            k_hat = self.nm.effective(kind.K, kind.C, kind.M)
            for s in members:
                T.dense(self.oB + s * nd, self.oB + s * nd, k_hat)
        act = b.support_active.ravel()
        rows = (self.oB + nd * np.arange(b.nsub)[:, None] + b.support_dof).ravel()
        cols = support_col + np.arange(3 * b.nsub)
        T.add(rows[act], cols[act], -coupling[: 3 * b.nsub][act])
        T.add(cols[act], rows[act], coupling[: 3 * b.nsub][act])
        T.add(cols[~act], cols[~act], coupling[: 3 * b.nsub][~act])  # an unused slot: its unknown is 0
        L = b.links
        ua, ub = (self.oB + d for d in L.flat_dofs(nd))
        cl = support_col + 3 * b.nsub + np.arange(len(L))
        cpl = coupling[3 * b.nsub :]
        T.add(ua, cl, -cpl)
        T.add(ub, cl, cpl)
        T.add(cl, ua, cpl)
        T.add(cl, ub, -cpl)
        spring = L.spring  # a bearing spring's row: u_a - u_b + F / k = 0 (F on end a)
        T.add(cl[spring], cl[spring], cpl[spring] ** 2 * L.compliance[spring])

    def _constraint_load(self, fB: np.ndarray, H: np.ndarray) -> None:
        """Subtract the known part ``H`` of the support (and link) forces from the bridge load,
        with the pattern of :meth:`_bridge_blocks` (in place)."""
        b = self.model.bridge
        if b.uniform:
            fB[:, b.support_dofs] -= H.reshape(b.spans, b.nsupport)
            return
        hs = H[: 3 * b.nsub].reshape(b.nsub, 3)
        act = b.support_active
        np.subtract.at(fB, (np.nonzero(act)[0], b.support_dof[act]), hs[act])
        fB -= b.links.load(H[3 * b.nsub :], fB.shape)

    def _bridge_step(self, t: float) -> BridgeStep:
        """Histories of the bridge at t_n, the support targets at t_{n+1} and the bridge load."""
        m, st = self.model, self.state
        b = m.bridge
        PB, QB = self.nm.history(st.uB, st.vB, st.aB)
        q, q1, q2 = m.supports(t)
        q_hat = self.point.target(b.at_supports(PB), b.at_supports(QB), q, q1, q2)
        q_hat = b.held_values(q_hat)
        if not b.uniform:  # the links' gaps follow their own rows
            q_hat = np.concatenate([q_hat, b.links.targets(self.point, PB, QB)])
        fB = b.history_load(PB, QB, q1)
        return BridgeStep(PB, QB, q_hat, fB)

    def _contact_dofs(self, c: Contacts) -> ContactDofs:
        span = c.loc.span
        idx = c.element_dofs()
        gdofs = self.oB + span[:, None] * self.model.bridge.ndof + idx
        return ContactDofs(c.on, np.flatnonzero(c.on), span, idx, gdofs)

    def _moving_loads(self, bs: BridgeStep, c: Contacts, N0: np.ndarray, rhs: np.ndarray) -> None:
        """Moving loads: the axle forces of the axles on the bridge load the bridge rows."""
        tr = self.model.train
        cd = self._contact_dofs(c)
        P = np.where(cd.on, tr.axle_loads, 0.0)
        np.add.at(bs.fB, (cd.span[cd.sel, None], cd.idx[cd.sel]), -N0[cd.sel] * P[cd.sel, None])
        rhs[self.oB : self.oB + self.NB] = bs.fB.reshape(-1)

    def _finish_bridge(self, x: np.ndarray, PB: np.ndarray, QB: np.ndarray) -> None:
        """Newmark update of the bridge from its solved displacements at t_{n+1}."""
        st, b = self.state, self.model.bridge
        uB = x[self.oB : self.oB + self.NB].reshape(b.nsub, b.ndof)
        st.vB, st.aB = self.nm.update(uB, PB, QB)
        st.uB = uB
