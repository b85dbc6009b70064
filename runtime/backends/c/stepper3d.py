"""The compiled loop of the 3D localized-dynamic step (docs/three-d.md, "The C loop";
docs/c-backend.md, "The 3D loop").

:class:`LocalizedDynamic3DC` steps a :class:`svbi.runtime.model.system3d.System3D` as
:class:`svbi.runtime.methods.localized3d.LocalizedDynamic3D` does (the same equations, the same
active set, impact and creep, the same convergence rule), many steps per call from Python, in the C
of ``runtime/csrc/loop3d/`` linked with the CasADi-emitted contact kernels of
``generated/contact3d/``. The set-up is the NumPy step's (:class:`_Step3D`: the supports at their
targets, the initial creep forces, the explicit creep's stability check), plus what the C loop
needs: the vehicle's per-car blocks, the span's effective matrix factored once (band Cholesky in
reverse Cuthill-McKee order), its compliance and inverse mass (dense, as the NumPy step's), and
the sparse mass, damping and support couplings.

The excitation of a chunk (:class:`svbi.runtime.methods.chunk3d.Excitation3D`) is built here: the
elements and local coordinates under the wheelsets vectorised over the chunk's steps (for a
:class:`~svbi.runtime.model.span3d.Span3D` or a :class:`~svbi.runtime.model.bridge3d.Bridge3D`);
under an earthquake, the ground under the wheelsets and the supports' targets, vectorised for the
records of a scenario (:meth:`System3D.ground_motions`, the model's evaluation of the ground at
many times), by a loop over the chunk's steps in Python for another ground.

The structs handed to C are mirrored from the field lists of :mod:`svbi.codegen.loop3d_abi`, which
also render the loop's header ``generated/solver3d/svbi_loop3d_types.h``.
"""

from __future__ import annotations

import ctypes
import os
import shlex
from functools import cache
from importlib import resources
from typing import Any

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components, reverse_cuthill_mckee

from ....codegen.c_flags import CASADI_WARNING_EXCEPTION, STRICT_FLAGS
from ....codegen.loop3d_abi import (
    CHUNK3D_FIELDS,
    INFO3D_FIELDS,
    SETUP3D_FIELDS,
    SOLVER3D_FOLDER,
    STATE3D_FIELDS,
    STATUS3D_CODES,
    STATUS3D_NAMES,
    TYPES3D_HEADER,
)
from ... import toolchain as kernel_cache
from ...methods.chunk3d import Chunk3D, Excitation3D
from ...methods.coupled3d import PER_WHEELSET, State3D, _Step3D
from ...model.bridge3d import GROUND_DIRECTIONS
from ...model.ground import RecordGround, seen_moving
from ...model.system import newmark_targets, support_hat
from ...model.system3d import NIRREGULARITY, System3D
from ...toolchain import generated_root
from .build import CSRC, CSRC_3D, simd_flags, structure

STATUS = STATUS3D_NAMES
"""The C loop's status codes and their messages (``S3_*`` of the generated
``svbi_loop3d_types.h``, from :mod:`svbi.codegen.loop3d_abi`)."""
NOT_FINITE, SINGULAR = STATUS3D_CODES["NOT_FINITE"], STATUS3D_CODES["SINGULAR"]
SOLVE_FAILURES = frozenset(STATUS3D_CODES[k] for k in ("SINGULAR", "ACTIVE_SET", "IMPULSE", "FORCE_JUMP"))
"""The statuses of a step whose contact problem had no solution or did not settle: the contact state
changed more within the step than it can resolve (a time step too large for the motion)."""
CHORD_RATE = 0.25
"""A chord iteration must shrink the interface iteration's update 4 times, or the next is Newton's (a
chord contracts at the rate the matrix's age allows; the Newton iteration after it restores the
quadratic rate)."""
MAX_WHEELSETS = 256
"""The loop keeps the span's compliance between the elements of every pair of wheelsets (144
doubles a pair): 75 MB at this many wheelsets."""
MAX_FREE_DOFS = 8000
"""The span's compliance and inverse mass are dense, as the NumPy step's (512 MB each at this size)."""

CONTACT3D_FILES = ("contact3d_kernels.c", "contact3d_kernels.h", "contact3d_model.c", "contact3d.h")
"""The generated contact kernels linked into the loop (``generated/contact3d/``)."""

_P = ctypes.c_void_p


Setup3D = structure("Setup3D", SETUP3D_FIELDS, "ctypes mirror of ``setup3d_t`` (``svbi_loop3d_types.h``).")
CState3D = structure("CState3D", STATE3D_FIELDS, "ctypes mirror of ``state3d_t``.")
CChunk3D = structure("CChunk3D", CHUNK3D_FIELDS, "ctypes mirror of ``chunk3d_t``.")
Info3D = structure("Info3D", INFO3D_FIELDS, "ctypes mirror of ``info3d_t``.")
MIRRORS = {"setup3d_t": Setup3D, "state3d_t": CState3D, "chunk3d_t": CChunk3D, "info3d_t": Info3D}
"""The ctypes mirror of every struct of ``loop3d_abi.STRUCTS3D``, in the order of ``svbi3d_sizes``."""


def loop3d_sources() -> dict[str, bytes]:
    """``{file name: bytes}``: the static C of ``runtime/csrc/loop3d``, its generated header of the
    structs (``generated/solver3d/``) and the generated contact kernels, one flat folder."""
    folder = resources.files("svbi.runtime").joinpath(CSRC).joinpath(CSRC_3D)
    files = {p.name: p.read_bytes() for p in folder.iterdir() if p.name.endswith((".c", ".h"))}
    files[TYPES3D_HEADER] = (generated_root() / SOLVER3D_FOLDER / TYPES3D_HEADER).read_bytes()
    root = generated_root() / "contact3d"
    for name in CONTACT3D_FILES:
        files[name] = (root / name).read_bytes()
    return dict(sorted(files.items()))


@cache
def load_loop3d() -> ctypes.CDLL:
    """Compile (cached by content) and load the 3D loop; the struct layouts checked against C."""
    flags = (
        *STRICT_FLAGS,
        CASADI_WARNING_EXCEPTION,
        "-O3",
        "-fPIC",
        "-shared",
        *simd_flags(),
        *shlex.split(os.environ.get("SVBI_CFLAGS", "")),
    )
    lib = kernel_cache.load_library(loop3d_sources(), "svbi_loop3d", flags=flags)
    sizes = (ctypes.c_long * len(MIRRORS))()
    lib.svbi3d_sizes(sizes)
    want = [ctypes.sizeof(s) for s in MIRRORS.values()]
    if list(sizes) != want:
        raise RuntimeError(
            f"the 3D loop's structs do not match their ctypes mirrors: C {list(sizes)}, Python {want}"
        )
    lib.svbi3d_workspace.argtypes = [
        ctypes.POINTER(Setup3D),
        ctypes.POINTER(ctypes.c_long),
        ctypes.POINTER(ctypes.c_long),
    ]
    lib.svbi3d_run.argtypes = [
        ctypes.POINTER(Setup3D),
        ctypes.POINTER(CState3D),
        ctypes.POINTER(CChunk3D),
        _P,
        _P,
        ctypes.c_long,
        ctypes.c_long,
        ctypes.POINTER(Info3D),
    ]
    lib.svbi3d_gaps.argtypes = [ctypes.POINTER(Setup3D), ctypes.POINTER(CState3D), _P, _P, _P, _P, _P, _P, _P]
    return lib


def vehicle_blocks(*matrices: np.ndarray, together: list[np.ndarray] = ()) -> list[tuple[int, int]]:  # type: ignore[assignment]
    """The diagonal blocks ``[(start, stop)]`` of the vehicle: the finest split into consecutive DOF
    ranges that no entry of ``matrices`` couples (a train's cars), each index set of ``together``
    (a wheelset's DOFs) within one block."""
    n = matrices[0].shape[0]
    pattern = np.zeros((n, n), dtype=bool)
    for m in matrices:
        pattern |= m != 0
    reach = np.array([np.flatnonzero(pattern[i]).max(initial=i) for i in range(n)])
    reach = np.maximum.accumulate(reach)
    inside = np.zeros(n + 1, dtype=bool)
    for idx in together:
        inside[int(np.min(idx)) + 1 : int(np.max(idx)) + 1] = True
    cuts = [0] + [b for b in range(1, n) if reach[b - 1] < b and not inside[b]] + [n]
    return list(zip(cuts[:-1], cuts[1:], strict=True))


def _csr(m: Any, rows: int, cols: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    a = sp.csr_matrix(m, shape=(rows, cols))
    a.eliminate_zeros()
    return a.indptr.astype(np.int32), a.indices.astype(np.int32), a.data.astype(float)


def _i32(a: Any) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.int32)


def _f64(a: Any) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=float)


class LocalizedDynamic3DC(_Step3D):
    """The 3D localized-dynamic step in C; constructed as
    :class:`~svbi.runtime.methods.localized3d.LocalizedDynamic3D`, advanced by :meth:`advance`."""

    name = "localized-dynamic-3d"

    def __init__(
        self,
        system: System3D,
        state: State3D,
        time_step: float,
        kappa: float = 1.0,
        zeta: float = 1.0,
        normal: str = "unilateral",
        chord: bool = True,
        chord_rate: float = CHORD_RATE,
    ) -> None:
        nW, nF = len(system.vehicle.wheelsets), len(system.span.free)
        if nW > MAX_WHEELSETS:
            raise ValueError(
                f"the 3D C loop takes at most {MAX_WHEELSETS} wheelsets (its compliance blocks grow with "
                f"their square); this train has {nW}"
            )
        if nF > MAX_FREE_DOFS:
            raise ValueError(
                f"the 3D C loop takes bridges of at most {MAX_FREE_DOFS} free DOFs (dense compliance and "
                f"inverse mass); this one has {nF}"
            )
        super().__init__(system, state, time_step, kappa, zeta, normal)
        self.chord = chord
        """Chord iterations after each active-set pass's first (Newton) iteration (False: Newton at
        every iteration, as :class:`LocalizedDynamic3D`); both stop at the same solution."""
        self.chord_rate = chord_rate
        """A chord iteration that shrinks the update by less than this factor is followed by a Newton
        iteration (0: after every chord that has not converged)."""
        self.stopped: str | None = None
        """Why the last :meth:`advance` stopped early (None: it did every step)."""
        self.lib = load_loop3d()
        self._keep: list[np.ndarray] = []
        self._setup()
        self._bind_state()

    # ----------------------------------------------------------------------------------------------
    def _ptr(self, a: np.ndarray | None) -> int | None:
        if a is None:
            return None
        self._keep.append(a)
        return a.ctypes.data

    def _setup(self) -> None:
        sys_, nm, asm = self.system, self.nm, self.asm
        veh, span = sys_.vehicle, sys_.span
        nV, nW, nF = asm.nV, asm.nW, asm.nF
        nB = span.M.shape[0]
        blocks = vehicle_blocks(veh.M, veh.C, veh.K, together=[ws.dofs for ws in veh.wheelsets])
        k_hat_V = nm.effective(veh.K, veh.C, veh.M)
        of = np.zeros(nV, dtype=int)
        for b, (s, e) in enumerate(blocks):
            of[s:e] = b
        ws_blk = []
        for ws in veh.wheelsets:
            owners = set(of[ws.dofs].tolist())
            ws_blk.append(owners.pop())
        offsets = np.cumsum([0] + [(e - s) ** 2 for s, e in blocks])

        def packed(m: np.ndarray, invert: bool = False) -> np.ndarray:
            parts = []
            for s, e in blocks:
                blk = m[s:e, s:e]
                parts.append((np.linalg.inv(blk) if invert else blk).ravel())
            return _f64(np.concatenate(parts))

        f = asm.free
        k_hat_B = nm.effective(span.K, self.CB, span.M)
        kff = k_hat_B[np.ix_(f, f)]
        self.S_B = np.linalg.inv(kff)  # the compliance, as the NumPy step's
        pattern = sp.csr_matrix(kff != 0)
        perm = reverse_cuthill_mckee(pattern, symmetric_mode=True).astype(np.int32)
        kp = kff[np.ix_(perm, perm)]
        rows, cols = np.nonzero(kp)
        p = int(np.abs(rows - cols).max(initial=0))
        ab = np.zeros((p + 1, nF))
        for r in range(p + 1):
            ab[r, : nF - r] = np.diagonal(kp, -r)
        band = sla.cholesky_banded(ab, lower=True)
        band[0] = 1.0 / band[0]  # the C solve multiplies by the diagonal's reciprocal
        full_to_free = -np.ones(nB, dtype=np.int32)
        full_to_free[f] = np.arange(nF)
        nE = int(span.n_elements)
        el_dofs = np.array([span.element_dofs(e) for e in range(nE)], dtype=np.int32)
        # the parts of the structure: the stiffness graph with each deck element's free DOFs joined
        # (axial, lateral, vertical and torsional DOFs decouple in the stiffness of a straight
        # girder, but a wheelset on the element loads them all): the compliance between two
        # elements in different parts is zero
        joins = [full_to_free[d][full_to_free[d] >= 0] for d in el_dofs]
        rows_j = np.concatenate([j[:-1] for j in joins if j.size > 1] + [np.zeros(0, dtype=int)])
        cols_j = np.concatenate([j[1:] for j in joins if j.size > 1] + [np.zeros(0, dtype=int)])
        joined = pattern + sp.csr_matrix((np.ones(rows_j.size), (rows_j, cols_j)), shape=(nF, nF))
        _, comp = connected_components(joined, directed=False)
        M_csr = _csr(span.M, nB, nB)
        C_csr = _csr(self.CB, nB, nB)
        if self.quake:
            held = _i32(self.held)
            Kfs = _csr(self.k_hat_fs, nF, len(held))
            CT = _csr(self.CT, nF, len(held))
        else:
            held = np.zeros(0, dtype=np.int32)
            Kfs = CT = _csr(np.zeros((nF, 0)), nF, 0)
        geom = np.array([k._geometry for k in self.kernels], dtype=float)
        # entry 7, the element length: the approach track's here, each deck element's from el_len
        # (the loop sets it whenever it places a wheelset on an element)
        geom[:, 7] = sys_.ground_element_length
        material = np.array(
            [fk._material if fk._material is not None else np.zeros(10) for _, fk in self.pairs], dtype=float
        )
        self.blocks = blocks
        self.bandwidth = p
        P = self._ptr
        S = Setup3D()
        S.nV, S.nW, S.nF, S.nB, S.nS, S.nE, S.nblk, S.p = nV, nW, nF, nB, len(held), nE, len(blocks), p
        S.quake, S.creep, S.bilateral = int(self.quake), int(sys_.creep is not None), int(self.bilateral)
        S.chord, S.chord_rate = int(self.chord), float(self.chord_rate)
        S.dt, S.a0, S.a1, S.a2 = nm.dt, nm.a0, nm.a1, nm.a2
        S.c1, S.c0, S.scale = self.c1, self.c0, self.scale
        S.blk_start = P(_i32([s for s, _ in blocks] + [nV]))
        S.blk_off = P(np.ascontiguousarray(offsets, dtype=np.int64))
        S.MV_ptr, S.MV_idx, S.MV_val = (P(a) for a in _csr(veh.M, nV, nV))
        S.CV_ptr, S.CV_idx, S.CV_val = (P(a) for a in _csr(veh.C, nV, nV))
        S.KV_ptr, S.KV_idx, S.KV_val = (P(a) for a in _csr(veh.K, nV, nV))
        S.AV, S.MVi = P(packed(k_hat_V, True)), P(packed(veh.M, True))
        S.ws_dofs = P(_i32(np.array([ws.dofs for ws in veh.wheelsets])))
        S.ws_blk = P(_i32(ws_blk))
        S.geom, S.material = P(_f64(geom)), P(_f64(material))
        S.el_dofs, S.full_to_free, S.free_dofs = P(el_dofs), P(full_to_free), P(_i32(f))
        S.comp = P(_i32(comp))
        S.S, S.MBi = P(_f64(self.S_B)), P(_f64(self.MB_inv))
        nonzero = self.MB_inv != 0.0  # zero between the parts of the structure (block_inverse)
        first = np.argmax(nonzero, axis=1)
        last = nF - 1 - np.argmax(nonzero[:, ::-1], axis=1)
        S.MBi_cols = P(_i32(np.stack([first, last], axis=1)))
        S.band, S.perm = P(_f64(band.T)), P(perm)
        S.M_ptr, S.M_idx, S.M_val = (P(a) for a in M_csr)
        S.C_ptr, S.C_idx, S.C_val = (P(a) for a in C_csr)
        S.held = P(held)
        S.Kfs_ptr, S.Kfs_idx, S.Kfs_val = (P(a) for a in Kfs)
        S.CT_ptr, S.CT_idx, S.CT_val = (P(a) for a in CT)
        S.el_len = P(_f64(sys_.element_lengths))
        self.setup = S
        nd, ni = ctypes.c_long(), ctypes.c_long()
        self.lib.svbi3d_workspace(ctypes.byref(S), ctypes.byref(nd), ctypes.byref(ni))
        self.work = np.zeros(max(nd.value, 1))
        self.iwork = np.zeros(max(ni.value, 1), dtype=np.int32)
        self.iterations = self.passes = self.factorizations = 0
        self._kept: dict[str, np.ndarray] | None = None

    def _bind_state(self) -> None:
        """The state's arrays, contiguous and owned, that the C loop updates in place."""
        st = self.state
        for name in ("q", "qd", "qdd", "u", "ud", "udd", "P", "flange", "creep", "creep_V", "creep_B"):
            setattr(st, name, np.array(getattr(st, name), dtype=float, order="C"))
        self._contact = _i32(st.contact)
        self._load = _f64(self.system.vehicle_load())
        X = CState3D()
        X.t = st.t
        for name in ("q", "qd", "qdd", "u", "ud", "udd", "P", "flange", "creep", "creep_V", "creep_B"):
            setattr(X, name, getattr(st, name).ctypes.data)
        X.contact = self._contact.ctypes.data
        X.load = self._load.ctypes.data
        self.cstate = X

    # ----------------------------------------------------------------------------------------------
    def excitation(self, n0: int, k: int, irregularity: np.ndarray) -> Excitation3D:
        """The excitation of steps ``n0 .. n0 + k - 1`` at their ends t_{n+1}."""
        sys_ = self.system
        t = (n0 + 1 + np.arange(k)) * self.dt
        element, xi = self.system.contact_locations(t)
        element, xi = np.ascontiguousarray(element, dtype=np.int32), _f64(xi)
        ground = support = None
        if self.quake and isinstance(sys_.ground, RecordGround) and hasattr(sys_.span, "supports"):
            ground, support = self._quake_many(n0, k, t)
        elif self.quake:  # another ground: a loop over the chunk's steps, in Python
            ground, support = self._quake_loop(t)
        return Excitation3D(t, element, xi, _f64(irregularity), ground, support)

    def _quake_loop(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The ground under the wheelsets and the supports' targets step by step (any ground)."""
        ground = np.empty((t.size, 3, self.asm.nW, 12))
        support = np.empty((t.size, 3, len(self.held)))
        for s, ts in enumerate(t):
            ground[s] = np.stack(self.system.ground_under(float(ts)))
            support[s] = np.stack(self.support_targets(float(ts)))
        return ground, support

    def _quake_many(self, n0: int, k: int, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The ground under the wheelsets and the supports' targets at the chunk's steps, vectorised
        (:meth:`System3D.ground_under`, :meth:`_Step3D.support_targets`; the ground's records
        evaluated at all the steps at once by :meth:`System3D.ground_motions`)."""
        sys_, span, dt = self.system, self.system.span, self.dt
        nW = self.asm.nW
        offsets = np.array([w.offset for w in sys_.vehicle.wheelsets])
        x = sys_.start + sys_.speed * t[:, None] - offsets[None, :]
        q = sys_.ground_motions(t, x)
        moving = seen_moving(*q, getattr(sys_.ground, "apparent_velocity", None), sys_.speed)
        ground = np.zeros((k, 3, nW, 12))
        for d in range(3):
            ground[:, d, :, 0:3] = moving[d]
            ground[:, d, :, 6:9] = moving[d]
        # the supports: h = q - dt^2/4 q'' at steps n0 .. n0 + k + 1, then the three-point targets
        m = np.arange(n0, n0 + k + 2)
        times = m * dt
        lines = np.asarray(span.line_x, dtype=float)
        lq = sys_.ground_motions(times, lines)
        line = np.array([s.line for s in span.supports])
        direction = np.array(
            [
                GROUND_DIRECTIONS.index(s.direction) if s.direction in GROUND_DIRECTIONS else -1
                for s in span.supports
            ]
        )
        take = lambda a: np.where(direction >= 0, a[:, line, np.maximum(direction, 0)], 0.0)  # noqa: E731
        h = support_hat(take(lq[0]), take(lq[2]), dt)
        support = np.stack(newmark_targets(h[:-2], h[1:-1], h[2:], dt), axis=1)
        return _f64(ground), _f64(support)

    def _outputs(self, k: int, reuse: bool) -> dict[str, np.ndarray]:
        """The chunk's output arrays for ``k`` steps: fresh, or (``reuse``) the first ``k`` rows of
        the stepper's buffers (grown when ``k`` exceeds them)."""
        nW, nV, nB = self.asm.nW, self.asm.nV, self.state.u.size

        def fresh(rows: int) -> dict[str, np.ndarray]:
            return {
                "t": np.empty(rows),
                "q": np.empty((rows, nV)),
                "qd": np.empty((rows, nV)),
                "qdd": np.empty((rows, nV)),
                "u": np.empty((rows, nB)),
                "ud": np.empty((rows, nB)),
                "udd": np.empty((rows, nB)),
                "P": np.empty((rows, 2 * nW)),
                "flange": np.empty((rows, 2 * nW)),
                "contact": np.empty((rows, PER_WHEELSET * nW), dtype=np.int32),
                "creep": np.empty((rows, nW, 2, 3)),
                "gaps": np.empty((rows, 2 * nW)),
            }

        if not reuse:
            return fresh(k)
        kept = self._kept
        if kept is None or len(kept["t"]) < k:
            kept = self._kept = fresh(k)
        return {name: a[:k] for name, a in kept.items()}

    def advance(self, n0: int, k: int, irregularity: np.ndarray, every: int, reuse: bool = False) -> Chunk3D:
        """Steps ``n0 .. n0 + k - 1`` (step ``n``: t_n to t_{n+1}); ``irregularity`` ``(k, wheelsets,
        9)`` under each wheelset at each t_{n+1}. The normal gaps are evaluated at the steps with
        ``(n + 1) % every == 0`` (NaN at the others). A chunk shorter than ``k`` means the loop
        stopped (:attr:`stopped` says why, at which step); the state is then that of the step that
        failed (non-finite) or of the last good step's solve in progress (a failed solve).

        With ``reuse``, the chunk's arrays are the stepper's own, kept from call to call (the loop
        then writes to memory already mapped, not to fresh pages): they hold this chunk until the
        next ``advance`` with ``reuse`` overwrites them; a caller that keeps a chunk copies it."""
        nW = self.asm.nW
        irregularity = _f64(np.broadcast_to(irregularity, (k, nW, NIRREGULARITY)))
        ex = self.excitation(n0, k, irregularity)
        self._load[:] = self.system.vehicle_load()
        out = self._outputs(k, reuse)
        C = CChunk3D()
        C.element, C.xi, C.irr = ex.element.ctypes.data, ex.xi.ctypes.data, ex.irregularity.ctypes.data
        C.ground = None if ex.ground is None else ex.ground.ctypes.data
        C.support = None if ex.support is None else ex.support.ctypes.data
        for name, a in out.items():
            setattr(C, name, a.ctypes.data)
        C.every = int(every)
        info = Info3D()
        self.cstate.t = self.state.t
        status = self.lib.svbi3d_run(
            ctypes.byref(self.setup),
            ctypes.byref(self.cstate),
            ctypes.byref(C),
            self.work.ctypes.data,
            self.iwork.ctypes.data,
            int(n0),
            int(k),
            ctypes.byref(info),
        )
        self.iterations += info.iterations
        self.passes += info.passes
        self.factorizations += info.factorizations
        st = self.state
        st.t = float(self.cstate.t)
        st.contact = self._contact.astype(bool)
        done = int(info.steps)
        last = irregularity[done - 1] if done else None
        if last is not None:  # the NumPy kernels (gaps(), step()) at the state's rail
            self.set_irregularity(last.copy())
        self.stopped = None
        if status:
            n = int(info.step)
            why = STATUS.get(status, str(status))
            self.stopped = f"the 3D C loop stopped at step {n + 1} (t = {(n + 1) * self.dt:.6g} s): {why}"
            self.status = int(status)
        else:
            self.status = 0
        return Chunk3D(
            out["t"][:done],
            out["q"][:done],
            out["qd"][:done],
            out["qdd"][:done],
            out["u"][:done],
            out["ud"][:done],
            out["udd"][:done],
            out["P"][:done],
            out["flange"][:done],
            out["contact"][:done].astype(bool),
            out["creep"][:done],
            out["gaps"][:done],
            irregularity[:done],
        )

    def step(self, n: int) -> State3D:
        """One step with the kernels' current irregularity (as the NumPy steps)."""
        level = np.array([k.irregularity for k in self.kernels], dtype=float)[None]
        self.advance(n, 1, level, 1)
        if self.stopped:
            if self.status == SINGULAR:
                raise np.linalg.LinAlgError(self.stopped)
            if self.status != NOT_FINITE:
                raise RuntimeError(self.stopped)
        return self.state
