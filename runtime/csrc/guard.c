/*
 * The divergence guard (svbi.runtime.simulate._Guard.check_finite), after every step.
 */
#include "internal.h"

/* The sum of x[0 .. n) in four independent chains (a serial sum waits for every add): finite
 * exactly when every term is, short of an overflow of the sum. */
static double sum4(const double* x, long n) {
  long i;
  double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
  for (i = 0; i + 4 <= n; i += 4) {
    s0 += x[i];
    s1 += x[i + 1];
    s2 += x[i + 2];
    s3 += x[i + 3];
  }
  for (; i < n; ++i) s0 += x[i];
  return (s0 + s1) + (s2 + s3);
}

/* simulate._Guard.check_finite: NaN or Inf anywhere, or a contact force beyond the limit. */
int svbi_guard(const setup_t* S, const state_t* X, const work_t* w, info_t* I) {
  long i;
  double sp = sum4(X->P, S->nc), sb = sum4(w->bu, w->nb), sv = 0.0, pmax = 0.0;
#if !SVBI_MOVING_LOAD
  sv = sum4(X->uV, (long)S->cars * NV);
#endif
  if (!isfinite(sp + sb + sv)) {
    I->quantity = !isfinite(sp) ? 1 : (!isfinite(sb) ? 2 : 3);
    I->value = sp + sb + sv;
    return ST_NOT_FINITE;
  }
  for (i = 0; i < S->nc; ++i)
    if (fabs(X->P[i]) > pmax) pmax = fabs(X->P[i]);
  if (pmax > S->force_limit) {
    I->quantity = 1;
    I->value = pmax;
    return ST_FORCE_LIMIT;
  }
  return ST_OK;
}
