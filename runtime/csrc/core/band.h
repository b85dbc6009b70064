/*
 * Small dense and banded linear algebra of svbi's C time loop (band.c). Independent of the
 * topology: tests/backends/test_c_numerics.py compiles band.c alone and checks it against SciPy and NumPy.
 *
 * Layouts:
 *  - symmetric positive definite band (Cholesky): the lower band by columns, element (i, j),
 *    i >= j, at L[j * (p + 1) + (i - j)] (p: half bandwidth);
 *  - general band (LU with partial pivoting, LAPACK's dgbtf2/dgbtrs): A(r, c) at
 *    AB[(kv + r - c) + c * ldab], kl = ku = bw, kv = 2 bw, ldab = 3 bw + 1;
 *  - dense: row-major n x n.
 */
#ifndef SVBI_SOLVER_BAND_H
#define SVBI_SOLVER_BAND_H

#include <string.h>

#include "svbi_solver_types.h"

/* where a routine is a template over constant sizes: inlined, so that its loops unroll */
#if defined(__GNUC__)
#define SVBI_ALWAYS_INLINE __attribute__((always_inline)) inline
#else
#define SVBI_ALWAYS_INLINE inline
#endif

/* lanes of the localized bridge state: spans padded to a multiple of LW ([DOF][spans]); four
 * doubles fill one AVX2 register (c_solver_build.simd_flags), two SSE2 registers */
#define LW 4
/* the lane solves (svbi_band_solve_lanes): FS_G groups of LW lanes side by side, the factor's
 * half-bandwidth at most FS_PMAX (a frame span's is 3 in reverse Cuthill-McKee order, 5 at most) */
#define FS_G 3
#define FS_PMAX 6
/* VW doubles as one value: the register of the lane loops that keep their values in registers (a
 * GNU C vector, the width of the target's registers; the build flags already ask for a
 * GCC-compatible compiler). VEC(p) is the VW doubles at p, read or written as one (vec_u: no
 * alignment assumed, may alias the doubles). */
#if defined(__AVX__)
#define VW 4
#else
#define VW 2
#endif
typedef double vec_t __attribute__((vector_size(VW * sizeof(double))));
typedef double vec_u __attribute__((vector_size(VW * sizeof(double)), aligned(sizeof(double)), may_alias));
#define VEC(p) (*(vec_u*)(p))
#define SW 4 /* spans per block of the localized bridge state ([block][DOF][SW], padded with zeros) */

/* Lower band Cholesky in place. Returns SVBI_SOLVER_STATUS_NOT_SPD on a non-positive pivot. */
int svbi_band_cholesky(double* L, int n, int p);

/* Solve L L^T x = b in place. */
void svbi_band_solve(const double* L, int n, int p, double* b);

/* Solve L L^T X = B in place for nblk * SW right-hand sides stored row by row (B[j * m + s],
 * m = nblk * SW); dinv holds the reciprocals of L's diagonal. */
void svbi_band_solve_blocked(const double* L, const double* dinv, int n, int p, double* b, long nblk);

/* The band Cholesky factor L (p <= FS_PMAX) as the unit triangle U = L D^-1 (D = diag L), dense in
 * its band: row j's U(j, j - r) at fw[j p + r - 1], column j's U(j + r, j) at bk[j p + r - 1] (zero
 * where nothing couples or beyond the matrix), and dinv2[j] = 1 / L(j, j)^2. */
void svbi_band_unit_factor(const double* L, int n, int p, double* fw, double* bk, double* dinv2);

/* Solve L L^T X = B in place with svbi_band_unit_factor's arrays, for m right-hand sides (m a
 * multiple of LW) held row after row: row j at b + row(j) m, row(j) = rows[j] (or j without rows). */
void svbi_band_solve_lanes(const double* fw, const double* bk, const double* dinv2, int n, int p, double* b,
                           const int* rows, long m);

/* Dense Cholesky of an n x n row-major matrix in place (lower triangle); the solve with it. */
int svbi_dense_cholesky(double* A, int n);
void svbi_dense_solve(const double* L, int n, double* b);

/* General band LU with partial pivoting in place (ipiv: n) and the solve with it. Returns
 * SVBI_SOLVER_STATUS_SINGULAR on a zero pivot. */
int svbi_gb_factor(double* AB, int n, int bw, int* ipiv);
void svbi_gb_solve(const double* AB, int n, int bw, const int* ipiv, double* b);

/* The same factor with the reciprocal pivots stored (rpiv: n; multiplications instead of
 * divisions), and the solve of b in place, in one pass (the localized interface). */
int svbi_gb_factor_solve_r(double* AB, int n, int bw, int* ipiv, double* rpiv, double* b);

/* Clear a general band matrix, add v to its element (r, c). */
static inline void svbi_gb_zero(double* AB, int n, int bw) {
  memset(AB, 0, sizeof(double) * (size_t)n * (size_t)(3 * bw + 1));
}

static inline void svbi_gb_add(double* AB, int bw, int r, int c, double v) {
  AB[(2 * bw + r - c) + (long)c * (3 * bw + 1)] += v;
}


#endif /* SVBI_SOLVER_BAND_H */
