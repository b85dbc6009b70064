/*
 * The divergence guard (svbi.runtime.run.simulate._Guard.check_finite), after every step.
 */
#include "internal.h"

/* The sum of x[0 .. n) in 2 VW independent chains, a register at a time (a serial sum waits for
 * every add): finite exactly when every term is, short of an overflow of the sum. */
static double sum_all(const double* x, long n) {
  long i;
  int l;
  vec_t s0 = {0.0}, s1 = {0.0};
  double s = 0.0;
  for (i = 0; i + 2 * VW <= n; i += 2 * VW) {
    s0 += VEC(x + i);
    s1 += VEC(x + i + VW);
  }
  for (; i < n; ++i) s += x[i];
  s0 += s1;
  for (l = 0; l < VW; ++l) s += s0[l];
  return s;
}

/* simulate._Guard.check_finite: NaN or Inf anywhere, or a contact force beyond the limit. */
int svbi_guard(const setup_t* S, const state_t* X, const work_t* w, info_t* I) {
  long i;
  double sp = sum_all(X->P, S->nc), sb = sum_all(w->br.bu, w->br.nb), sv = 0.0, pmax = 0.0;
#if !SVBI_MOVING_LOAD
  sv = sum_all(X->uV, (long)S->cars * NV);
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
