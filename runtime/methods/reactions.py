"""Support reactions from the bridge's equations of motion (results ``support_reaction``).

A support constraint holds its DOF on the ground motion; the force it needs is what the span's
equation of motion leaves over at that DOF (paper Eq. 10 with the support rows of Eq. 22):
``R = [M a + C (v - T q') + K u]_s + [N P]_s``, with the contact forces ``P`` (compression positive,
pushing the deck down) through the shape functions ``N`` of the element under each wheel. The
bridge DOFs are measured from the dead-load state, so the deck's own weight is
``Bridge.dead_load_reactions``, added once in the results. Positive: the support pushes the deck up
(vertical) or forward (longitudinal).
"""

from __future__ import annotations

import numpy as np

from ..model.contact_rows import ShapeKernel
from ..model.system import Contacts, Model, State


def support_reactions(model: Model, state: State, contacts: Contacts, P: np.ndarray) -> np.ndarray:
    """Support forces ``R_G`` beyond the dead load at ``state.t``: ``(spans, nsupport)`` for the
    paper's bridge, else one per active support (``Bridge.support_table``)."""
    b = model.bridge
    f = _residual(model, state, contacts, P)
    if b.uniform:
        return f[:, b.support_dofs]
    return b.reaction_at_supports(f)


def _residual(model: Model, state: State, contacts: Contacts, P: np.ndarray) -> np.ndarray:
    """``M a + C (v - T q') + K u + N P`` of every substructure DOF: the force its constraints
    (supports and links) put there."""
    b = model.bridge
    _, q1, _ = model.supports(state.t)
    f = b.per_kind(state.aB, "M") + b.per_kind(state.vB - b.quasi_static(q1), "C") + b.per_kind(state.uB, "K")
    (N0,) = ShapeKernel(b.contact_element_length)(contacts.loc.xi, contacts.loc.span)
    idx = contacts.element_dofs()
    sel = np.flatnonzero(contacts.on)
    np.add.at(f, (contacts.loc.span[sel, None], idx[sel]), N0[sel] * P[sel, None])
    return f


def constraint_forces(model: Model, state: State, contacts: Contacts, P: np.ndarray) -> np.ndarray:
    """The force of every support constraint and, for a bridge with links, of every support slot
    (zero where unused) and link at ``state.t``: the layout of the monolithic methods' constraint
    unknowns (``Monolithic._bridge_blocks``). A support force acts on its DOF; a link force ``F``
    acts ``+F`` on its first end and ``-F`` on its second."""
    b = model.bridge
    if b.uniform:
        return support_reactions(model, state, contacts, P).reshape(-1)
    f = _residual(model, state, contacts, P)
    L = b.links
    nd, ns, nl = b.ndof, 3 * b.nsub, len(L)
    act = b.support_active.ravel()
    dof_of_slot = (nd * np.arange(b.nsub)[:, None] + b.support_dof).ravel()
    rows = np.concatenate([dof_of_slot[act], *L.flat_dofs(nd)])
    cols = np.concatenate([np.flatnonzero(act), ns + np.arange(nl), ns + np.arange(nl)])
    vals = np.concatenate([np.ones(int(act.sum())), np.ones(nl), -np.ones(nl)])
    eq, where = np.unique(rows, return_inverse=True)
    unknowns = np.concatenate([np.flatnonzero(act), ns + np.arange(nl)])
    G = np.zeros((len(eq), ns + nl))
    np.add.at(G, (where, cols), vals)
    forces = np.zeros(ns + nl)
    forces[unknowns] = np.linalg.lstsq(G[:, unknowns], f.reshape(-1)[eq], rcond=None)[0]
    return forces
