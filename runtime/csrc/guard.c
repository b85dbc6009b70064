/*
 * The divergence guard (svbi.runtime.simulate._Guard.check_finite), after every step.
 */
#include "internal.h"

/* simulate._Guard.check_finite: NaN or Inf anywhere, or a contact force beyond the limit. */
int svbi_guard(const setup_t* S, const state_t* X, const work_t* w, info_t* I) {
  long i;
  double sp = 0.0, sb = 0.0, sv = 0.0, pmax = 0.0;
  for (i = 0; i < S->nc; ++i) sp += X->P[i];
  for (i = 0; i < w->nb; ++i) sb += w->bu[i];
#if !SVBI_MOVING_LOAD
  for (i = 0; i < (long)S->cars * NV; ++i) sv += X->uV[i];
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
