"""The 3D C loop's shortcuts (docs/c-backend.md, "The 3D loop"), each against an independent
answer:

* the dense LU of the interface and of the impact's complementarity problems (``lu_solve3``; the
  interface's factors kept and applied later, ``lu_factor3`` and ``lu_back3``)
  follows each row's last nonzero, so a band (the interface of a train, in train order) costs its
  profile: its solutions against LAPACK's (``numpy.linalg.solve``) on a dense matrix, a band that
  needs row exchanges (which widen the rows: fill-in past the band), rows of very different
  lengths, and a zero pivot;
* the chunk's output buffers kept from call to call (``advance(..., reuse=True)``): the same
  numbers as fresh buffers, the memory reused.

The couplings found again only when a wheelset changes element and the interface built over the
coupled pairs are the whole loop's path: tests/backends/test_loop3d_c.py holds them to the NumPy
step on a chain of spans, wheelsets on a support element, the approach track, a continuous girder
on a pier.
"""

from __future__ import annotations

import ctypes

import numpy as np
import pytest

try:  # the compiler is needed
    from svbi.runtime.backends.c.stepper3d import load_loop3d

    LIB = load_loop3d()
except Exception as exc:  # pragma: no cover - no C compiler
    pytest.skip(f"no C compiler for the 3D loop: {exc}", allow_module_level=True)


def lu_solve3(a: np.ndarray, b: np.ndarray) -> tuple[int, np.ndarray]:
    """The C solve of a x = b (its status and x)."""
    n = a.shape[0]
    A = np.ascontiguousarray(a, dtype=float).copy()
    x = np.ascontiguousarray(b, dtype=float).copy()
    piv = np.zeros(max(n, 1), dtype=np.int32)
    f = LIB.lu_solve3
    f.restype = ctypes.c_int
    f.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p]
    status = f(A.ctypes.data, n, x.ctypes.data, piv.ctypes.data)
    return status, x


def lu_factored(a: np.ndarray, b: np.ndarray) -> tuple[int, np.ndarray]:
    """The interface's route: ``lu_factor3`` (the factors kept), then ``lu_back3`` (its status, x)."""
    n = a.shape[0]
    A = np.ascontiguousarray(a, dtype=float).copy()
    x = np.ascontiguousarray(b, dtype=float).copy()
    piv, last, first = (np.zeros(max(n, 1), dtype=np.int32) for _ in range(3))
    f = LIB.lu_factor3
    f.restype = ctypes.c_int
    f.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
    status = f(A.ctypes.data, n, piv.ctypes.data, last.ctypes.data, first.ctypes.data)
    if status == 0:
        g = LIB.lu_back3
        g.restype = None
        g.argtypes = [ctypes.c_void_p, ctypes.c_int] + [ctypes.c_void_p] * 4
        g(A.ctypes.data, n, piv.ctypes.data, last.ctypes.data, first.ctypes.data, x.ctypes.data)
    return status, x


def band(n: int, lower: int, upper: int, rng: np.random.Generator) -> np.ndarray:
    a = rng.standard_normal((n, n))
    i, j = np.indices((n, n))
    return np.where((j - i <= upper) & (i - j <= lower), a, 0.0)


def check(a: np.ndarray, rng: np.random.Generator) -> None:
    b = rng.standard_normal(a.shape[0])
    status, x = lu_solve3(a, b)
    assert status == 0
    truth = np.linalg.solve(a, b)
    # both backward stable: the difference within the condition number times round-off
    bound = 1e-13 * np.linalg.cond(a) * np.abs(truth).max()
    assert np.abs(x - truth).max() <= bound, (np.abs(x - truth).max(), bound)
    assert np.abs(a @ x - b).max() <= 1e-12 * np.abs(a).max() * np.abs(x).max() * a.shape[0]
    # the factors kept in the caller's arrays and applied by a later call (the chord iterations'
    # route): the same x bit for bit
    status2, x2 = lu_factored(a, b)
    assert status2 == 0 and np.array_equal(x2, x)


def test_dense_matrix() -> None:
    rng = np.random.default_rng(1)
    check(rng.standard_normal((40, 40)), rng)


def test_band_with_row_exchanges_and_fill_in() -> None:
    """A band of half-widths 6 and 3 whose diagonal is small: partial pivoting exchanges rows at
    most steps, and the exchanged rows reach past the band (the profile must follow them)."""
    rng = np.random.default_rng(2)
    a = band(80, 6, 3, rng)
    a[np.diag_indices(80)] *= 1e-3
    check(a, rng)


def test_rows_of_different_lengths() -> None:
    """An arrow: a band plus a full last column and a full last row (rows ending at the last
    column and rows ending early, in one matrix)."""
    rng = np.random.default_rng(3)
    a = band(50, 2, 2, rng)
    a[:, -1] = rng.standard_normal(50)
    a[-1, :] = rng.standard_normal(50)
    check(a, rng)
    check(a.T.copy(), rng)


def test_block_diagonal_with_an_empty_row_start() -> None:
    """Blocks along the diagonal (independent spans), the first row's only nonzero in its last
    column: the first pivot is in another row."""
    rng = np.random.default_rng(4)
    a = np.zeros((12, 12))
    for s in range(0, 12, 4):
        a[s : s + 4, s : s + 4] = rng.standard_normal((4, 4))
    a[0, :] = 0.0
    a[0, 3] = 2.0
    check(a, rng)


def test_band_rows_out_of_order() -> None:
    """A band whose rows are shuffled: rows that start late sit above rows that start early (the
    factorisation's bound on the rows that reach a column comes from where the rows start, not
    from their order)."""
    rng = np.random.default_rng(6)
    a = band(60, 4, 5, rng)[rng.permutation(60)]
    check(a, rng)


def test_a_zero_pivot_is_singular() -> None:
    a = np.eye(5)
    a[2, 2] = 0.0
    status, _ = lu_solve3(a, np.ones(5))
    assert lu_factored(a, np.ones(5))[0] != 0
    assert status == 2  # S3_SINGULAR


def test_reused_chunk_buffers_hold_the_same_numbers() -> None:
    """Two steppers from one state, one writing fresh arrays, the other its kept buffers: the same
    chunks bit for bit; the kept buffers are the same memory from call to call (a longer chunk
    grows them)."""
    from cases import SW_CONICITY, SW_DECK, copy_state3d, sprung_wheelset3d

    from svbi.runtime.backends.c.stepper3d import LocalizedDynamic3DC
    from svbi.runtime.methods.coupled3d import static_state
    from svbi.runtime.model.bridge import Girder, Section
    from svbi.runtime.model.bridge3d import Bridge3D, section3d
    from svbi.runtime.model.system3d import System3D, Track3D

    deck = Section(**SW_DECK, damping_ratio=0.02)
    bridge = Bridge3D([Girder((10.0, 10.0), deck)], 4, [section3d(deck, 10.0, 5.0)])
    system = System3D(
        sprung_wheelset3d(damped=True), bridge, Track3D(conicity=SW_CONICITY), speed=20.0, start=4.0
    )
    state = static_state(system)
    fresh = LocalizedDynamic3DC(system, copy_state3d(state), 1e-3)
    kept = LocalizedDynamic3DC(system, copy_state3d(state), 1e-3)
    rng = np.random.default_rng(5)
    n, seen = 0, []
    for k in (20, 20, 30, 10):
        irr = 1e-4 * rng.standard_normal((k, 1, 9))
        a = fresh.advance(n, k, irr, 5)
        b = kept.advance(n, k, irr, 5, reuse=True)
        assert fresh.stopped is None and kept.stopped is None
        for name in ("t", "q", "qd", "qdd", "u", "ud", "udd", "P", "flange", "contact", "creep", "gaps"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
        seen.append(b.u.__array_interface__["data"][0])
        n += k
    assert seen[0] == seen[1] != seen[2] == seen[3]


def test_the_impact_over_the_parts_of_the_structure_is_the_dense_one() -> None:
    """The impact of a landing forms the inverse mass's responses over the columns of each row of
    M_B^-1 that are not zero (``MBi_cols``: the parts of the structure) and over the closed
    constraints only: three cars whose wheels all lift off at once and land over the next steps on a
    chain of three spans give the chunks of the same loop told that every column is nonzero, bit
    for bit; and the columns were restricted (each span's rows)."""
    from cases import copy_state3d
    from test_loop3d_c import irregularity, landing_next_to_supports

    from svbi.runtime.backends.c.stepper3d import LocalizedDynamic3DC
    from svbi.runtime.methods.coupled3d import static_state

    system = landing_next_to_supports()
    state = static_state(system)
    dt, steps = 1e-4, 120
    level = np.array([irregularity(system, (m + 1) * dt) for m in range(steps)])
    parts = LocalizedDynamic3DC(system, copy_state3d(state), dt)
    dense = LocalizedDynamic3DC(system, copy_state3d(state), dt)
    nF = len(system.span.free)
    pointer = ctypes.cast(parts.setup.MBi_cols, ctypes.POINTER(ctypes.c_int32))
    cols = np.ctypeslib.as_array(pointer, shape=(nF, 2))
    assert (cols[:, 1] - cols[:, 0] + 1).max() < nF / 2  # a span's rows: a third of the DOFs
    every = np.ascontiguousarray(np.stack([np.zeros(nF), np.full(nF, nF - 1)], axis=1), dtype=np.int32)
    dense.setup.MBi_cols = dense._ptr(every)
    a = parts.advance(0, steps, level, 5)
    b = dense.advance(0, steps, level, 5)
    assert parts.stopped is None and dense.stopped is None
    landed = a.contact[1:, :] & ~a.contact[:-1, :]
    assert landed.sum() >= 5  # impacts at several steps
    for name in ("t", "q", "qd", "qdd", "u", "ud", "udd", "P", "flange", "contact", "creep", "gaps"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
