/*
 * Small dense and banded linear algebra of svbi's C time loop; layouts in band.h. The banded
 * Cholesky factors the span matrices, the banded LU the interface systems (contact forces or
 * multipliers, in track order), the dense Cholesky the car blocks of the coupled methods.
 */
#include <math.h>

#include "band.h"

#define GB_FAST_BW 8 /* the half-bandwidths up to which the interface routines are unrolled */

/* Lower band Cholesky in place: element (i, j), i >= j, at L[j * (p + 1) + (i - j)]. */
int svbi_band_cholesky(double* L, int n, int p) {
  int j, r, k;
  for (j = 0; j < n; ++j) {
    double* col = L + (long)j * (p + 1);
    int kn = n - 1 - j < p ? n - 1 - j : p;
    double d = col[0];
    if (!(d > 0.0)) return SVBI_SOLVER_STATUS_NOT_SPD;
    d = sqrt(d);
    col[0] = d;
    for (r = 1; r <= kn; ++r) col[r] /= d;
    for (k = 1; k <= kn; ++k) {
      double* ck = L + (long)(j + k) * (p + 1);
      double lk = col[k];
      for (r = k; r <= kn; ++r) ck[r - k] -= col[r] * lk;
    }
  }
  return SVBI_SOLVER_STATUS_OK;
}

/* Solve L L^T x = b in place. */
void svbi_band_solve(const double* L, int n, int p, double* b) {
  int j, r;
  for (j = 0; j < n; ++j) {
    const double* col = L + (long)j * (p + 1);
    int kn = n - 1 - j < p ? n - 1 - j : p;
    double x = b[j] / col[0];
    b[j] = x;
    for (r = 1; r <= kn; ++r) b[j + r] -= col[r] * x;
  }
  for (j = n - 1; j >= 0; --j) {
    const double* col = L + (long)j * (p + 1);
    int kn = n - 1 - j < p ? n - 1 - j : p;
    double x = b[j];
    for (r = 1; r <= kn; ++r) x -= col[r] * b[j + r];
    b[j] = x / col[0];
  }
}

/* Solve L L^T X = B in place for nblk * SW right-hand sides stored row by row (B[j * m + s],
 * m = nblk * SW); dinv holds the reciprocals of L's diagonal. Every row update runs over all the
 * right-hand sides, in blocks of SW (fixed width: vector instructions, independent chains). */
void svbi_band_solve_blocked(const double* L, const double* dinv, int n, int p, double* b, long nblk) {
  int j, r, l;
  long k, m = nblk * SW;
  for (j = 0; j < n; ++j) {
    const double* col = L + (long)j * (p + 1);
    int kn = n - 1 - j < p ? n - 1 - j : p;
    double* bj = b + (long)j * m;
    double di = dinv[j];
    for (k = 0; k < nblk; ++k)
      for (l = 0; l < SW; ++l) bj[k * SW + l] *= di;
    for (r = 1; r <= kn; ++r) {
      double c = col[r];
      double* br = bj + (long)r * m;
      if (c == 0.0) continue; /* axial and bending DOFs do not couple: the band is 40 % zeros */
      for (k = 0; k < nblk; ++k)
        for (l = 0; l < SW; ++l) br[k * SW + l] -= c * bj[k * SW + l];
    }
  }
  for (j = n - 1; j >= 0; --j) {
    const double* col = L + (long)j * (p + 1);
    int kn = n - 1 - j < p ? n - 1 - j : p;
    double* bj = b + (long)j * m;
    double di = dinv[j];
    for (r = 1; r <= kn; ++r) {
      double c = col[r];
      const double* br = bj + (long)r * m;
      if (c == 0.0) continue;
      for (k = 0; k < nblk; ++k)
        for (l = 0; l < SW; ++l) bj[k * SW + l] -= c * br[k * SW + l];
    }
    for (k = 0; k < nblk; ++k)
      for (l = 0; l < SW; ++l) bj[k * SW + l] *= di;
  }
}
/* One row of a sweep of window_solve: t -= sum_r u[r - 1] x[r - 1], the farthest row first, stored
 * at bj; then the window slides (x[0]: the row just solved). */
static SVBI_ALWAYS_INLINE void window_row(double* bj, const double* u, vec_t* t, vec_t (*x)[FS_G * LW / VW],
                                          const int P, const int k1) {
  int r, k;
  for (r = P; r >= 1; --r)
    for (k = 0; k < k1; ++k) t[k] -= u[r - 1] * x[r - 1][k];
  for (k = 0; k < k1; ++k) VEC(bj + k * VW) = t[k];
  for (r = P - 1; r >= 1; --r)
    for (k = 0; k < k1; ++k) x[r][k] = x[r - 1][k];
  for (k = 0; k < k1; ++k) x[0][k] = t[k];
}

/* Solve L L^T X = B in place for m right-hand sides (m a multiple of LW) held row after row: row j
 * at b + row(j) m, row(j) = rows[j] (or j without rows). With U = L D^-1 (unit lower, D = diag L),
 * L L^T = U D^2 U^T: U z = b forward, then U^T x = D^-2 z backward (fw, bk, dinv2). The
 * sweeps are latency-bound (each row waits for the one before), so the last P rows' results stay
 * in registers (a window sliding down, then up), G groups of LW lanes side by side (independent
 * chains), and a row's chain to the next is one multiply and one subtraction: the nearest row is
 * subtracted last, and no scaling by the diagonal is on it. P and G are constants where
 * window_solve is inlined, so that its loops unroll and its arrays live in registers. */
static SVBI_ALWAYS_INLINE void window_solve(const double* fw, const double* bk, const double* dinv2, double* b,
                                            const int* rows, long m, long c, int n, const int P, const int G) {
  enum { K = FS_G * LW / VW };
  const int k1 = G * LW / VW; /* registers per row */
  vec_t x[FS_PMAX][K], t[K];
  int j, r, k;
  for (r = 0; r < P; ++r)
    for (k = 0; k < k1; ++k) x[r][k] = (vec_t){0.0};
  for (j = 0; j < n; ++j) {
    double* restrict bj = b + (long)(rows ? rows[j] : j) * m + c;
    const double* u = fw + (long)j * P;
    for (k = 0; k < k1; ++k) t[k] = VEC(bj + k * VW);
    window_row(bj, u, t, x, P, k1);
  }
  for (r = 0; r < P; ++r)
    for (k = 0; k < k1; ++k) x[r][k] = (vec_t){0.0};
  for (j = n - 1; j >= 0; --j) {
    double* restrict bj = b + (long)(rows ? rows[j] : j) * m + c;
    const double* u = bk + (long)j * P;
    double d = dinv2[j];
    for (k = 0; k < k1; ++k) t[k] = VEC(bj + k * VW) * d;
    window_row(bj, u, t, x, P, k1);
  }
}

/* window_solve over all m lanes, FS_G groups of LW at a time, for the factor's half-bandwidth p
 * (the frame's 3 in reverse Cuthill-McKee order; up to FS_PMAX). */
static SVBI_ALWAYS_INLINE void window_lanes(const double* fw, const double* bk, const double* dinv2, double* b,
                                            const int* rows, long m, int n, const int P) {
  long c = 0;
  for (; c + FS_G * LW <= m; c += FS_G * LW) window_solve(fw, bk, dinv2, b, rows, m, c, n, P, FS_G);
  if (m - c == 2 * LW) window_solve(fw, bk, dinv2, b, rows, m, c, n, P, 2);
  else if (m - c == LW) window_solve(fw, bk, dinv2, b, rows, m, c, n, P, 1);
}

void svbi_band_solve_lanes(const double* fw, const double* bk, const double* dinv2, int n, int p, double* b,
                           const int* rows, long m) {
  switch (p) {
    case 1: window_lanes(fw, bk, dinv2, b, rows, m, n, 1); return;
    case 2: window_lanes(fw, bk, dinv2, b, rows, m, n, 2); return;
    case 3: window_lanes(fw, bk, dinv2, b, rows, m, n, 3); return;
    case 4: window_lanes(fw, bk, dinv2, b, rows, m, n, 4); return;
    case 5: window_lanes(fw, bk, dinv2, b, rows, m, n, 5); return;
    default: window_lanes(fw, bk, dinv2, b, rows, m, n, 6); return;
  }
}

void svbi_band_unit_factor(const double* L, int n, int p, double* fw, double* bk, double* dinv2) {
  int k, r;
  for (k = 0; k < n; ++k) {
    double d = L[(long)k * (p + 1)];
    dinv2[k] = 1.0 / (d * d);
    for (r = 1; r <= p; ++r) {
      fw[(long)k * p + r - 1] = k >= r ? L[(long)(k - r) * (p + 1) + r] / L[(long)(k - r) * (p + 1)] : 0.0;
      bk[(long)k * p + r - 1] = k + r < n ? L[(long)k * (p + 1) + r] / L[(long)k * (p + 1)] : 0.0;
    }
  }
}

/* General band matrix in LAPACK layout: A(r, c) at AB[(kv + r - c) + c * ldab], kv = kl + ku,
 * ldab = 2 kl + ku + 1. LU with partial pivoting (dgbtf2) and the solve (dgbtrs), kl = ku = bw. */
int svbi_gb_factor(double* AB, int n, int bw, int* ipiv) {
  int kl = bw, ku = bw, kv = 2 * bw, ldab = 3 * bw + 1;
  int j, i, jp, ju = 0, km, jj;
  for (j = 0; j < n; ++j) {
    double* colj = AB + (long)j * ldab;
    double pmax, piv;
    km = kl < n - 1 - j ? kl : n - 1 - j;
    jp = 0;
    pmax = fabs(colj[kv]);
    for (i = 1; i <= km; ++i) {
      if (fabs(colj[kv + i]) > pmax) {
        pmax = fabs(colj[kv + i]);
        jp = i;
      }
    }
    ipiv[j] = j + jp;
    if (colj[kv + jp] == 0.0) return SVBI_SOLVER_STATUS_SINGULAR;
    {
      int jmax = j + ku + jp < n - 1 ? j + ku + jp : n - 1;
      if (jmax > ju) ju = jmax;
    }
    if (jp != 0) {
      /* swap rows j and j + jp over columns j .. ju */
      for (jj = j; jj <= ju; ++jj) {
        double* cc = AB + (long)jj * ldab;
        double tmp = cc[kv + j - jj];
        cc[kv + j - jj] = cc[kv + j + jp - jj];
        cc[kv + j + jp - jj] = tmp;
      }
    }
    piv = colj[kv];
    for (i = 1; i <= km; ++i) colj[kv + i] /= piv;
    for (jj = j + 1; jj <= ju; ++jj) {
      double* cc = AB + (long)jj * ldab;
      double u = cc[kv + j - jj];
      if (u != 0.0) {
        for (i = 1; i <= km; ++i) cc[kv + j + i - jj] -= colj[kv + i] * u;
      }
    }
  }
  return SVBI_SOLVER_STATUS_OK;
}

void svbi_gb_solve(const double* AB, int n, int bw, const int* ipiv, double* b) {
  int kl = bw, kv = 2 * bw, ldab = 3 * bw + 1;
  int j, i;
  for (j = 0; j < n - 1; ++j) {
    const double* colj = AB + (long)j * ldab;
    int lm = kl < n - 1 - j ? kl : n - 1 - j;
    int l = ipiv[j];
    double x;
    if (l != j) {
      double tmp = b[l];
      b[l] = b[j];
      b[j] = tmp;
    }
    x = b[j];
    for (i = 1; i <= lm; ++i) b[j + i] -= colj[kv + i] * x;
  }
  for (j = n - 1; j >= 0; --j) {
    const double* colj = AB + (long)j * ldab;
    int i0 = j - kv > 0 ? j - kv : 0;
    double x = b[j] / colj[kv];
    b[j] = x;
    for (i = i0; i < j; ++i) b[i] -= colj[kv + i - j] * x;
  }
}

/* Column j of the LU: scale its km sub-diagonal entries by the reciprocal pivot r, then subtract
 * its multiples from columns j + 1 .. ju (km a constant where it is inlined: the loops unroll). */
static SVBI_ALWAYS_INLINE void eliminate(double* AB, int j, int ju, const int km, int kv, int ldab, double r) {
  double* colj = AB + (long)j * ldab;
  int i, jj;
  for (i = 1; i <= km; ++i) colj[kv + i] *= r;
  for (jj = j + 1; jj <= ju; ++jj) {
    double* cc = AB + (long)jj * ldab;
    double u = cc[kv + j - jj];
    if (u != 0.0) {
      for (i = 1; i <= km; ++i) cc[kv + j + i - jj] -= colj[kv + i] * u;
    }
  }
}

/* The first columns of gb_factor_r while partial pivoting keeps every pivot on the diagonal
 * (no entry below it larger in magnitude): columns of fixed width, the multipliers and the next
 * pivot held in registers (the pivots are a chain: division, multiplier, update, next pivot), no
 * branch on the data. The same operations as the general loop (an update by an exact zero
 * included, which leaves the entry as it is). With b, the forward substitution goes along
 * (b[j + i] -= l_i b[j]: forward_columns' operations, off the pivots' chain). Returns the first column
 * it left to the general loop (one that needs a row swap, or one of the last bw). bw is a
 * constant, 1 .. GB_FAST_BW. */
static SVBI_ALWAYS_INLINE int diagonal_columns(double* AB, int n, const int bw, int* ipiv, double* rpiv, double* b) {
  const int kv = 2 * bw, ldab = 3 * bw + 1;
  int j, i, jj;
  double d = n > bw ? AB[kv] : 0.0; /* the pivot A(j, j) */
  for (j = 0; j < n - bw; ++j) {
    double* colj = AB + (long)j * ldab;
    double* c1 = colj + ldab;
    double ad = fabs(d), r, u, l[GB_FAST_BW];
    int keep = d != 0.0;
    for (i = 1; i <= bw; ++i) keep &= !(fabs(colj[kv + i]) > ad);
    if (!keep) break;
    ipiv[j] = j;
    r = 1.0 / d;
    rpiv[j] = r;
    for (i = 1; i <= bw; ++i) colj[kv + i] = l[i - 1] = colj[kv + i] * r;
    u = c1[kv - 1]; /* column j + 1: the next pivot first */
    d = c1[kv] - l[0] * u;
    c1[kv] = d;
    for (i = 2; i <= bw; ++i) c1[kv - 1 + i] -= l[i - 1] * u;
    for (jj = 2; jj <= bw; ++jj) {
      double* cc = AB + (long)(j + jj) * ldab;
      u = cc[kv - jj];
      for (i = 1; i <= bw; ++i) cc[kv - jj + i] -= l[i - 1] * u;
    }
    if (b)
      for (i = 1; i <= bw; ++i) b[j + i] -= l[i - 1] * b[j];
  }
  return j;
}

/* svbi_gb_factor that also stores the reciprocal of every pivot (rpiv: n) and scales the column
 * by it (one division per column instead of one per sub-diagonal entry), from column j0 on (the
 * columns before it factored by diagonal_columns, no row swapped). bw is a constant where
 * svbi_gb_factor_solve_r inlines it (the interface's usual half-bandwidths): its loops then unroll. */
static SVBI_ALWAYS_INLINE int gb_factor_r(double* AB, int n, const int bw, int* ipiv, double* rpiv, int j0) {
  const int ku = bw, kv = 2 * bw, ldab = 3 * bw + 1;
  int j, i, jp, ju = j0 > 0 ? (j0 - 1 + ku < n - 1 ? j0 - 1 + ku : n - 1) : 0, km, jj;
  for (j = j0; j < n; ++j) {
    double* colj = AB + (long)j * ldab;
    double pmax, r;
    km = bw < n - 1 - j ? bw : n - 1 - j;
    jp = 0;
    pmax = fabs(colj[kv]);
    for (i = 1; i <= km; ++i) {
      double a = fabs(colj[kv + i]);
      if (a > pmax) {
        pmax = a;
        jp = i;
      }
    }
    ipiv[j] = j + jp;
    if (colj[kv + jp] == 0.0) return SVBI_SOLVER_STATUS_SINGULAR;
    {
      int jmax = j + ku + jp < n - 1 ? j + ku + jp : n - 1;
      if (jmax > ju) ju = jmax;
    }
    if (jp != 0) {
      for (jj = j; jj <= ju; ++jj) {
        double* cc = AB + (long)jj * ldab;
        double tmp = cc[kv + j - jj];
        cc[kv + j - jj] = cc[kv + j + jp - jj];
        cc[kv + j + jp - jj] = tmp;
      }
    }
    r = 1.0 / colj[kv];
    rpiv[j] = r;
    if (km == bw) /* every column but the last bw: a constant trip count */
      eliminate(AB, j, ju, bw, kv, ldab, r);
    else
      eliminate(AB, j, ju, km, kv, ldab, r);
  }
  return SVBI_SOLVER_STATUS_OK;
}

/* The forward substitution (row swaps and L) of gb_factor_r's factor, from column j0 on. */
static SVBI_ALWAYS_INLINE void forward_columns(const double* AB, int n, const int bw, const int* ipiv, double* b,
                                               int j0) {
  const int kv = 2 * bw, ldab = 3 * bw + 1;
  int j, i;
  for (j = j0; j < n - 1; ++j) {
    const double* colj = AB + (long)j * ldab;
    int lm = bw < n - 1 - j ? bw : n - 1 - j;
    int l = ipiv[j];
    double x;
    if (l != j) {
      double tmp = b[l];
      b[l] = b[j];
      b[j] = tmp;
    }
    x = b[j];
    if (lm == bw)
      for (i = 1; i <= bw; ++i) b[j + i] -= colj[kv + i] * x;
    else
      for (i = 1; i <= lm; ++i) b[j + i] -= colj[kv + i] * x;
  }
}

/* The backward substitution with U (its fill up to 2 bw above the diagonal), column by column. */
static SVBI_ALWAYS_INLINE void backward_columns(const double* AB, int n, const int bw, const double* rpiv,
                                                double* b) {
  const int kv = 2 * bw, ldab = 3 * bw + 1;
  int j, i;
  for (j = n - 1; j >= 0; --j) {
    const double* colj = AB + (long)j * ldab;
    double x = b[j] * rpiv[j];
    b[j] = x;
    if (j >= kv)
      for (i = j - kv; i < j; ++i) b[i] -= colj[kv + i - j] * x;
    else
      for (i = 0; i < j; ++i) b[i] -= colj[kv + i - j] * x;
  }
}

/* The forward substitution of a factor in which no row was swapped, row by row, the last bw
 * unknowns in registers: an unknown's chain to the next is one multiply and one subtraction. A
 * row's terms are subtracted farthest first, as forward_columns subtracts them: the same
 * operations. */
static SVBI_ALWAYS_INLINE void forward_rows(const double* AB, int n, const int bw, double* b) {
  const int kv = 2 * bw, ldab = 3 * bw + 1;
  double x[GB_FAST_BW];
  int j, i;
  for (i = 0; i < bw; ++i) x[i] = 0.0;
  for (j = 0; j < n; ++j) { /* x[i - 1]: the unknown j - i */
    double t = b[j];
    for (i = bw; i >= 1; --i)
      if (j - i >= 0) t -= AB[kv + i + (long)(j - i) * ldab] * x[i - 1];
    b[j] = t;
    for (i = bw - 1; i >= 1; --i) x[i] = x[i - 1];
    x[0] = t;
  }
}

/* backward_columns for a factor in which no row was swapped, row by row as forward_rows (U's fill
 * above its bw-th superdiagonal, zero without swaps, left out): the same operations. */
static SVBI_ALWAYS_INLINE void backward_rows(const double* AB, int n, const int bw, const double* rpiv, double* b) {
  const int kv = 2 * bw, ldab = 3 * bw + 1;
  double x[GB_FAST_BW];
  int j, i;
  for (i = 0; i < bw; ++i) x[i] = 0.0;
  for (j = n - 1; j >= 0; --j) { /* x[i - 1]: the unknown j + i */
    double t = b[j];
    for (i = bw; i >= 1; --i)
      if (j + i < n) t -= AB[kv - i + (long)(j + i) * ldab] * x[i - 1];
    t *= rpiv[j];
    b[j] = t;
    for (i = bw - 1; i >= 1; --i) x[i] = x[i - 1];
    x[0] = t;
  }
}

static int swapped_rows(const int* ipiv, int n) {
  int j, swapped = 0;
  for (j = 0; j < n; ++j) swapped |= ipiv[j] != j;
  return swapped;
}

/* The banded LU with partial pivoting and reciprocal pivots (rpiv: n), and the solve with it, in
 * one pass: the forward substitution of the diagonal columns goes along with their factorization
 * (diagonal_columns), the rest follows; the backward substitution row by row where no row was
 * swapped. fast: bw is a constant 1 .. GB_FAST_BW. */
static SVBI_ALWAYS_INLINE int gb_factor_solve_r(double* AB, int n, const int bw, int* ipiv, double* rpiv, double* b,
                                                const int fast) {
  int j0 = fast ? diagonal_columns(AB, n, bw, ipiv, rpiv, b) : 0;
  int status = gb_factor_r(AB, n, bw, ipiv, rpiv, j0);
  if (status) return status;
  forward_columns(AB, n, bw, ipiv, b, j0);
  if (fast && !swapped_rows(ipiv, n))
    backward_rows(AB, n, bw, rpiv, b);
  else
    backward_columns(AB, n, bw, rpiv, b);
  return SVBI_SOLVER_STATUS_OK;
}

int svbi_gb_factor_solve_r(double* AB, int n, int bw, int* ipiv, double* rpiv, double* b) {
  switch (bw) {
    case 1: return gb_factor_solve_r(AB, n, 1, ipiv, rpiv, b, 1);
    case 2: return gb_factor_solve_r(AB, n, 2, ipiv, rpiv, b, 1);
    case 3: return gb_factor_solve_r(AB, n, 3, ipiv, rpiv, b, 1);
    case 4: return gb_factor_solve_r(AB, n, 4, ipiv, rpiv, b, 1);
    case 5: return gb_factor_solve_r(AB, n, 5, ipiv, rpiv, b, 1);
    case 6: return gb_factor_solve_r(AB, n, 6, ipiv, rpiv, b, 1);
    case 7: return gb_factor_solve_r(AB, n, 7, ipiv, rpiv, b, 1);
    case 8: return gb_factor_solve_r(AB, n, 8, ipiv, rpiv, b, 1);
    default: return gb_factor_solve_r(AB, n, bw, ipiv, rpiv, b, 0);
  }
}

/* Dense Cholesky of an n x n row-major matrix in place (lower triangle). */
int svbi_dense_cholesky(double* A, int n) {
  int i, j, k;
  for (j = 0; j < n; ++j) {
    double d = A[j * n + j];
    for (k = 0; k < j; ++k) d -= A[j * n + k] * A[j * n + k];
    if (!(d > 0.0)) return SVBI_SOLVER_STATUS_NOT_SPD;
    d = sqrt(d);
    A[j * n + j] = d;
    for (i = j + 1; i < n; ++i) {
      double s = A[i * n + j];
      for (k = 0; k < j; ++k) s -= A[i * n + k] * A[j * n + k];
      A[i * n + j] = s / d;
    }
  }
  return SVBI_SOLVER_STATUS_OK;
}

void svbi_dense_solve(const double* L, int n, double* b) {
  int i, k;
  for (i = 0; i < n; ++i) {
    double s = b[i];
    for (k = 0; k < i; ++k) s -= L[i * n + k] * b[k];
    b[i] = s / L[i * n + i];
  }
  for (i = n - 1; i >= 0; --i) {
    double s = b[i];
    for (k = i + 1; k < n; ++k) s -= L[k * n + i] * b[k];
    b[i] = s / L[i * n + i];
  }
}
