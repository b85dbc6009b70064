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

void svbi_ppoly_eval(const svbi_ppoly* p, double x, double* out) {
  int i, k = p->k, n = p->n;
  double s;
  const double* c;
  if (n == 0 || x <= p->x[0]) {
    if (n == 0 && x > p->x[0]) {
      out[0] = p->right0;
      out[1] = p->right1;
      out[2] = p->right2;
    } else {
      out[0] = p->left0;
      out[1] = p->left1;
      out[2] = p->left2;
    }
    return;
  }
  if (x >= p->x[n]) {
    out[0] = p->right0;
    out[1] = p->right1;
    out[2] = p->right2;
    return;
  }
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
  s = x - p->x[i];
  c = p->c + (long)i * (k + 1);
  if (k == 3) /* cubic (splines, ground motions) and quintic (rail profiles, onset ramps) pieces */
    horner(c, s, 3, out);
  else if (k == 5)
    horner(c, s, 5, out);
  else
    horner(c, s, k, out);
}
