/*
 * The 3D loop's linear algebra: the solve with a band Cholesky factor (the span's effective
 * matrix, factored once by SciPy at set-up) and a small dense LU with partial pivoting (the
 * interface and the complementarity problems, as numpy.linalg.solve).
 */
#include <math.h>

#include "loop3d.h"

/* L L^T x = b in place; L(j + r, j) at L[j (p + 1) + r], except the diagonal: its reciprocal
 * (multiplications, not divisions, in the solve's chain). Rows with a full band (j + p < n) are
 * taken apart from the last p, so that with p known at compile time (band_solve3 dispatches the
 * small half-bandwidths of a chain of spans to their own copies) the inner loops unroll; the
 * operations and their order are the generic loop's. */
static inline void band_solve_n(const double* L, int n, const int p, double* b, double* b2) {
  const int full = n - p > 0 ? n - p : 0;
  int j, r;
  for (j = 0; j < full; ++j) {
    const double* c = L + (long)j * (p + 1);
    double x = b[j] * c[0];
    b[j] = x;
    for (r = 1; r <= p; ++r) b[j + r] -= c[r] * x;
    if (b2) {
      double x2 = b2[j] * c[0];
      b2[j] = x2;
      for (r = 1; r <= p; ++r) b2[j + r] -= c[r] * x2;
    }
  }
  for (j = full; j < n; ++j) {
    const double* c = L + (long)j * (p + 1);
    double x = b[j] * c[0];
    int m = n - 1 - j;
    b[j] = x;
    for (r = 1; r <= m; ++r) b[j + r] -= c[r] * x;
    if (b2) {
      double x2 = b2[j] * c[0];
      b2[j] = x2;
      for (r = 1; r <= m; ++r) b2[j + r] -= c[r] * x2;
    }
  }
  for (j = n - 1; j >= full; --j) {
    const double* c = L + (long)j * (p + 1);
    double s = b[j];
    int m = n - 1 - j;
    for (r = 1; r <= m; ++r) s -= c[r] * b[j + r];
    b[j] = s * c[0];
    if (b2) {
      double s2 = b2[j];
      for (r = 1; r <= m; ++r) s2 -= c[r] * b2[j + r];
      b2[j] = s2 * c[0];
    }
  }
  for (j = full - 1; j >= 0; --j) {
    const double* c = L + (long)j * (p + 1);
    double s = b[j];
    for (r = 1; r <= p; ++r) s -= c[r] * b[j + r];
    b[j] = s * c[0];
    if (b2) {
      double s2 = b2[j];
      for (r = 1; r <= p; ++r) s2 -= c[r] * b2[j + r];
      b2[j] = s2 * c[0];
    }
  }
}

static void band_dispatch(const double* L, int n, int p, double* b, double* b2) {
  switch (p) {
    case 1:
      band_solve_n(L, n, 1, b, b2);
      return;
    case 2:
      band_solve_n(L, n, 2, b, b2);
      return;
    case 3:
      band_solve_n(L, n, 3, b, b2);
      return;
    case 4:
      band_solve_n(L, n, 4, b, b2);
      return;
    case 6:
      band_solve_n(L, n, 6, b, b2);
      return;
    default:
      band_solve_n(L, n, p, b, b2);
  }
}

void band_solve3(const double* L, int n, int p, double* b) { band_dispatch(L, n, p, b, 0); }

/* band_solve3 of two right-hand sides at once (the same operations on each) */
void band_solve3_2(const double* L, int n, int p, double* b, double* b2) { band_dispatch(L, n, p, b, b2); }

/* A x = b (A n x n row-major, overwritten by its factors; b by x). S3_SINGULAR on a zero pivot (a
 * NaN goes on: the guard reports the state). Gaussian elimination with partial pivoting
 * (numpy.linalg.solve's), skipping exact zeros: each row's last nonzero column is followed, so a
 * matrix whose rows end early (the interface in track order: a band) costs its profile, not n^3;
 * the arithmetic done is the dense elimination's. lu_factor3, then lu_back3. */
int lu_solve3(double* A, int n, double* b, int* piv) {
  int last[n > 0 ? n : 1], first[n > 0 ? n : 1];
  int st = lu_factor3(A, n, piv, last, first);
  if (st) return st;
  lu_back3(A, n, piv, last, first, b);
  return S3_OK;
}

/* The factors of A (kept: the interface's, for the chord iterations of interface3): A overwritten
 * by L (unit, below the diagonal) and U, the row swaps in piv, each row's last nonzero column of U
 * in last and first nonzero column of L in first. S3_SINGULAR on a zero pivot. */
int lu_factor3(double* A, int n, int* piv, int* last, int* first) {
  int i, j, k;
  int hi[n > 0 ? n : 1]; /* hi[k]: no row below it has a nonzero in column k, now or later */
  for (i = 0; i < n; ++i) {
    const double* ri = A + (long)i * n;
    for (j = n - 1; j > 0 && ri[j] == 0.0; --j) {
    }
    last[i] = j;
    hi[i] = -1;
  }
  /* A row's first nonzero never moves left (its fill lies right of the pivot column that its first
   * nonzero precedes), and the row exchanges at column k stay within the rows up to hi[k]: the rows
   * that start after column k stay below hi[k], and the column's search and elimination stop there
   * (the zeros they skip are those the loops would skip). */
  for (i = 0; i < n; ++i) {
    const double* ri = A + (long)i * n;
    for (j = 0; j < n - 1 && ri[j] == 0.0; ++j) {
    }
    if (i > hi[j]) hi[j] = i;
  }
  for (k = 1; k < n; ++k)
    if (hi[k - 1] > hi[k]) hi[k] = hi[k - 1];
  for (k = 0; k < n; ++k) {
    int m = k;
    const int end = hi[k] + 1 < n ? hi[k] + 1 : n;
    double big = fabs(A[(long)k * n + k]);
    for (i = k + 1; i < end; ++i)
      if (fabs(A[(long)i * n + k]) > big) {
        big = fabs(A[(long)i * n + k]);
        m = i;
      }
    piv[k] = m;
    if (big == 0.0) return S3_SINGULAR;
    if (m != k) {
      double t;
      int e = last[k] > last[m] ? last[k] : last[m];
      for (j = 0; j <= e; ++j) {
        t = A[(long)k * n + j];
        A[(long)k * n + j] = A[(long)m * n + j];
        A[(long)m * n + j] = t;
      }
      j = last[k];
      last[k] = last[m];
      last[m] = j;
    }
    {
      const double* rk = A + (long)k * n;
      const int e = last[k];
      double inv = 1.0 / rk[k];
      for (i = k + 1; i < end; ++i) {
        double* ri = A + (long)i * n;
        double f = ri[k] * inv;
        if (f == 0.0) continue;
        ri[k] = f;
        for (j = k + 1; j <= e; ++j) ri[j] -= f * rk[j];
        if (e > last[i]) last[i] = e;
      }
    }
  }
  for (i = 0; i < n; ++i) {
    const double* ri = A + (long)i * n;
    for (j = 0; j < i && ri[j] == 0.0; ++j) {
    }
    first[i] = j;
  }
  return S3_OK;
}

/* x of A x = b from lu_factor3's factors (b overwritten): the swaps in order, then the unit lower
 * and the upper triangle; each b[i] takes its subtractions in the order of the elimination that
 * would have carried b along (LAPACK's getrs after getrf). */
void lu_back3(const double* A, int n, const int* piv, const int* last, const int* first, double* b) {
  int i, j, k;
  for (k = 0; k < n; ++k)
    if (piv[k] != k) {
      double t = b[k];
      b[k] = b[piv[k]];
      b[piv[k]] = t;
    }
  for (i = 1; i < n; ++i) {
    const double* ri = A + (long)i * n;
    double s = b[i];
    for (k = first[i]; k < i; ++k) s -= ri[k] * b[k];
    b[i] = s;
  }
  for (i = n - 1; i >= 0; --i) {
    const double* ri = A + (long)i * n;
    double s = b[i];
    for (j = i + 1; j <= last[i]; ++j) s -= ri[j] * b[j];
    b[i] = s / ri[i];
  }
}
