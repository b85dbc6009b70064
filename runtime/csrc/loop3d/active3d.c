/*
 * The contact state (unilateral.ActiveSet's pivoting rule, unilateral.Pivoting) and the
 * complementarity solves of the impact (unilateral.complementary_solve), pass for pass.
 */
#include "loop3d.h"

void pivot_reset3(pivot3_t* P, int n) {
  P->n = n;
  P->best = n + 1;
  P->tries = PIVOT_TRIES3;
  P->passes = 0;
}

/* The flips of this pass in bad (changed in place); nonzero when the passes are exhausted. */
int pivot_flips3(pivot3_t* P, int* bad, int n) {
  int k = 0, i, first = -1;
  P->passes++;
  if (P->passes > 4 * P->n + 16) return 1;
  for (i = 0; i < n; ++i)
    if (bad[i]) {
      ++k;
      if (first < 0) first = i;
    }
  if (k < P->best) {
    P->best = k;
    P->tries = PIVOT_TRIES3;
    return 0;
  }
  if (P->tries > 0) {
    P->tries--;
    return 0;
  }
  for (i = 0; i < n; ++i) bad[i] = (i == first);
  return 0;
}

/* y with z = x0 + y >= 0, w = G y - want >= 0, z w = 0 over the candidates (the others y = -x0);
 * basic: the candidates with w = 0. G is n x n row-major. code: the status when it does not settle. */
int complementary3(work3d_t* W, const double* G, int n, const double* want, const double* x0,
                   const int* candidates, double* y, int* basic, int code) {
  pivot3_t P;
  int i, j, c = 0;
  for (i = 0; i < n; ++i) {
    basic[i] = candidates[i];
    c += candidates[i] != 0;
  }
  pivot_reset3(&P, c);
  for (;;) {
    int nb = 0, any = 0;
    for (i = 0; i < n; ++i) {
      y[i] = basic[i] ? 0.0 : -x0[i];
      if (basic[i]) W->idx[nb++] = i;
    }
    if (nb) {
      int a, b;
      for (a = 0; a < nb; ++a) {
        const double* r = G + (long)W->idx[a] * n;
        double s = want[W->idx[a]];
        for (j = 0; j < n; ++j)
          if (!basic[j]) s -= r[j] * y[j];
        W->subr[a] = s;
        for (b = 0; b < nb; ++b) W->sub[(long)a * nb + b] = r[W->idx[b]];
      }
      if (lu_solve3(W->sub, nb, W->subr, W->piv)) return S3_SINGULAR;
      for (a = 0; a < nb; ++a) y[W->idx[a]] = W->subr[a];
    }
    for (i = 0; i < n; ++i) {
      W->bad[i] = basic[i] && (x0[i] + y[i] < 0.0);
      if (candidates[i] && !basic[i]) {
        const double* r = G + (long)i * n;
        double s = -want[i];
        for (j = 0; j < n; ++j) s += r[j] * y[j];
        W->bad[i] = s < 0.0;
      }
      any |= W->bad[i];
    }
    if (!any) return S3_OK;
    if (pivot_flips3(&P, W->bad, n)) return code;
    for (i = 0; i < n; ++i)
      if (W->bad[i]) basic[i] = !basic[i];
  }
}
