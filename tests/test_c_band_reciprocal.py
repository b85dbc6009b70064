"""The banded LU with reciprocal pivots of the localized interface (``svbi_gb_factor_r`` /
``svbi_gb_solve_r`` in ``runtime/csrc/band.c``) against SciPy and against the LU it shortcuts.

Truth: ``scipy.linalg.solve_banded`` and ``numpy.linalg.solve`` to round-off of the condition
number (as ``test_c_numerics`` holds ``svbi_gb_factor``), the same pivots as ``svbi_gb_factor``,
and a zero pivot reported as singular.
"""

from __future__ import annotations

import ctypes
from functools import cache

import numpy as np
import pytest
import scipy.linalg
from svbi.runtime import c_solver_build, kernel_cache

DP = ctypes.POINTER(ctypes.c_double)
IP = ctypes.POINTER(ctypes.c_int)


@cache
def library() -> ctypes.CDLL:
    static = c_solver_build.static_sources()
    sources = {n: static[n] for n in ("band.c", "band.h")}
    glue = c_solver_build.glue_sources(c_solver_build.LoopSpec("moving-load", 0, 0))
    sources[c_solver_build.TYPES_HEADER] = glue[c_solver_build.TYPES_HEADER]
    lib = kernel_cache.load_library(sources, "svbi_test_c_band_reciprocal", flags=c_solver_build.LOOP_FLAGS)
    lib.svbi_gb_factor.argtypes = [DP, ctypes.c_int, ctypes.c_int, IP]
    lib.svbi_gb_factor_r.argtypes = [DP, ctypes.c_int, ctypes.c_int, IP, DP]
    lib.svbi_gb_solve_r.argtypes = [DP, ctypes.c_int, ctypes.c_int, IP, DP, DP]
    lib.svbi_gb_solve_r.restype = None
    return lib


def _compiler_works() -> bool:
    try:
        library()
    except kernel_cache.CompilerError:
        return False
    return True


pytestmark = pytest.mark.skipif(not _compiler_works(), reason="no working C compiler")


def dp(a: np.ndarray) -> ctypes._Pointer:
    assert a.dtype == np.float64 and a.flags.c_contiguous
    return a.ctypes.data_as(DP)


def ip(a: np.ndarray) -> ctypes._Pointer:
    assert a.dtype == np.int32 and a.flags.c_contiguous
    return a.ctypes.data_as(IP)


def general_band(rng: np.random.Generator, n: int, bw: int) -> np.ndarray:
    """A random band matrix whose diagonal is small: partial pivoting must swap rows."""
    a = np.zeros((n, n))
    for i in range(n):
        for j in range(max(0, i - bw), min(n, i + bw + 1)):
            a[i, j] = rng.uniform(-1.0, 1.0)
        a[i, i] *= 0.1
    return a


def lapack_band(a: np.ndarray, bw: int) -> np.ndarray:
    """band.h's general layout: row c of the result holds column c, A(r, c) at 2 bw + r - c."""
    n = a.shape[0]
    out = np.zeros((n, 3 * bw + 1))
    for c in range(n):
        for r in range(max(0, c - bw), min(n, c + bw + 1)):
            out[c, 2 * bw + r - c] = a[r, c]
    return out


@pytest.mark.parametrize(("n", "bw"), [(1, 0), (6, 1), (40, 5), (33, 7)])
def test_reciprocal_pivot_lu_matches_scipy(n: int, bw: int) -> None:
    rng = np.random.default_rng(7 * n + bw)
    a = general_band(rng, n, bw)
    if n == 1:
        a[0, 0] = 0.7
    ab = lapack_band(a, bw)
    piv, rpiv = np.zeros(n, dtype=np.int32), np.zeros(n)
    assert library().svbi_gb_factor_r(dp(ab), n, bw, ip(piv), dp(rpiv)) == c_solver_build.STATUS_OK
    ref, ref_piv = lapack_band(a, bw), np.zeros(n, dtype=np.int32)
    assert library().svbi_gb_factor(dp(ref), n, bw, ip(ref_piv)) == c_solver_build.STATUS_OK
    np.testing.assert_array_equal(piv, ref_piv)  # the same pivoting
    if n > 1:
        assert np.any(piv != np.arange(n))  # it did pivot
    b = rng.standard_normal(n)
    x = b.copy()
    library().svbi_gb_solve_r(dp(ab), n, bw, ip(piv), dp(rpiv), dp(x))
    scipy_ab = np.zeros((2 * bw + 1, n))
    for c in range(n):
        for r in range(max(0, c - bw), min(n, c + bw + 1)):
            scipy_ab[bw + r - c, c] = a[r, c]
    expected = scipy.linalg.solve_banded((bw, bw), scipy_ab, b)
    cond = np.linalg.cond(a)
    np.testing.assert_allclose(x, expected, rtol=1e-14 * cond, atol=1e-14 * cond * np.abs(expected).max())
    np.testing.assert_allclose(x, np.linalg.solve(a, b), rtol=1e-14 * cond, atol=1e-14 * cond)


def test_reciprocal_pivot_lu_reports_a_singular_matrix() -> None:
    a = general_band(np.random.default_rng(3), 8, 2)
    a[:, 4] = 0.0
    ab = lapack_band(a, 2)
    piv, rpiv = np.zeros(8, dtype=np.int32), np.zeros(8)
    assert library().svbi_gb_factor_r(dp(ab), 8, 2, ip(piv), dp(rpiv)) == c_solver_build.STATUS_SINGULAR
