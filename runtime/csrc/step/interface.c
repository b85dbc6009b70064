/*
 * The last part of the localized step's interface solve, the same for both bridge kinds: the
 * right-hand sides, the rows of airborne wheels, the banded LU and its solve.
 */
#include "internal.h"

/* The contact rows' right-hand sides (a landing wheel's: its landing row's), an inactive wheel's
 * row replaced by P_i = 0 (band row zeroed, unit diagonal), then the banded LU and the solve, in
 * w->bsol (n unknowns: the contacts at w->it.cpos, and a general bridge's links). */
int svbi_interface_finish(const setup_t* S, work_t* w, int n, int bw, const int* active, const int* landing) {
  int i, status, nc = S->nc;
  for (i = 0; i < nc; ++i) w->it.bsol[w->it.cpos[i]] = landing && landing[i] ? w->un.rland[i] : w->it.rhs[i];
  if (active) {
    for (i = 0; i < nc; ++i) {
      if (!active[i]) {
        int r = w->it.cpos[i], c0 = r - bw > 0 ? r - bw : 0, c1 = r + bw < n - 1 ? r + bw : n - 1, cc;
        for (cc = c0; cc <= c1; ++cc) w->it.band[(2 * bw + r - cc) + (long)cc * (3 * bw + 1)] = 0.0;
        svbi_gb_add(w->it.band, bw, r, r, 1.0);
        w->it.bsol[r] = 0.0;
      }
    }
  }
  status = svbi_gb_factor_solve_r(w->it.band, n, bw, w->it.piv, w->it.rpiv, w->it.bsol);
  return status ? status : ST_OK;
}
