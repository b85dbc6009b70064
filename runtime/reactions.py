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
from svbi.runtime.assembly import Contacts, Model, State
from svbi.runtime.contact_rows import ShapeKernel


def support_reactions(model: Model, state: State, contacts: Contacts, P: np.ndarray) -> np.ndarray:
    """Support forces ``R_G`` beyond the dead load at ``state.t``: ``(spans, nsupport)`` for the
    paper's bridge, else one per active support (``Bridge.support_table``)."""
    b = model.bridge
    _, q1, _ = model.supports(state.t)
    f = b.per_kind(state.aB, "M") + b.per_kind(state.vB - b.quasi_static(q1), "C") + b.per_kind(state.uB, "K")
    (N0,) = ShapeKernel(b.contact_element_length)(contacts.loc.xi, contacts.loc.span)
    idx = contacts.element_dofs()
    sel = np.flatnonzero(contacts.on)
    np.add.at(f, (contacts.loc.span[sel, None], idx[sel]), N0[sel] * P[sel, None])
    if b.uniform:
        return f[:, b.support_dofs]
    return b.reaction_at_supports(f)
