"""The C loop's numerical building blocks, function by function, against SciPy and NumPy.

``runtime/csrc/band.c`` (banded Cholesky and its solves, banded LU with partial pivoting and its
reciprocal-pivot variant, dense Cholesky) and ``runtime/csrc/tables.c`` (piecewise-polynomial
tables) depend on no topology: they are compiled here on their own, with the generated
``svbi_solver_types.h``, into a small library and called through ctypes. The same library carries
a helper that reports ``sizeof`` and ``offsetof`` of every generated struct, which must equal the
ctypes mirrors of ``svbi.runtime.backends.c.build`` (both come from its field lists).

Truth: ``scipy.linalg.cholesky_banded`` / ``cho_solve_banded`` / ``solve_banded``,
``numpy.linalg.solve`` and ``scipy.interpolate.PPoly``. Tolerances are round-off of the condition
numbers involved (the random matrices are kept well conditioned).
"""

from __future__ import annotations

import ctypes
from functools import cache

import numpy as np
import pytest
import scipy.interpolate
import scipy.linalg

from svbi.codegen import loop_abi
from svbi.runtime import toolchain as kernel_cache
from svbi.runtime.backends.c import build as c_solver_build

SW = 4  # spans per block of band_solve_blocked (runtime/csrc/band.h)
STRUCTS = {
    "svbi_ppoly": ("ppoly", c_solver_build.PPoly),
    "svbi_solver_setup": ("setup", c_solver_build.Setup),
    "svbi_solver_state": ("state", c_solver_build.State),
    "svbi_solver_excitation": ("excitation", c_solver_build.Excitation),
    "svbi_solver_outputs": ("outputs", c_solver_build.Outputs),
    "svbi_solver_info": ("info", c_solver_build.Info),
}

DP = ctypes.POINTER(ctypes.c_double)
IP = ctypes.POINTER(ctypes.c_int)


def _layout_source() -> bytes:
    """C that reports sizeof and offsetof of every struct member of svbi_solver_types.h."""
    lines = ["#include <stddef.h>", '#include "svbi_solver_types.h"', ""]
    for ctype, (key, _) in STRUCTS.items():
        fields = loop_abi.STRUCTS[key]
        values = [f"(long)sizeof({ctype})"] + [f"(long)offsetof({ctype}, {f.name})" for f in fields]
        lines.append(f"const long svbi_layout_{key}[{len(values)}] = {{{', '.join(values)}}};")
    return ("\n".join(lines) + "\n").encode()


@cache
def library() -> ctypes.CDLL:
    static = c_solver_build.static_sources()
    sources = {n: static[n] for n in ("band.c", "band.h", "tables.c", "tables.h", "roots.c", "roots.h")}
    types = c_solver_build.glue_sources(c_solver_build.LoopSpec("moving-load", 0, 0))[loop_abi.TYPES_HEADER]
    sources[loop_abi.TYPES_HEADER] = types
    sources["layout.c"] = _layout_source()
    lib = kernel_cache.load_library(sources, "svbi_test_c_numerics", flags=c_solver_build.LOOP_FLAGS)
    lib.svbi_band_cholesky.argtypes = [DP, ctypes.c_int, ctypes.c_int]
    lib.svbi_band_solve.argtypes = [DP, ctypes.c_int, ctypes.c_int, DP]
    lib.svbi_band_solve_blocked.argtypes = [DP, DP, ctypes.c_int, ctypes.c_int, DP, ctypes.c_long]
    lib.svbi_band_unit_factor.argtypes = [DP, ctypes.c_int, ctypes.c_int, DP, DP, DP]
    lib.svbi_band_solve_lanes.argtypes = [DP, DP, DP, ctypes.c_int, ctypes.c_int, DP, IP, ctypes.c_long]
    lib.svbi_dense_cholesky.argtypes = [DP, ctypes.c_int]
    lib.svbi_dense_solve.argtypes = [DP, ctypes.c_int, DP]
    lib.svbi_gb_factor.argtypes = [DP, ctypes.c_int, ctypes.c_int, IP]
    lib.svbi_gb_solve.argtypes = [DP, ctypes.c_int, ctypes.c_int, IP, DP]
    lib.svbi_gb_factor_solve_r.argtypes = [DP, ctypes.c_int, ctypes.c_int, IP, DP, DP]
    lib.svbi_ppoly_eval.argtypes = [ctypes.POINTER(c_solver_build.PPoly), ctypes.c_double, DP]
    lib.svbi_ppoly_eval_many.argtypes = [
        ctypes.POINTER(c_solver_build.PPoly),
        DP,
        ctypes.c_int,
        DP,
        ctypes.c_long,
    ]
    lib.svbi_ppoly_eval_many.restype = None
    lib.svbi_cube_root.argtypes = [ctypes.c_double]
    lib.svbi_cube_root.restype = ctypes.c_double
    for name in (
        "svbi_band_solve",
        "svbi_band_solve_blocked",
        "svbi_band_unit_factor",
        "svbi_band_solve_lanes",
        "svbi_dense_solve",
        "svbi_gb_solve",
    ):
        lib[name].restype = None
    lib.svbi_ppoly_eval.restype = None
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


def spd_band(rng: np.random.Generator, n: int, p: int) -> np.ndarray:
    """A random symmetric positive definite matrix of half bandwidth p (dense)."""
    a = np.zeros((n, n))
    for k in range(1, p + 1):
        d = rng.uniform(-1.0, 1.0, n - k)
        a += np.diag(d, k) + np.diag(d, -k)
    return a + np.diag(2.0 * p + 1.0 + rng.uniform(0.0, 1.0, n))


def lower_band(a: np.ndarray, p: int) -> np.ndarray:
    """SciPy's lower band form: ab[r, j] = A[j + r, j]."""
    n = a.shape[0]
    ab = np.zeros((p + 1, n))
    for r in range(p + 1):
        ab[r, : n - r] = np.diag(a, -r)
    return ab


# --------------------------------------------------------------------------------------------------
# struct layouts


@pytest.mark.parametrize("ctype", sorted(STRUCTS))
def test_generated_structs_match_the_ctypes_mirrors(ctype: str) -> None:
    key, mirror = STRUCTS[ctype]
    fields = loop_abi.STRUCTS[key]
    values = (ctypes.c_long * (len(fields) + 1)).in_dll(library(), f"svbi_layout_{key}")
    assert values[0] == ctypes.sizeof(mirror)
    for i, f in enumerate(fields):
        assert values[i + 1] == getattr(mirror, f.name).offset, f.name


# --------------------------------------------------------------------------------------------------
# banded Cholesky


@pytest.mark.parametrize(("n", "p"), [(1, 0), (7, 1), (30, 3), (41, 8), (12, 11)])
def test_band_cholesky_and_solve_match_scipy(n: int, p: int) -> None:
    rng = np.random.default_rng(100 * n + p)
    a = spd_band(rng, n, p)
    ab = lower_band(a, p)
    factor = np.array(ab.T, order="C")  # band.h: L[j * (p + 1) + (i - j)] = column j, row i
    assert library().svbi_band_cholesky(dp(factor), n, p) == loop_abi.STATUS_OK
    np.testing.assert_allclose(factor.T, scipy.linalg.cholesky_banded(ab, lower=True), rtol=1e-13, atol=1e-14)
    b = rng.standard_normal(n)
    x = b.copy()
    library().svbi_band_solve(dp(factor), n, p, dp(x))
    expected = scipy.linalg.cho_solve_banded((scipy.linalg.cholesky_banded(ab, lower=True), True), b)
    np.testing.assert_allclose(x, expected, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(a @ x, b, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("nblk", [1, 3])
def test_band_solve_blocked_solves_every_right_hand_side(nblk: int) -> None:
    """B[j * m + s], m = nblk * SW: every column s is one solve (the localized layout)."""
    rng = np.random.default_rng(nblk)
    n, p, m = 25, 4, nblk * SW
    a = spd_band(rng, n, p)
    ab = lower_band(a, p)
    factor = np.array(ab.T, order="C")
    assert library().svbi_band_cholesky(dp(factor), n, p) == loop_abi.STATUS_OK
    dinv = np.ascontiguousarray(1.0 / factor[:, 0])
    b = rng.standard_normal((n, m))
    x = b.copy()
    library().svbi_band_solve_blocked(dp(factor), dp(dinv), n, p, dp(x), nblk)
    expected = scipy.linalg.cho_solve_banded((scipy.linalg.cholesky_banded(ab, lower=True), True), b)
    np.testing.assert_allclose(x, expected, rtol=1e-12, atol=1e-13)


LW = 4  # lanes per group of svbi_band_solve_lanes (runtime/csrc/band.h)


@pytest.mark.parametrize(
    ("p", "m", "permuted"), [(1, 4, False), (3, 12, True), (3, 20, False), (5, 8, True), (6, 36, True)]
)
def test_band_solve_lanes_solves_every_lane(p: int, m: int, permuted: bool) -> None:
    """The span solves of both methods (svbi_band_unit_factor, then svbi_band_solve_lanes: the last
    rows in registers, three groups of LW lanes at a time and the rest): every lane one solve, rows
    placed through ``rows`` (the localized predictor's free DOFs) or in order (no rows), against SciPy."""
    rng = np.random.default_rng(10 * p + m)
    n = 48
    a = spd_band(rng, n, p)
    ab = lower_band(a, p)
    factor = np.array(ab.T, order="C")
    assert library().svbi_band_cholesky(dp(factor), n, p) == loop_abi.STATUS_OK
    fw, bk, dinv2 = np.zeros(n * p), np.zeros(n * p), np.zeros(n)
    library().svbi_band_unit_factor(dp(factor), n, p, dp(fw), dp(bk), dp(dinv2))
    rows = (rng.permutation(n + 3)[:n] if permuted else np.arange(n)).astype(np.int32)
    b = rng.standard_normal((n, m))
    x = rng.standard_normal((n + 3, m))  # unused rows stay as they are
    x[rows] = b
    before = x.copy()
    library().svbi_band_solve_lanes(dp(fw), dp(bk), dp(dinv2), n, p, dp(x), ip(rows) if permuted else None, m)
    expected = scipy.linalg.cho_solve_banded((scipy.linalg.cholesky_banded(ab, lower=True), True), b)
    np.testing.assert_allclose(x[rows], expected, rtol=1e-12, atol=1e-13)
    untouched = np.setdiff1d(np.arange(n + 3), rows)
    np.testing.assert_array_equal(x[untouched], before[untouched])


def test_band_cholesky_reports_a_matrix_that_is_not_positive_definite() -> None:
    a = spd_band(np.random.default_rng(5), 10, 2)
    a[6, 6] = -1.0
    factor = np.array(lower_band(a, 2).T, order="C")
    assert library().svbi_band_cholesky(dp(factor), 10, 2) == loop_abi.STATUS_NOT_SPD


# --------------------------------------------------------------------------------------------------
# banded LU with partial pivoting


def general_band(rng: np.random.Generator, n: int, bw: int) -> np.ndarray:
    """A random general band matrix whose diagonal is small: partial pivoting has to swap rows."""
    a = np.zeros((n, n))
    for k in range(-bw, bw + 1):
        a += np.diag(rng.uniform(-1.0, 1.0, n - abs(k)), k)
    a[np.arange(n), np.arange(n)] *= 1e-3
    return a


def lapack_band(a: np.ndarray, bw: int) -> np.ndarray:
    """band.h's general layout: row c of the result holds column c, A(r, c) at 2 bw + r - c."""
    n = a.shape[0]
    out = np.zeros((n, 3 * bw + 1))
    for c in range(n):
        for r in range(max(0, c - bw), min(n, c + bw + 1)):
            out[c, 2 * bw + r - c] = a[r, c]
    return out


@pytest.mark.parametrize(("n", "bw"), [(1, 0), (6, 1), (40, 3), (33, 7)])
def test_banded_lu_matches_scipy_solve_banded(n: int, bw: int) -> None:
    rng = np.random.default_rng(10 * n + bw)
    a = general_band(rng, n, bw)
    if n == 1:
        a[0, 0] = 0.7
    ab = lapack_band(a, bw)
    piv = np.zeros(n, dtype=np.int32)
    assert library().svbi_gb_factor(dp(ab), n, bw, ip(piv)) == loop_abi.STATUS_OK
    if n > 1:
        assert np.any(piv != np.arange(n))  # it did pivot
    b = rng.standard_normal(n)
    x = b.copy()
    library().svbi_gb_solve(dp(ab), n, bw, ip(piv), dp(x))
    scipy_ab = np.zeros((2 * bw + 1, n))
    for c in range(n):
        for r in range(max(0, c - bw), min(n, c + bw + 1)):
            scipy_ab[bw + r - c, c] = a[r, c]
    expected = scipy.linalg.solve_banded((bw, bw), scipy_ab, b)
    cond = np.linalg.cond(a)
    np.testing.assert_allclose(x, expected, rtol=1e-14 * cond, atol=1e-14 * cond * np.abs(expected).max())
    np.testing.assert_allclose(x, np.linalg.solve(a, b), rtol=1e-14 * cond, atol=1e-14 * cond)


def test_banded_lu_reports_a_singular_matrix() -> None:
    a = general_band(np.random.default_rng(3), 8, 2)
    a[:, 4] = 0.0
    ab = lapack_band(a, 2)
    piv = np.zeros(8, dtype=np.int32)
    assert library().svbi_gb_factor(dp(ab), 8, 2, ip(piv)) == loop_abi.STATUS_SINGULAR


# the reciprocal-pivot variant of the localized interface, factor and solve in one pass
# (svbi_gb_factor_solve_r)


def factor_solve_r(
    a: np.ndarray, bw: int, b: np.ndarray
) -> tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """svbi_gb_factor_solve_r on ``a``'s band and a copy of ``b``: status, factor (band.h's layout),
    pivots, reciprocal pivots, solution."""
    n = a.shape[0]
    ab, piv, rpiv, x = lapack_band(a, bw), np.zeros(n, dtype=np.int32), np.zeros(n), np.array(b, dtype=float)
    status = library().svbi_gb_factor_solve_r(dp(ab), n, bw, ip(piv), dp(rpiv), dp(x))
    return status, ab, piv, rpiv, x


@pytest.mark.parametrize(("n", "bw"), [(1, 0), (6, 1), (40, 5), (33, 7)])
def test_reciprocal_pivot_lu_matches_scipy(n: int, bw: int) -> None:
    rng = np.random.default_rng(7 * n + bw)
    a = general_band(rng, n, bw)
    if n == 1:
        a[0, 0] = 0.7
    b = rng.standard_normal(n)
    status, _, piv, _, x = factor_solve_r(a, bw, b)
    assert status == loop_abi.STATUS_OK
    ref, ref_piv = lapack_band(a, bw), np.zeros(n, dtype=np.int32)
    assert library().svbi_gb_factor(dp(ref), n, bw, ip(ref_piv)) == loop_abi.STATUS_OK
    np.testing.assert_array_equal(piv, ref_piv)  # the same pivoting
    if n > 1:
        assert np.any(piv != np.arange(n))  # it did pivot
    scipy_ab = np.zeros((2 * bw + 1, n))
    for c in range(n):
        for r in range(max(0, c - bw), min(n, c + bw + 1)):
            scipy_ab[bw + r - c, c] = a[r, c]
    expected = scipy.linalg.solve_banded((bw, bw), scipy_ab, b)
    cond = np.linalg.cond(a)
    np.testing.assert_allclose(x, expected, rtol=1e-14 * cond, atol=1e-14 * cond * np.abs(expected).max())
    np.testing.assert_allclose(x, np.linalg.solve(a, b), rtol=1e-14 * cond, atol=1e-14 * cond)


def doolittle_reciprocal(a: np.ndarray, bw: int) -> tuple[np.ndarray, np.ndarray]:
    """LU without row swaps in band.c's operations, one IEEE operation at a time: each column's
    multipliers are its entries times the reciprocal pivot, and every entry of the trailing band
    loses multiplier x pivot-row entry once per column. Returns (L U packed, reciprocal pivots)."""
    lu, n = a.copy(), a.shape[0]
    rpiv = np.zeros(n)
    for j in range(n):
        rpiv[j] = 1.0 / lu[j, j]
        rows = slice(j + 1, min(n, j + bw + 1))
        lu[rows, j] = lu[rows, j] * rpiv[j]
        lu[rows, rows] -= np.outer(lu[rows, j], lu[j, rows])  # each entry: one product, one difference
    return lu, rpiv


def substitute_reciprocal(lu: np.ndarray, rpiv: np.ndarray, bw: int, b: np.ndarray) -> np.ndarray:
    """The solve with doolittle_reciprocal's factor, every row's terms subtracted farthest first."""
    n, x = len(b), [float(v) for v in b]
    for j in range(n):
        for i in range(min(bw, j), 0, -1):
            x[j] -= float(lu[j, j - i]) * x[j - i]
    for j in range(n - 1, -1, -1):
        for i in range(min(bw, n - 1 - j), 0, -1):
            x[j] -= float(lu[j, j + i]) * x[j + i]
        x[j] *= float(rpiv[j])
    return np.array(x)


@pytest.mark.parametrize(("n", "bw"), [(1, 1), (7, 1), (40, 5), (30, 8), (12, 9)])
def test_reciprocal_pivot_lu_without_swaps_is_the_textbook_elimination(n: int, bw: int) -> None:
    """A diagonally dominant band (the localized interface's usual case) is factored on the
    diagonal (band.c, diagonal_columns, the forward substitution along) and solved backward row by
    row (backward_rows): bit for bit the elimination of doolittle_reciprocal, and NumPy's solution
    to round-off."""
    rng = np.random.default_rng(5 * n + bw)
    a = general_band(rng, n, bw)
    a[np.arange(n), np.arange(n)] = 2.0 * bw + 1.0 + rng.uniform(0.0, 1.0, n)
    b = rng.standard_normal(n)
    status, ab, piv, rpiv, x = factor_solve_r(a, bw, b)
    assert status == loop_abi.STATUS_OK
    np.testing.assert_array_equal(piv, np.arange(n))
    lu, ref_rpiv = doolittle_reciprocal(a, bw)
    np.testing.assert_array_equal(rpiv, ref_rpiv)
    np.testing.assert_array_equal(ab, lapack_band(lu, bw))
    np.testing.assert_array_equal(x, substitute_reciprocal(lu, ref_rpiv, bw, b))
    np.testing.assert_allclose(x, np.linalg.solve(a, b), rtol=1e-13, atol=1e-14)


@pytest.mark.parametrize("bw", [2, 5])
def test_reciprocal_pivot_lu_swaps_from_the_first_column_that_needs_it(bw: int) -> None:
    """Diagonally dominant in its first half, not in its second: the diagonal columns hand over to
    partial pivoting where the first swap is due, with the pivots of svbi_gb_factor."""
    n = 40
    rng = np.random.default_rng(bw)
    a = general_band(rng, n, bw)
    a[np.arange(n // 2), np.arange(n // 2)] = 2.0 * bw + 1.0
    b = rng.standard_normal(n)
    status, _, piv, _, x = factor_solve_r(a, bw, b)
    assert status == loop_abi.STATUS_OK
    ref, ref_piv = lapack_band(a, bw), np.zeros(n, dtype=np.int32)
    assert library().svbi_gb_factor(dp(ref), n, bw, ip(ref_piv)) == loop_abi.STATUS_OK
    np.testing.assert_array_equal(piv, ref_piv)
    first_swap = int(np.flatnonzero(piv != np.arange(n))[0])
    assert n // 2 - bw <= first_swap  # the dominant half kept its diagonal
    cond = np.linalg.cond(a)
    np.testing.assert_allclose(x, np.linalg.solve(a, b), rtol=1e-14 * cond, atol=1e-14 * cond)


def test_reciprocal_pivot_lu_reports_a_singular_matrix() -> None:
    a = general_band(np.random.default_rng(3), 8, 2)
    a[:, 4] = 0.0
    assert factor_solve_r(a, 2, np.ones(8))[0] == loop_abi.STATUS_SINGULAR


# --------------------------------------------------------------------------------------------------
# dense Cholesky (the car blocks of the coupled methods)


@pytest.mark.parametrize("n", [1, 2, 14])
def test_dense_cholesky_solve_matches_numpy(n: int) -> None:
    rng = np.random.default_rng(n)
    m = rng.standard_normal((n, n))
    a = m @ m.T + n * np.eye(n)
    factor = np.array(a, order="C")
    assert library().svbi_dense_cholesky(dp(factor), n) == loop_abi.STATUS_OK
    np.testing.assert_allclose(np.tril(factor), np.linalg.cholesky(a), rtol=1e-13, atol=1e-14)
    b = rng.standard_normal(n)
    x = b.copy()
    library().svbi_dense_solve(dp(factor), n, dp(x))
    np.testing.assert_allclose(x, np.linalg.solve(a, b), rtol=1e-12, atol=1e-14)
    a[0, 0] = -1.0
    assert library().svbi_dense_cholesky(dp(np.ascontiguousarray(a)), n) == loop_abi.STATUS_NOT_SPD


# --------------------------------------------------------------------------------------------------
# piecewise-polynomial tables


def table(pp: scipy.interpolate.PPoly, uniform: bool, keep: list) -> c_solver_build.PPoly:
    """The C table of ``pp`` (tables.h: c[i][m] = PPoly.c[m, i]), constant beyond both ends."""
    x = np.ascontiguousarray(pp.x, dtype=float)
    c = np.ascontiguousarray(pp.c.T, dtype=float)
    keep += [x, c]
    left = [float(pp(x[0], nu)) for nu in range(3)]
    right = [float(pp(x[-1], nu)) for nu in range(3)]
    return c_solver_build.PPoly(
        n=len(x) - 1,
        k=pp.c.shape[0] - 1,
        uniform=int(uniform),
        h=float((x[-1] - x[0]) / (len(x) - 1)),
        x=x.ctypes.data,
        c=c.ctypes.data,
        left0=left[0],
        left1=left[1],
        left2=left[2],
        right0=right[0],
        right1=right[1],
        right2=right[2],
    )


def evaluate(p: c_solver_build.PPoly, x: float) -> np.ndarray:
    out = np.zeros(3)
    library().svbi_ppoly_eval(ctypes.byref(p), x, dp(out))
    return out


@pytest.mark.parametrize(
    ("k", "breaks"), [(1, "uniform"), (3, "uniform"), (5, "nearly-uniform"), (3, "random"), (5, "random")]
)
def test_ppoly_eval_matches_scipy_ppoly(k: int, breaks: str) -> None:
    rng = np.random.default_rng(k)
    n = 37
    if breaks == "random":
        x = np.cumsum(rng.uniform(0.1, 2.0, n + 1))
    else:
        x = 0.5 + 0.25 * np.arange(n + 1)
        if breaks == "nearly-uniform":  # the O(1) guess, then the exact interval
            x[1:-1] += rng.uniform(-1e-7, 1e-7, n - 1)
    pp = scipy.interpolate.PPoly(rng.standard_normal((k + 1, n)), x)
    keep: list = []
    p = table(pp, breaks != "random", keep)
    points = np.concatenate([rng.uniform(x[0], x[-1], 300), x[:-1], x[1:-1] - 1e-12])
    for xv in points:
        got = evaluate(p, float(xv))
        want = np.array([pp(xv, nu) for nu in range(3)])
        scale = 1.0 + np.abs(want)
        # measured: 1.4e-15 of (1 + |value|) at worst over these cases
        assert np.all(np.abs(got - want) <= 1e-13 * scale), (xv, got, want)
    # beyond the ends: the end values (the C tables clamp; NumPy's callers stop earlier)
    np.testing.assert_array_equal(evaluate(p, x[0] - 3.0), [p.left0, p.left1, p.left2])
    np.testing.assert_array_equal(evaluate(p, x[0]), [p.left0, p.left1, p.left2])
    np.testing.assert_array_equal(evaluate(p, x[-1]), [p.right0, p.right1, p.right2])
    np.testing.assert_array_equal(evaluate(p, x[-1] + 5.0), [p.right0, p.right1, p.right2])


@pytest.mark.parametrize(("k", "breaks"), [(3, "uniform"), (5, "nearly-uniform"), (5, "random")])
def test_ppoly_eval_many_is_the_point_by_point_evaluation(k: int, breaks: str) -> None:
    """The batched evaluation (the rail under every contact at once) gives, point by point, the bits
    of svbi_ppoly_eval: inside, at the breaks, beyond both ends, over more than one block of 64."""
    rng = np.random.default_rng(10 + k)
    n = 29
    x = np.cumsum(rng.uniform(0.1, 2.0, n + 1)) if breaks == "random" else 1.0 + 0.5 * np.arange(n + 1)
    if breaks == "nearly-uniform":
        x[1:-1] += rng.uniform(-1e-7, 1e-7, n - 1)
    pp = scipy.interpolate.PPoly(rng.standard_normal((k + 1, n)), x)
    keep: list = []
    p = table(pp, breaks != "random", keep)
    points = np.concatenate([rng.uniform(x[0] - 2.0, x[-1] + 2.0, 150), x, [x[0] - 1.0, x[-1] + 1.0]])
    stride = points.size + 3  # rows apart by more than the count: the stride is honoured
    out = np.full(3 * stride, np.nan)
    library().svbi_ppoly_eval_many(ctypes.byref(p), dp(points), points.size, dp(out), stride)
    got = out.reshape(3, stride)[:, : points.size].T
    want = np.array([evaluate(p, float(v)) for v in points])
    np.testing.assert_array_equal(got, want)
    assert np.isnan(out.reshape(3, stride)[:, points.size :]).all()


def test_cube_root_is_libm_cube_root_to_round_off() -> None:
    """The creep law's N^(1/3) (roots.c: a guess from the exponent bits, three Halley steps) against
    NumPy's cbrt, over forces from 1e-100 to 1e100 N and around the contact forces of a run; outside
    that range it is cbrt itself."""
    rng = np.random.default_rng(7)
    x = np.concatenate(
        [10.0 ** rng.uniform(-100.0, 100.0, 20000), rng.uniform(1.0, 3e5, 20000), [1e-100, 1.0, 8.0, 1e100]]
    )
    got = np.array([library().svbi_cube_root(float(v)) for v in x])
    # measured: 8.1e-16 at worst over 2e7 samples (about 4 ulp)
    np.testing.assert_allclose(got, np.cbrt(x), rtol=1e-15, atol=0.0)
    assert library().svbi_cube_root(8.0) == 2.0
    for v in (1e-300, 5e-101, 2e100, 1e300):  # outside: libm's cbrt
        assert library().svbi_cube_root(v) == pytest.approx(np.cbrt(v), rel=5e-16, abs=0.0)


def test_ppoly_without_intervals_is_a_step() -> None:
    """n = 0: a step at x[0] from the left values to the right values."""
    x = np.array([2.0])
    c = np.zeros(1)
    p = c_solver_build.PPoly(n=0, k=0, uniform=0, h=0.0, x=x.ctypes.data, c=c.ctypes.data)
    p.left0, p.left1, p.left2, p.right0, p.right1, p.right2 = 1.0, 2.0, 3.0, 4.0, 5.0, 6.0
    np.testing.assert_array_equal(evaluate(p, 1.0), [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(evaluate(p, 2.0), [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(evaluate(p, 2.5), [4.0, 5.0, 6.0])
