"""The 3D loop's ABI, as plain data: the members of the structs that Python hands to the compiled
3D localized-dynamic step (``runtime/csrc/loop3d/``), its status codes and the name of its
generated header.

One definition for both sides, as :mod:`svbi.codegen.loop_abi` for the 2D loop: at generation time
:mod:`svbi.codegen.loop_glue` renders ``generated/solver3d/svbi_loop3d_types.h`` from these lists
(``loop3d.h`` includes it); at run time :mod:`svbi.runtime.backends.c.stepper3d` builds its ctypes
mirrors of the structs and its messages of the status codes from the same lists, so the two cannot
disagree (``svbi generate --check``, tests/backends/test_loop3d_abi.py; the loop's ``svbi3d_sizes``
is checked at load as well).

This module imports nothing but the standard library and :mod:`svbi.codegen.loop_abi` (its
``Field``; standard library only too): the runtime imports it on the run path.
"""

from __future__ import annotations

from .loop_abi import F

TYPES3D_HEADER = "svbi_loop3d_types.h"
SOLVER3D_FOLDER = "solver3d"
"""``generated/solver3d/``: the 3D loop's generated header (the structs and status codes)."""

STATUS3D = (
    ("OK", "ok"),
    ("NOT_FINITE", "non-finite state"),
    ("SINGULAR", "singular system"),
    ("ACTIVE_SET", "the contact state did not settle"),
    ("IMPULSE", "the landing impulses did not settle"),
    ("FORCE_JUMP", "the force after a landing did not settle"),
    ("KERNEL", "a contact kernel failed"),
)
"""``S3_<name>`` of the generated header, numbered from 0 in this order, with the message the
stepper reports for each."""
STATUS3D_CODES = {name: code for code, (name, _) in enumerate(STATUS3D)}
STATUS3D_NAMES = {code: message for code, (_, message) in enumerate(STATUS3D)}


SETUP3D_FIELDS = [
    # sizes and switches
    F("nV", "int", "vehicle DOFs"),
    F("nW", "int", "wheelsets"),
    F("nF", "int", "free span DOFs"),
    F("nB", "int", "span DOFs"),
    F("nS", "int", "held support DOFs (0 without an earthquake)"),
    F("nE", "int", "span elements"),
    F("nblk", "int", "diagonal blocks of the vehicle (its cars)"),
    F("p", "int", "half bandwidth of the factor of K^_ff"),
    F("quake", "int", "1: the supports move (support targets and the ground under the wheelsets)"),
    F("creep", "int", "1: explicit creep forces"),
    F("bilateral", "int", "1: bilateral normal contact (no active set)"),
    F("chord", "int", "1: chord iterations after a pass's first Newton iteration; 0: Newton every iteration"),
    # scalars
    F("chord_rate", "double", "a chord shrinks the update by at least this, or the next is Newton's"),
    F("dt", "double", "time step (s)"),
    F("a0", "double", "Newmark 4/dt^2"),
    F("a1", "double", "Newmark 2/dt"),
    F("a2", "double", "Newmark 4/dt"),
    F("c1", "double", "constraint stabilisation 2 zeta omega (coefficient of the rate)"),
    F("c0", "double", "constraint stabilisation omega^2 (coefficient of the value)"),
    F("scale", "double", "a0 + c1 a1 + c0: scale of the stabilised residuals"),
    # vehicle: blocks [blk_start[b], blk_start[b + 1]) of the DOFs, dense blocks (row-major) at
    # blk_off[b]; M, C, K sparse (nV x nV CSR)
    F("blk_start", "int*", "nblk + 1: first DOF of every vehicle block"),
    F("blk_off", "long*", "nblk + 1: where every block's dense matrices start in AV and MVi"),
    F("AV", "double*", "the blocks of the vehicle compliance K^_V^-1"),
    F("MVi", "double*", "the blocks of the inverse vehicle mass"),
    F("MV_ptr", "int*", "nV + 1: CSR row pointers of the vehicle mass"),
    F("MV_idx", "int*", "its column indices"),
    F("CV_ptr", "int*", "nV + 1: CSR row pointers of the vehicle damping"),
    F("CV_idx", "int*", "its column indices"),
    F("KV_ptr", "int*", "nV + 1: CSR row pointers of the vehicle stiffness"),
    F("KV_idx", "int*", "its column indices"),
    F("MV_val", "double*", "vehicle mass values"),
    F("CV_val", "double*", "vehicle damping values"),
    F("KV_val", "double*", "vehicle stiffness values"),
    F("ws_dofs", "int*", "nW x 4: [y, z, phi, psi] of each wheelset"),
    F("ws_blk", "int*", "nW: the vehicle block of each wheelset"),
    F("geom", "double*", "nW x 8: the kernels' geometry argument"),
    F("material", "double*", "nW x 10: the creep law's material argument"),
    # span (dense matrices row-major)
    F("el_dofs", "int*", "nE x 12: full DOFs of each element"),
    F("full_to_free", "int*", "nB: free index or -1"),
    F("free_dofs", "int*", "nF: the free DOFs"),
    F("comp", "int*", "nF: connected part of the structure"),
    F("S", "double*", "nF x nF: compliance K^_ff^-1"),
    F("MBi", "double*", "nF x nF: M_ff^-1"),
    F(
        "MBi_cols",
        "int*",
        "nF x 2: the first and the last column of each row of MBi that are not zero (the parts of the "
        "structure: zero between them)",
    ),
    F(
        "band",
        "double*",
        "nF x (p + 1): Cholesky factor of K^_ff in perm order, L(j+r, j) at [j (p+1) + r], the "
        "diagonal as its reciprocal",
    ),
    F("perm", "int*", "nF: free index at band position k"),
    F("M_ptr", "int*", "nB + 1: CSR row pointers of the span mass"),
    F("M_idx", "int*", "its column indices"),
    F("M_val", "double*", "its values"),
    F("C_ptr", "int*", "nB + 1: CSR row pointers of the span damping"),
    F("C_idx", "int*", "its column indices"),
    F("C_val", "double*", "its values"),
    F("held", "int*", "nS: the supports' DOFs"),
    F("Kfs_ptr", "int*", "nF + 1: CSR row pointers of K^_fs (nF x nS)"),
    F("Kfs_idx", "int*", "its column indices"),
    F("Kfs_val", "double*", "its values"),
    F("CT_ptr", "int*", "nF + 1: CSR row pointers of (C T)_f (nF x nS)"),
    F("CT_idx", "int*", "its column indices"),
    F("CT_val", "double*", "its values"),
    F(
        "el_len",
        "double*",
        "nE: each deck element's length, entry 7 of a wheelset's geometry on it (geom's own entry 7 "
        "is taken on the ground)",
    ),
]
"""``setup3d_t``: everything constant over a run (arrays owned by Python)."""

STATE3D_FIELDS = [
    F("t", "double", "time of the state (s)"),
    F("q", "mdouble*", "nV: vehicle displacements"),
    F("qd", "mdouble*", "nV: vehicle velocities"),
    F("qdd", "mdouble*", "nV: vehicle accelerations"),
    F("u", "mdouble*", "nB: span displacements"),
    F("ud", "mdouble*", "nB: span velocities"),
    F("udd", "mdouble*", "nB: span accelerations"),
    F("P", "mdouble*", "2 nW: normal contact forces"),
    F("flange", "mdouble*", "2 nW: flange contact forces"),
    F("contact", "mint*", "4 nW: closed at t (in_contact)"),
    F("creep", "mdouble*", "nW x 6: creep forces"),
    F("creep_V", "mdouble*", "nV: the creep forces' load on the vehicle"),
    F("creep_B", "mdouble*", "nB: the creep forces' load on the span"),
    F("load", "mdouble*", "nV: the vehicle's load (gravity and system.load)"),
]
"""``state3d_t``: the state at t_n, updated in place to the last step."""

CHUNK3D_FIELDS = [
    # the excitation of k steps (Excitation3D)
    F("element", "int*", "k x nW: element under each wheelset (-1: the ground)"),
    F("xi", "double*", "k x nW: local coordinate on it"),
    F("irr", "double*", "k x nW x 9: rail irregularities"),
    F("ground", "double*", "k x 3 x nW x 12, or NULL: the ground under the wheelsets"),
    F("support", "double*", "k x 3 x nS, or NULL: the supports' targets"),
    # the outputs (Chunk3D)
    F("t", "mdouble*", "k: times"),
    F("q", "mdouble*", "k x nV"),
    F("qd", "mdouble*", "k x nV"),
    F("qdd", "mdouble*", "k x nV"),
    F("u", "mdouble*", "k x nB"),
    F("ud", "mdouble*", "k x nB"),
    F("udd", "mdouble*", "k x nB"),
    F("P", "mdouble*", "k x 2 nW"),
    F("flange", "mdouble*", "k x 2 nW"),
    F("contact", "mint*", "k x 4 nW"),
    F("creep", "mdouble*", "k x nW x 6"),
    F("gaps", "mdouble*", "k x 2 nW (NaN where not evaluated)"),
    F("every", "long", "the normal gaps at the steps with (n + 1) % every == 0"),
]
"""``chunk3d_t``: the excitation of k steps and the outputs."""

INFO3D_FIELDS = [
    F("steps", "long", "steps done"),
    F("step", "long", "the step that failed (n)"),
    F("status", "int", "0 ok, else an S3_* code"),
    F("wheelset", "int", "where known"),
    F("iterations", "long", "interface iterations, all steps"),
    F("passes", "long", "active-set passes, all steps"),
    F("factorizations", "long", "interface matrices formed and factored (Newton iterations), all steps"),
]
"""``info3d_t``: how a call went."""

STRUCTS3D = {
    "setup3d_t": SETUP3D_FIELDS,
    "state3d_t": STATE3D_FIELDS,
    "chunk3d_t": CHUNK3D_FIELDS,
    "info3d_t": INFO3D_FIELDS,
}
"""The C name of every struct and its members, in the order of ``svbi3d_sizes``."""
