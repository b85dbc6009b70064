"""A run of consecutive 3D steps as arrays: what a 3D time loop hands to the recording.

The 3D steps (:mod:`svbi.runtime.methods.coupled3d`, :mod:`svbi.runtime.methods.localized3d`, and
the compiled loop) advance many steps between two calls from Python; they return the states of
those steps as one :class:`Chunk3D`, and the recording of a run reads whole chunks (vectorised over
the steps), so that nothing in Python runs once per step. :class:`Excitation3D` is what the loop
needs to know of the track and the ground at each step of a chunk.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Excitation3D:
    """The excitation at the ends of ``k`` consecutive steps (times ``t``)."""

    t: np.ndarray
    """``(k,)``: t_{n+1} of each step (s)."""
    element: np.ndarray
    """``(k, wheelsets)`` int: the deck element under each wheelset (``GROUND``, -1, on the approach
    track), as :meth:`svbi.runtime.model.system3d.System3D.contact_location`."""
    xi: np.ndarray
    """``(k, wheelsets)``: the local coordinate in that element."""
    irregularity: np.ndarray
    """``(k, wheelsets, 9)``: the contact kernels' irregularity argument under each wheelset
    (``[r_v, r_a, r_c]``, their slopes and curvatures along x)."""
    ground: np.ndarray | None
    """``(k, 3, wheelsets, 12)``: the ground's rigid "element" under each wheelset and its first and
    second time derivatives (:meth:`System3D.ground_under`); None when the ground is at rest."""
    support: np.ndarray | None
    """``(k, 3, supports)``: the supports' Newmark-consistent targets ``Q, Q', Q''``; None when the
    supports do not move."""


@dataclass
class Chunk3D:
    """The states at the ends of ``k`` consecutive steps, step by step along the first axis."""

    t: np.ndarray
    """``(k,)`` (s)."""
    q: np.ndarray
    """``(k, vehicle DOFs)``: the vehicle's displacements; ``qd``, ``qdd`` their rates."""
    qd: np.ndarray
    qdd: np.ndarray
    u: np.ndarray
    """``(k, bridge DOFs)``: the span's full DOF vector (supports included); ``ud``, ``udd``."""
    ud: np.ndarray
    udd: np.ndarray
    P: np.ndarray
    """``(k, 2 wheelsets)``: normal contact forces, wheelset by wheelset, left then right (N)."""
    flange: np.ndarray
    """``(k, 2 wheelsets)``: flange forces (N, compression positive)."""
    contact: np.ndarray
    """``(k, 4 wheelsets)`` bool: which constraints are closed (normal left, right, flange left,
    right, wheelset by wheelset)."""
    creep: np.ndarray
    """``(k, wheelsets, 2, 3)``: creep forces ``[F_x, F_y, M_sp]`` of each contact (zeros without
    creep)."""
    gaps: np.ndarray
    """``(k, 2 wheelsets)``: normal gaps (m); NaN at steps where they were not evaluated (the
    recording reads them at output steps only)."""
    irregularity: np.ndarray
    """``(k, wheelsets, 9)``: the irregularity argument under each wheelset at ``t``."""

    def __len__(self) -> int:
        return int(self.t.size)
