/*
 * The step of LocalizedDynamic3D (_Step3D.step) and the loop over a chunk of steps: the Newmark
 * histories and effective loads (the creep loads of t_n, the supports at their targets), the
 * active-set passes around the interface iteration, the commit, the impact of a landing, the new
 * contact state, the creep forces, the divergence guard and the chunk's rows.
 */
#include <math.h>
#include <string.h>

#include "loop3d.h"

int svbi3d_sizes(long* out) {
  out[0] = (long)sizeof(setup3d_t);
  out[1] = (long)sizeof(state3d_t);
  out[2] = (long)sizeof(chunk3d_t);
  out[3] = (long)sizeof(info3d_t);
  return 0;
}

int svbi3d_workspace(const setup3d_t* S, long* n_double, long* n_int) {
  work3d_t W;
  w3_carve(S, &W, 0, 0, n_double, n_int);
  return 0;
}

/* the wheelsets' elements, the free index of each element DOF (-1: held, or the ground) and the
 * length of each wheelset's element in its kernels' geometry (on the ground: S->geom's) */
static void locate(work3d_t* W, const int* el) {
  const setup3d_t* S = W->S;
  int w, j;
  for (w = 0; w < S->nW; ++w) {
    W->ondeck[w] = el[w] >= 0 ? el[w] : -1;
    W->geom[8 * w + 7] = el[w] >= 0 ? S->el_len[el[w]] : S->geom[8 * w + 7];
    for (j = 0; j < 12; ++j)
      W->fidx[12 * w + j] = el[w] >= 0 ? S->full_to_free[S->el_dofs[12 * el[w] + j]] : -1;
  }
}

/* _Step3D._loads: the histories and the effective loads of both subsystems */
static void loads(work3d_t* W, const state3d_t* X) {
  const setup3d_t* S = W->S;
  int i;
  for (i = 0; i < S->nV; ++i) {
    W->PtV[i] = S->a2 * X->qd[i] + X->qdd[i];
    W->QtV[i] = X->qd[i];
    W->fV[i] = X->load[i] + X->creep_V[i];
  }
  csr_mul3(S->nV, S->KV_ptr, S->KV_idx, S->KV_val, X->q, W->tV, 0);
  for (i = 0; i < S->nV; ++i) W->fV[i] -= W->tV[i];
  csr_mul3(S->nV, S->MV_ptr, S->MV_idx, S->MV_val, W->PtV, W->fV, 1);
  csr_mul3(S->nV, S->CV_ptr, S->CV_idx, S->CV_val, W->QtV, W->fV, 1);
  for (i = 0; i < S->nB; ++i) {
    W->PB[i] = S->a0 * X->u[i] + S->a2 * X->ud[i] + X->udd[i];
    W->QB[i] = S->a1 * X->u[i] + X->ud[i];
  }
  csr_mul3(S->nB, S->M_ptr, S->M_idx, S->M_val, W->PB, W->fBfull, 0);
  csr_mul3(S->nB, S->C_ptr, S->C_idx, S->C_val, W->QB, W->fBfull, 1);
  for (i = 0; i < S->nF; ++i) W->fB[i] = W->fBfull[S->free_dofs[i]] + X->creep_B[S->free_dofs[i]];
  if (W->Q0) {
    csr_mul3(S->nF, S->Kfs_ptr, S->Kfs_idx, S->Kfs_val, W->Q0, W->tF, 0);
    for (i = 0; i < S->nF; ++i) W->fB[i] -= W->tF[i];
    csr_mul3(S->nF, S->CT_ptr, S->CT_idx, S->CT_val, W->Q1, W->tF, 0);
    for (i = 0; i < S->nF; ++i) W->fB[i] += W->tF[i];
  }
}

static double force_of(const state3d_t* X, int i) {
  return (i % 4 < 2) ? X->P[2 * (i / 4) + i % 4] : X->flange[2 * (i / 4) + i % 4 - 2];
}

static int finite_all(const double* x, long n) {
  double s = 0.0;
  long i;
  for (i = 0; i < n; ++i) s += x[i] * 0.0;
  return s == 0.0;
}

/* One step n (t_n -> t_{n+1}); the excitation of the step is set in W. */
static int step(work3d_t* W, state3d_t* X, long n, const int* el, const double* xi, const double* irr) {
  const setup3d_t* S = W->S;
  const int nW = S->nW, nC = 4 * nW;
  int i, w, j, st, any_landing = 0;
  loads(W, X);
  for (i = 0; i < nC; ++i) {
    W->start[i] = force_of(X, i);
    W->active[i] = W->in_contact[i];
    W->landing[i] = 0;
  }
  pivot_reset3(&W->pv, nC);
  for (;;) {
    int any = 0;
    W->passes++;
    if ((st = interface3(W, X, el, xi, irr))) return st;
    /* the rows at the solution: the stabilised residuals (in m) and the gaps */
    for (w = 0; w < nW; ++w)
      for (j = 0; j < 12; ++j)
        if (W->fidx[12 * w + j] >= 0) W->ucn[12 * w + j] = W->uk[S->el_dofs[12 * W->ondeck[w] + j]];
    if ((st = iterate_rows3(W, X, W->ucn, xi, irr, ROWS_CHECK))) return st;
    for (i = 0; i < nC; ++i) {
      double f = W->lam[i], g = W->in_contact[i] ? W->res[i] / S->scale : W->gap[i];
      if (S->bilateral && i % 4 < 2) f = fabs(f) + 1.0;
      W->bad[i] = W->active[i] ? (f < 0.0) : (g < 0.0);
      any |= W->bad[i];
    }
    if (!any) break;
    if (pivot_flips3(&W->pv, W->bad, nC)) return S3_ACTIVE_SET;
    for (i = 0; i < nC; ++i) {
      if (W->bad[i]) W->active[i] = !W->active[i];
      W->landing[i] = W->active[i] && !W->in_contact[i];
    }
  }
  /* commit */
  for (i = 0; i < S->nV; ++i) {
    X->qd[i] = S->a1 * W->dq[i] - W->QtV[i];
    X->qdd[i] = S->a0 * W->dq[i] - W->PtV[i];
    X->q[i] += W->dq[i];
  }
  span_rates3(W, W->uk, X->ud, X->udd);
  memcpy(X->u, W->uk, sizeof(double) * (size_t)S->nB);
  for (w = 0; w < nW; ++w) {
    X->P[2 * w] = W->lam[4 * w];
    X->P[2 * w + 1] = W->lam[4 * w + 1];
    X->flange[2 * w] = W->lam[4 * w + 2];
    X->flange[2 * w + 1] = W->lam[4 * w + 3];
  }
  X->t = (double)(n + 1) * S->dt;
  for (i = 0; i < nC; ++i) {
    any_landing |= W->landing[i];
    W->cand[i] = 0;
  }
  if (any_landing) {
    int* dropped = W->basic;
    if ((st = impact3(W, X, el, xi, irr, dropped))) return st;
    for (i = 0; i < nC; ++i) W->in_contact[i] = W->active[i] && !dropped[i];
  } else {
    for (i = 0; i < nC; ++i) W->in_contact[i] = W->active[i];
  }
  for (i = 0; i < nC; ++i) X->contact[i] = W->in_contact[i];
  if ((st = creep3(W, X, el, xi, irr))) return st;
  if (!finite_all(X->q, S->nV) || !finite_all(X->u, S->nB) || !finite_all(X->P, 2 * nW)) return S3_NOT_FINITE;
  return S3_OK;
}

static void set_step(work3d_t* W, const chunk3d_t* C, long s) {
  const setup3d_t* S = W->S;
  W->gz = C->ground ? C->ground + s * 36 * S->nW : 0;
  if (C->support) {
    W->Q0 = C->support + s * 3 * S->nS;
    W->Q1 = W->Q0 + S->nS;
    W->Q2 = W->Q1 + S->nS;
  } else {
    W->Q0 = W->Q1 = W->Q2 = 0;
  }
  locate(W, C->element + s * S->nW);
}

static int normal_gaps(work3d_t* W, const state3d_t* X, const double* xi, const double* irr, double* out) {
  const setup3d_t* S = W->S;
  double z[NZ3], c[4] = {S->c1, S->c0, 0.0, 0.0}, g[2];
  int w;
  for (w = 0; w < S->nW; ++w) {
    zvec3(W, w, X->q, X->u, W->gz, z);
    if (kcall3(W, SVBI_CONTACT3D_K_NORMAL_GAPS, w, z, W->zero16, W->zero16, xi[w], irr + 9 * w, c, g, 0))
      return S3_KERNEL;
    out[2 * w] = g[0];
    out[2 * w + 1] = g[1];
    if (kcall3(W, SVBI_CONTACT3D_K_FLANGE_GAPS, w, z, W->zero16, W->zero16, xi[w], irr + 9 * w, c, g, 0))
      return S3_KERNEL;
    out[2 * S->nW + 2 * w] = g[0];
    out[2 * S->nW + 2 * w + 1] = g[1];
  }
  return S3_OK;
}

int svbi3d_gaps(const setup3d_t* S, const state3d_t* X, const int* element, const double* xi,
                const double* irr, const double* ground, double* work, int* iwork, double* out) {
  work3d_t W;
  long nd, ni;
  w3_carve(S, &W, work, iwork, &nd, &ni);
  W.gz = ground;
  locate(&W, element);
  return normal_gaps(&W, X, xi, irr, out);
}

int svbi3d_run(const setup3d_t* S, state3d_t* X, chunk3d_t* C, double* work, int* iwork, long n0, long k,
               info3d_t* I) {
  work3d_t W;
  long nd, ni, s;
  const long nW = S->nW, nV = S->nV, nB = S->nB;
  w3_carve(S, &W, work, iwork, &nd, &ni);
  veh_transpose3(S, S->AV, W.AVt);
  veh_transpose3(S, S->MVi, W.MVit);
  for (s = 0; s < nB; ++s) W.held_of[s] = -1;
  for (s = 0; s < S->nS; ++s) W.held_of[S->held[s]] = (int)s;
  W.iterations = W.passes = W.factorizations = 0;
  for (s = 0; s < 4 * nW; ++s) W.in_contact[s] = X->contact[s] != 0;
  I->steps = 0;
  I->status = S3_OK;
  I->wheelset = -1;
  for (s = 0; s < k; ++s) {
    long n = n0 + s;
    const double* xi = C->xi + s * nW;
    const double* irr = C->irr + s * nW * 9;
    int st;
    set_step(&W, C, s);
    st = step(&W, X, n, C->element + s * nW, xi, irr);
    I->iterations = W.iterations;
    I->passes = W.passes;
    I->factorizations = W.factorizations;
    if (st) {
      I->status = st;
      I->step = n;
      return st;
    }
    C->t[s] = X->t;
    memcpy(C->q + s * nV, X->q, sizeof(double) * (size_t)nV);
    memcpy(C->qd + s * nV, X->qd, sizeof(double) * (size_t)nV);
    memcpy(C->qdd + s * nV, X->qdd, sizeof(double) * (size_t)nV);
    memcpy(C->u + s * nB, X->u, sizeof(double) * (size_t)nB);
    memcpy(C->ud + s * nB, X->ud, sizeof(double) * (size_t)nB);
    memcpy(C->udd + s * nB, X->udd, sizeof(double) * (size_t)nB);
    memcpy(C->P + s * 2 * nW, X->P, sizeof(double) * (size_t)(2 * nW));
    memcpy(C->flange + s * 2 * nW, X->flange, sizeof(double) * (size_t)(2 * nW));
    memcpy(C->contact + s * 4 * nW, X->contact, sizeof(int) * (size_t)(4 * nW));
    memcpy(C->creep + s * 6 * nW, X->creep, sizeof(double) * (size_t)(6 * nW));
    if ((n + 1) % C->every == 0) {
      double* g = W.ggap; /* 4 nW: normal then flange */
      int w;
      if (normal_gaps(&W, X, xi, irr, g)) {
        I->status = S3_KERNEL;
        I->step = n;
        return S3_KERNEL;
      }
      for (w = 0; w < 2 * nW; ++w) C->gaps[s * 2 * nW + w] = g[w];
    } else {
      int w;
      for (w = 0; w < 2 * nW; ++w) C->gaps[s * 2 * nW + w] = NAN;
    }
    I->steps = s + 1;
  }
  return S3_OK;
}
