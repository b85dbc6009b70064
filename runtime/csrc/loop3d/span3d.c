/*
 * The span: sparse products (mass, damping, the supports' coupling), the solve with the effective
 * matrix's band Cholesky factor (in its reverse Cuthill-McKee order) and the Newmark rates with the
 * supports at their targets (_Step3D._span_rates).
 */
#include "loop3d.h"

void csr_mul3(int n, const int* ptr, const int* idx, const double* val, const double* x, double* y, int add) {
  int i, k;
  for (i = 0; i < n; ++i) {
    double acc = 0.0;
    for (k = ptr[i]; k < ptr[i + 1]; ++k) acc += val[k] * x[idx[k]];
    y[i] = add ? y[i] + acc : acc;
  }
}

/* b (free DOFs) <- K^_ff^-1 b. */
void span_solve3(work3d_t* W, double* b) {
  const setup3d_t* S = W->S;
  int k;
  for (k = 0; k < S->nF; ++k) W->bw[k] = b[S->perm[k]];
  band_solve3(S->band, S->nF, S->p, W->bw);
  for (k = 0; k < S->nF; ++k) b[S->perm[k]] = W->bw[k];
}

/* b, b2 (free DOFs) <- K^_ff^-1 b, K^_ff^-1 b2: the two solves in one pass (each one's arithmetic
 * as span_solve3's; two independent chains). b2 may not be W->bw. */
void span_solve3_2(work3d_t* W, double* b, double* b2) {
  const setup3d_t* S = W->S;
  double* c2 = W->bw + S->nF;
  int k;
  for (k = 0; k < S->nF; ++k) {
    W->bw[k] = b[S->perm[k]];
    c2[k] = b2[S->perm[k]];
  }
  band_solve3_2(S->band, S->nF, S->p, W->bw, c2);
  for (k = 0; k < S->nF; ++k) {
    b[S->perm[k]] = W->bw[k];
    b2[S->perm[k]] = c2[k];
  }
}

/* ud = a1 u - QB, udd = a0 u - PB (full vectors), the supports' from their targets. */
void span_rates3(work3d_t* W, const double* u, double* ud, double* udd) {
  const setup3d_t* S = W->S;
  int i;
  for (i = 0; i < S->nB; ++i) {
    ud[i] = S->a1 * u[i] - W->QB[i];
    udd[i] = S->a0 * u[i] - W->PB[i];
  }
  if (W->Q0)
    for (i = 0; i < S->nS; ++i) {
      ud[S->held[i]] = W->Q1[i];
      udd[S->held[i]] = W->Q2[i];
    }
}
