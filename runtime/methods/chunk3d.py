"""A run of consecutive 3D steps as arrays: what a 3D time loop hands to the recording.

The 3D steps (:mod:`svbi.runtime.methods.coupled3d`, :mod:`svbi.runtime.methods.localized3d`, and
the compiled loop) advance many steps between two calls from Python; they return the states of
those steps as one :class:`Chunk3D`, and the recording of a run reads whole chunks (vectorised over
the steps), so that nothing in Python runs once per step. :class:`Excitation3D` is what the loop
needs to know of the track and the ground at each step of a chunk.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

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


class ChunkStopped(Exception):
    """Raised by ``advance`` when a step fails or is interrupted part-way through a chunk:
    ``chunk`` holds the steps finished before it (possibly none) and ``cause`` is the exception
    (``numpy.linalg.LinAlgError``, ``KeyboardInterrupt``, ...) that stopped the loop, so that the
    caller records those steps before it handles ``cause``."""

    def __init__(self, chunk: Chunk3D, cause: BaseException) -> None:
        super().__init__(f"stopped after {len(chunk)} steps of a chunk: {cause!r}")
        self.chunk = chunk
        self.cause = cause


class _Rows:
    """Preallocated arrays of a :class:`Chunk3D` of at most ``k`` steps, filled row by row."""

    def __init__(self, k: int, nq: int, nu: int, nw: int) -> None:
        self.t = np.zeros(k)
        self.q, self.qd, self.qdd = (np.zeros((k, nq)) for _ in range(3))
        self.u, self.ud, self.udd = (np.zeros((k, nu)) for _ in range(3))
        self.P = np.zeros((k, 2 * nw))
        self.flange = np.zeros((k, 2 * nw))
        self.contact = np.zeros((k, 4 * nw), dtype=bool)
        self.creep = np.zeros((k, nw, 2, 3))
        self.gaps = np.full((k, 2 * nw), np.nan)
        self.irregularity = np.zeros((k, nw, 9))

    def put(self, j: int, st: Any, irregularity: np.ndarray) -> None:
        """Row ``j`` from a :class:`~svbi.runtime.methods.coupled3d.State3D` (copied)."""
        self.t[j] = st.t
        self.q[j], self.qd[j], self.qdd[j] = st.q, st.qd, st.qdd
        self.u[j], self.ud[j], self.udd[j] = st.u, st.ud, st.udd
        self.P[j] = st.P
        if st.flange is not None:
            self.flange[j] = st.flange
        if st.contact is None:  # the normal contacts closed, the flanges open
            self.contact[j] = np.tile([True, True, False, False], self.P.shape[1] // 2)
        else:
            self.contact[j] = st.contact
        if st.creep is not None:
            self.creep[j] = st.creep
        self.irregularity[j] = irregularity

    def chunk(self, k: int) -> Chunk3D:
        """The first ``k`` rows."""
        return Chunk3D(
            t=self.t[:k],
            q=self.q[:k],
            qd=self.qd[:k],
            qdd=self.qdd[:k],
            u=self.u[:k],
            ud=self.ud[:k],
            udd=self.udd[:k],
            P=self.P[:k],
            flange=self.flange[:k],
            contact=self.contact[:k],
            creep=self.creep[:k],
            gaps=self.gaps[:k],
            irregularity=self.irregularity[:k],
        )


class SteppedChunks:
    """The chunk interface (``advance``) of a stepper that advances one step per call from Python
    (:class:`~svbi.runtime.methods.localized3d.LocalizedDynamic3D`,
    :class:`~svbi.runtime.methods.coupled3d.CoupledDynamic3D`): before each step it sets the
    stepper's contact kernels' irregularity argument (``stepper.kernels[w].irregularity``) to that
    under wheelset ``w`` at t_{n+1}, calls ``stepper.step(n)`` and copies the state into the chunk;
    the normal gaps (``stepper.gaps()``) are evaluated at output steps only, ``(n + 1) % every == 0``.

    A state that is not finite (``q``, ``u`` or ``P``) ends the chunk early: it is the chunk's last
    row, and the caller finds it there. An exception in a step raises :class:`ChunkStopped` with the
    steps finished before it."""

    def __init__(self, stepper: Any) -> None:
        self.stepper = stepper

    def _rows(self, k: int) -> _Rows:
        st = self.stepper.state
        return _Rows(k, st.q.size, st.u.size, len(self.stepper.kernels))

    def _set(self, irregularity: np.ndarray) -> None:
        self.stepper.set_irregularity(irregularity)

    def current(self, irregularity: np.ndarray) -> Chunk3D:
        """The stepper's present state as a chunk of one row, its gaps evaluated, after setting the
        kernels' irregularity argument to ``irregularity`` (wheelsets, 9) (the initial state)."""
        self._set(irregularity)
        rows = self._rows(1)
        rows.put(0, self.stepper.state, irregularity)
        rows.gaps[0] = self.stepper.gaps()
        return rows.chunk(1)

    def advance(self, n0: int, k: int, irregularity: np.ndarray, every: int) -> Chunk3D:
        """Steps ``n0`` to ``n0 + k - 1`` (t_{n0} to t_{n0 + k}); ``irregularity`` (k, wheelsets, 9)
        under each wheelset at each step's t_{n+1}."""
        rows = self._rows(k)
        every = max(1, int(every))
        stepper = self.stepper
        j = 0
        try:
            for j in range(k):
                self._set(irregularity[j])
                st = stepper.step(n0 + j)
                rows.put(j, st, irregularity[j])
                if not (np.isfinite(st.q).all() and np.isfinite(st.u).all() and np.isfinite(st.P).all()):
                    return rows.chunk(j + 1)
                if (n0 + j + 1) % every == 0:
                    rows.gaps[j] = stepper.gaps()
        except (Exception, KeyboardInterrupt) as exc:
            raise ChunkStopped(rows.chunk(j), exc) from exc
        return rows.chunk(k)


def chunk_head(chunk: Chunk3D, k: int) -> Chunk3D:
    """The first ``k`` steps of ``chunk`` (views)."""
    return Chunk3D(**{f.name: getattr(chunk, f.name)[:k] for f in fields(chunk)})


def first_non_finite(chunk: Chunk3D) -> int | None:
    """The index of the first step of ``chunk`` whose ``q``, ``u`` or ``P`` is not finite (None:
    all are)."""
    ok = (
        np.isfinite(chunk.q).all(axis=1) & np.isfinite(chunk.u).all(axis=1) & np.isfinite(chunk.P).all(axis=1)
    )
    bad = np.flatnonzero(~ok)
    return int(bad[0]) if bad.size else None
