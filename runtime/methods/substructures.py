"""Compliances of the bridge's substructures and the links between them (localized method).

Every span and pier is a substructure with its supports held at their targets (Eqs. 22-24). Given a
per-kind matrix ``Z`` (the effective stiffness ``K^`` of a Newmark step, or the mass ``M`` of an
impact), ``u = S f + R q_hat`` solves ``Z u = f + E R_G``, ``E^T u = q_hat`` on each substructure.

Links (girder continuity, bearings on pier tops: ``Bridge.links``) join substructures: the link forces
``Lambda`` load both ends, ``u = S (f - L^T Lambda)``, and the link rows ``L u = g_hat`` close the
system. ``A = L S L^T`` is constant and factored once; the methods eliminate ``Lambda`` (the
compliance between two contacts then includes the path through the links). Without links every
operation reduces to the per-span products of the paper's bridge.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.linalg as sla


class SubstructureCompliance:
    """``S`` and ``R`` of every substructure kind for the per-kind matrices ``Z``, and the links."""

    def __init__(
        self, bridge: Any, matrices: list[np.ndarray], cholesky: bool = True, springs: bool = True
    ) -> None:
        """``springs``: bearing springs act (their compliance joins ``A``); False for an impact,
        through which a spring passes no impulse (only the rigid links then count)."""
        self.bridge = b = bridge
        self.S: list[np.ndarray] = []
        self.R: list[np.ndarray] = []
        kinds = [b] if b.uniform else b.kinds
        for k, z in zip(kinds, matrices, strict=True):
            if cholesky:
                z_inv = sla.cho_solve(sla.cho_factor(z), np.eye(b.ndof))
            else:
                z_inv = np.linalg.inv(z)
            z_inv = 0.5 * (z_inv + z_inv.T)
            active = np.ones(3, dtype=bool) if b.uniform else k.support_active
            E = np.zeros((b.ndof, 3))
            E[k.support_dofs[active], np.flatnonzero(active)] = 1.0
            cols = np.flatnonzero(active)
            ke = z_inv @ E[:, cols]
            se_inv = np.linalg.inv(E[:, cols].T @ ke)
            S = z_inv - ke @ se_inv @ ke.T
            self.S.append(0.5 * (S + S.T))
            R = np.zeros((b.ndof, 3))
            R[:, cols] = ke @ se_inv
            self.R.append(R)
        self.use = np.zeros(0, dtype=bool)
        if not b.uniform:
            self.use = np.ones(len(b.links), dtype=bool) if springs else ~b.links.spring
        self.nlinks = int(self.use.sum())
        if self.nlinks:
            self._links()

    # ----------------------------------------------------------------------------------------------
    def _kind(self, sub: np.ndarray) -> np.ndarray:
        return np.zeros_like(sub) if self.bridge.uniform else self.bridge.kind[sub]

    def times(self, F: np.ndarray) -> np.ndarray:
        """``S f`` of every substructure, ``F`` is ``nsub x ndof``."""
        b = self.bridge
        if b.uniform:
            return F @ self.S[0]
        out = np.empty_like(F)
        for k, members in enumerate(b.kind_members):
            out[members] = F[members] @ self.S[k]
        return out

    def held(self, F: np.ndarray, q_hat: np.ndarray) -> np.ndarray:
        """``S f + R q_hat`` of every substructure: the supports at their targets ``q_hat``."""
        b = self.bridge
        if b.uniform:
            return F @ self.S[0] + q_hat @ self.R[0].T
        out = np.empty_like(F)
        for k, members in enumerate(b.kind_members):
            out[members] = F[members] @ self.S[k] + q_hat[members] @ self.R[k].T
        return out

    def rows_times(self, X: np.ndarray, sub: np.ndarray) -> np.ndarray:
        """``X_i S_(sub_i)`` for rows ``X`` placed in the DOF vector of substructure ``sub_i``."""
        if self.bridge.uniform:
            return X @ self.S[0]
        kinds = self._kind(sub)
        out = np.zeros_like(X)
        for k in np.unique(kinds):
            sel = kinds == k
            out[sel] = X[sel] @ self.S[k]
        return out

    # ----------------------------------------------------------------------------------------------
    def _links(self) -> None:
        import scipy.sparse as sps
        import scipy.sparse.linalg as spla

        self.links = L = self.bridge.links.subset(self.use)
        ka, kb = self._kind(L.a_sub), self._kind(L.b_sub)
        self.col_a = np.array([self.S[k][:, d] for k, d in zip(ka, L.a_dof, strict=True)])
        self.col_b = np.array([self.S[k][:, d] for k, d in zip(kb, L.b_dof, strict=True)])
        rows, cols, vals = [], [], []
        ends = ((L.a_sub, L.a_dof, 1.0), (L.b_sub, L.b_dof, -1.0))
        for sl, dl, sign_l in ends:
            for sm, dm, sign_m in ends:
                # every pair (i, j) of links whose end l of i and end m of j share a substructure,
                # by i then j: found through the ends m sorted by substructure (linear in the links)
                by_sub = np.argsort(sm, kind="stable")
                first = np.searchsorted(sm[by_sub], sl, side="left")
                count = np.searchsorted(sm[by_sub], sl, side="right") - first
                i = np.repeat(np.arange(self.nlinks), count)
                j = by_sub[np.repeat(first - np.cumsum(count) + count, count) + np.arange(count.sum())]
                kind = self._kind(sl)[i]
                v = np.empty(len(i))
                for k in np.unique(kind):
                    at = kind == k
                    v[at] = self.S[k][dl[i[at]], dm[j[at]]]
                rows.append(i)
                cols.append(j)
                vals.append(sign_l * sign_m * v)
        n = self.nlinks
        rows.append(np.arange(n))  # a bearing spring: the link's own compliance 1/k
        cols.append(np.arange(n))
        vals.append(L.compliance)
        A = sps.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
        self.A = A
        """``A = L S L^T`` (+ the springs' compliance), sparse: the C loop factors its band."""
        self._lu = spla.splu(A)

    def link_solve(self, r: np.ndarray) -> np.ndarray:
        """``A^-1 r`` with ``A = L S L^T``."""
        return self._lu.solve(np.asarray(r, dtype=float))

    def cross(self, X: np.ndarray, sub: np.ndarray, on: np.ndarray) -> np.ndarray:
        """``X S L^T`` (``n x nlinks``) for rows ``X`` on substructures ``sub`` (zero where not ``on``)."""
        L = self.links
        ma = on[:, None] & (sub[:, None] == L.a_sub[None, :])
        mb = on[:, None] & (sub[:, None] == L.b_sub[None, :])
        return np.where(ma, X @ self.col_a.T, 0.0) - np.where(mb, X @ self.col_b.T, 0.0)

    def pair(self, X: np.ndarray, Y: np.ndarray, sub: np.ndarray, on: np.ndarray) -> np.ndarray:
        """``X S_eff Y^T`` between rows on the bridge: the compliance of the linked structure (rows
        ``X``, ``Y`` placed in their substructures' DOF vectors)."""
        same = on[:, None] & on[None, :] & (sub[:, None] == sub[None, :])
        out = np.where(same, self.rows_times(X, sub) @ Y.T, 0.0)
        if self.nlinks:
            out -= self.cross(X, sub, on) @ self.link_solve(self.cross(Y, sub, on).T)
        return out

    def linked(self, U: np.ndarray, g_hat: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Impose the links on the unlinked motion ``U``: ``Lambda = A^-1 (L U - g_hat)`` and
        ``U - S L^T Lambda``; ``g_hat`` (``Links.targets``, every link of the bridge) or 0."""
        if not self.nlinks:
            return U, np.zeros(0)
        target = 0.0 if g_hat is None else g_hat[self.use]
        lam = self.link_solve(self.links.gap(U) - target)
        b = self.bridge
        return U - self.times(self.links.load(lam, (b.nsub, b.ndof))), lam

    def field(self, F: np.ndarray) -> np.ndarray:
        """``S_eff f``: the response of the linked structure (supports held at zero) to loads ``F``."""
        return self.linked(self.times(F))[0]
