/*
 * Piecewise-polynomial tables (tables.h): the same arithmetic as the NumPy side
 * (svbi.runtime.irregularity.horner, MotionHistory.evaluate), an O(1) interval guess on uniform
 * breaks and a bisection otherwise.
 */
#include <math.h>

#include "tables.h"

#if defined(__GNUC__)
#define SVBI_ALWAYS_INLINE __attribute__((always_inline)) inline
#else
#define SVBI_ALWAYS_INLINE inline
#endif

/* Value and first two derivatives of one piece at s by Horner's rule; k a constant where it is
 * inlined, so that the loops unroll (the same sums). */
static SVBI_ALWAYS_INLINE void horner(const double* c, double s, const int k, double* out) {
  int m;
  double v0 = 0.0, v1 = 0.0, v2 = 0.0;
  for (m = 0; m <= k; ++m) v0 = v0 * s + c[m];
  for (m = 0; m < k; ++m) v1 = v1 * s + (double)(k - m) * c[m];
  for (m = 0; m < k - 1; ++m) v2 = v2 * s + (double)(k - m) * (double)(k - m - 1) * c[m];
  out[0] = v0;
  out[1] = v1;
  out[2] = v2;
}

/* The interval of x inside the breaks (x[0] < x < x[n]): an O(1) guess on uniform breaks, stepped
 * to the exact interval, or a bisection. */
static inline int interval_of(const svbi_ppoly* p, double x) {
  int i, n = p->n;
  if (p->uniform) {
    i = (int)floor((x - p->x[0]) / p->h);
    if (i < 0) i = 0;
    if (i > n - 1) i = n - 1;
    while (i > 0 && x < p->x[i]) --i;
    while (i < n - 1 && x >= p->x[i + 1]) ++i;
  } else {
    int lo = 0, hi = n - 1;
    while (lo < hi) {
      int mid = (lo + hi + 1) / 2;
      if (p->x[mid] <= x)
        lo = mid;
      else
        hi = mid - 1;
    }
    i = lo;
  }
  return i;
}

/* Horner at s in piece i, k taken as a constant for the usual degrees. */
static inline void piece(const svbi_ppoly* p, int i, double s, double* out) {
  int k = p->k;
  const double* c = p->c + (long)i * (k + 1);
  if (k == 3) /* cubic (splines, ground motions) and quintic (rail profiles, onset ramps) pieces */
    horner(c, s, 3, out);
  else if (k == 5)
    horner(c, s, 5, out);
  else
    horner(c, s, k, out);
}

/* Where x falls: its interval, or -1 for the constant left end (x <= x[0]) and -2 for the right
 * end (x >= x[n]; with no interval, x > x[0]). */
static inline int where(const svbi_ppoly* p, double x) {
  if (p->n == 0) return x > p->x[0] ? -2 : -1;
  if (x <= p->x[0]) return -1;
  if (x >= p->x[p->n]) return -2;
  return interval_of(p, x);
}

/* Value, slope and curvature at x from where(p, x). */
static inline void value_at(const svbi_ppoly* p, int i, double x, double* out) {
  if (i >= 0) {
    piece(p, i, x - p->x[i], out);
  } else if (i == -1) {
    out[0] = p->left0;
    out[1] = p->left1;
    out[2] = p->left2;
  } else {
    out[0] = p->right0;
    out[1] = p->right1;
    out[2] = p->right2;
  }
}

/* svbi_ppoly_eval at count points, out[0..2][j] at out + j, out + stride + j, out + 2 stride + j. The
 * intervals of a block of points are found first and the pieces evaluated after, so that the
 * points' dependency chains (a division, a table load, Horner) overlap instead of following one
 * another; the same arithmetic as svbi_ppoly_eval, point by point. */
void svbi_ppoly_eval_many(const svbi_ppoly* p, const double* x, int count, double* out, long stride) {
  enum { BLOCK = 64 };
  int idx[BLOCK], j, j0;
  for (j0 = 0; j0 < count; j0 += BLOCK) {
    int nb = count - j0 < BLOCK ? count - j0 : BLOCK;
    for (j = 0; j < nb; ++j) idx[j] = where(p, x[j0 + j]);
    for (j = 0; j < nb; ++j) {
      double v[3];
      value_at(p, idx[j], x[j0 + j], v);
      out[j0 + j] = v[0];
      out[stride + j0 + j] = v[1];
      out[2 * stride + j0 + j] = v[2];
    }
  }
}

void svbi_ppoly_eval(const svbi_ppoly* p, double x, double* out) { value_at(p, where(p, x), x, out); }
