/*
 * The plastic impact of landing (closing) constraints at t_{n+1} (_Step3D._impact): the mass
 * flexibility G = G_V M_V^-1 G_V^T + G_B M_B^-1 G_B^T, the impulses that stop the landing ones
 * (complementary3), the velocity jump and the damping's share of the accelerations, then the force
 * jump that makes the accelerations consistent. The dense products' numbers bit for bit, by a
 * shorter path (a shaken run lands wheels at thousands of steps): G over the constraints closed in the step
 * only (an open one carries neither impulse nor force: its entries of the complementarity problems
 * only ever multiply a zero) and between coupled wheelsets only (zero between the others); the
 * inverse mass's products over the columns where its rows are not zero (S->MBi_cols: the parts of
 * the structure), so every term left out is an exact zero.
 */
#include <string.h>

#include "loop3d.h"

/* the state's z, z', z'' of wheelset w */
static void state_z(work3d_t* W, const state3d_t* X, int w, double* z, double* zd, double* zdd) {
  const double* g = W->gz;
  int nW = W->S->nW;
  zvec3(W, w, X->q, X->u, g, z);
  zvec3(W, w, X->qd, X->ud, g ? g + 12 * nW : 0, zd);
  zvec3(W, w, X->qdd, X->udd, g ? g + 24 * nW : 0, zdd);
}

/* g'' (c1 = c0 = 0) of every constraint at the state, and g'' + g' (c1 = 1) into t1 */
static int gap_rates(work3d_t* W, const state3d_t* X, const double* xi, const double* irr, double* tt,
                     double* t1) {
  double z[NZ3], zd[NZ3], zdd[NZ3], c0[4] = {0.0, 0.0, 0.0, 0.0}, c1[4] = {1.0, 0.0, 0.0, 0.0};
  int w, st = 0;
  for (w = 0; w < W->S->nW; ++w) {
    state_z(W, X, w, z, zd, zdd);
    st |= kcall3(W, SVBI_CONTACT3D_K_NORMAL_RESIDUALS, w, z, zd, zdd, xi[w], irr + 9 * w, c0, tt + 4 * w, 0);
    st |= kcall3(W, SVBI_CONTACT3D_K_FLANGE_RESIDUALS, w, z, zd, zdd, xi[w], irr + 9 * w, c0, tt + 4 * w + 2, 0);
    if (t1) {
      st |= kcall3(W, SVBI_CONTACT3D_K_NORMAL_RESIDUALS, w, z, zd, zdd, xi[w], irr + 9 * w, c1, t1 + 4 * w, 0);
      st |= kcall3(W, SVBI_CONTACT3D_K_FLANGE_RESIDUALS, w, z, zd, zdd, xi[w], irr + 9 * w, c1, t1 + 4 * w + 2, 0);
    }
  }
  return st ? S3_KERNEL : S3_OK;
}

/* The free DOFs [lo, hi] where M_B^-1 G_B^T of wheelset w's constraints can be nonzero: the columns
 * of the rows of M_B^-1 at its element's free DOFs (M_B^-1 is zero between the parts of the
 * structure; lo > hi: on the ground). */
static void part_of(const work3d_t* W, int w, int* lo, int* hi) {
  int j;
  *lo = W->S->nF;
  *hi = -1;
  for (j = 0; j < 12; ++j) {
    const int f = W->fidx[12 * w + j];
    if (f < 0) continue;
    if (W->S->MBi_cols[2 * f] < *lo) *lo = W->S->MBi_cols[2 * f];
    if (W->S->MBi_cols[2 * f + 1] > *hi) *hi = W->S->MBi_cols[2 * f + 1];
  }
}

/* the first of the n ascending entries of a that is at least v (n if none) */
static int first_at_least(const int* a, int n, int v) {
  int lo = 0, hi = n;
  while (lo < hi) {
    const int mid = (lo + hi) / 2;
    if (a[mid] < v)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo;
}

/* vehicle += sum_i AVt[i] x_i, span (free) += sum_i ABt[i] x_i (over the DOFs where ABt[i] can be
 * nonzero: a zero term leaves a sum as it is) */
static void respond(work3d_t* W, const double* x, double* veh, double* span) {
  const setup3d_t* S = W->S;
  int i, j, lo, hi, nC = 4 * S->nW;
  for (i = 0; i < nC; ++i) {
    if (x[i] == 0.0) continue;
    for (j = 0; j < S->nV; ++j) veh[j] += W->AVm[(long)i * S->nV + j] * x[i];
    part_of(W, i / 4, &lo, &hi);
    for (j = lo; j <= hi; ++j) span[j] += W->ABm[(long)i * S->nF + j] * x[i];
  }
}

int impact3(work3d_t* W, state3d_t* X, const int* el, const double* xi, const double* irr, int* dropped) {
  const setup3d_t* S = W->S;
  const int nW = S->nW, nC = 4 * nW, nV = S->nV, nF = S->nF;
  double z[NZ3], zd[NZ3], zdd[NZ3];
  int i, j, w, st;
  (void)el;
  /* the directions G_V, G_B at the state of the closed constraints, their mass responses and the
   * flexibility between them (the open ones' entries zero) */
  for (w = 0; w < nW; ++w) {
    const int* a = W->active + 4 * w;
    if (!(a[0] | a[1] | a[2] | a[3])) continue;
    state_z(W, X, w, z, zd, zdd);
    if ((st = gradients3(W, w, z, zd, zdd, xi[w], irr + 9 * w))) return st;
  }
  for (i = 0; i < nC; ++i) {
    int wi = i / 4;
    const double* g = W->grad + i * NZ3;
    if (!W->active[i]) continue;
    memset(W->GV + (long)i * nV, 0, sizeof(double) * (size_t)nV);
    for (j = 0; j < 4; ++j) W->GV[(long)i * nV + S->ws_dofs[4 * wi + j]] = g[j];
    veh_mul3(S, W->MVit, W->GV + (long)i * nV, W->AVm + (long)i * nV, 0);
    memset(W->ABm + (long)i * nF, 0, sizeof(double) * (size_t)nF);
    for (j = 0; j < 12; ++j) {
      int f = W->fidx[12 * wi + j], r;
      const double* row;
      if (f < 0) continue;
      row = S->MBi + (long)f * nF; /* M_B^-1 is symmetric: its row f is its column f */
      for (r = S->MBi_cols[2 * f]; r <= S->MBi_cols[2 * f + 1]; ++r) /* its nonzero columns */
        W->ABm[(long)i * nF + r] += row[r] * g[4 + j];
    }
  }
  memset(W->G, 0, sizeof(double) * (size_t)nC * nC);
  for (i = 0; i < nC; ++i) {
    const int wi = i / 4;
    const double* g = W->grad + i * NZ3;
    int l;
    if (!W->active[i]) continue;
    /* the wheelsets coupled to wi (the same car, the same part of the structure: couple's list); G
     * is zero between the others */
    for (l = W->pstart[wi]; l < W->pstart[wi + 1]; ++l) {
      const int v = W->plist[l] - wi * nW;
      int m;
      for (m = 0; m < 4; ++m) {
        double s = 0.0;
        int k;
        j = 4 * v + m;
        if (!W->active[j]) continue;
        for (k = 0; k < 4; ++k) s += g[k] * W->AVm[(long)j * nV + S->ws_dofs[4 * wi + k]];
        for (k = 0; k < 12; ++k)
          if (W->fidx[12 * wi + k] >= 0) s += g[4 + k] * W->ABm[(long)j * nF + W->fidx[12 * wi + k]];
        W->G[(long)i * nC + j] = s;
      }
    }
  }
  /* the impulses: landing constraints lose their relative velocity */
  if ((st = gap_rates(W, X, xi, irr, W->gtt, W->gt))) return st;
  for (i = 0; i < nC; ++i) {
    double lam = (i % 4 < 2) ? X->P[2 * (i / 4) + i % 4] : X->flange[2 * (i / 4) + i % 4 - 2];
    W->gt[i] -= W->gtt[i];
    W->force[i] = lam;
    W->x0[i] = W->active[i] ? 0.5 * S->dt * (W->start[i] + lam) : 0.0;
    W->want[i] = W->landing[i] ? -W->gt[i] : 0.0;
  }
  if ((st = complementary3(W, W->G, nC, W->want, W->x0, W->active, W->imp, W->held2, S3_IMPULSE))) return st;
  memset(W->tV, 0, sizeof(double) * (size_t)nV);
  memset(W->tF, 0, sizeof(double) * (size_t)nF);
  respond(W, W->imp, W->tV, W->tF); /* dqd, dud */
  for (i = 0; i < nV; ++i) X->qd[i] += W->tV[i];
  for (i = 0; i < nF; ++i) X->ud[S->free_dofs[i]] += W->tF[i];
  /* the damping forces follow the velocity jump */
  csr_mul3(S->nV, S->CV_ptr, S->CV_idx, S->CV_val, W->tV, W->gv, 0);
  veh_mul3(S, W->MVit, W->gv, W->dqn, 0);
  for (i = 0; i < nV; ++i) X->qdd[i] -= W->dqn[i];
  memset(W->tB, 0, sizeof(double) * (size_t)S->nB);
  for (i = 0; i < nF; ++i) W->tB[S->free_dofs[i]] = W->tF[i];
  csr_mul3(S->nB, S->C_ptr, S->C_idx, S->C_val, W->tB, W->fBfull, 0);
  /* M_B^-1 of the damping forces, over the DOFs they load only (the spans the impulses moved; the
   * same sums in the same order: a zero term leaves a sum unchanged) */
  for (i = 0, j = 0; i < nF; ++i) {
    W->bw[i] = W->fBfull[S->free_dofs[i]];
    if (W->bw[i] != 0.0) W->nzb[j++] = i;
  }
  for (i = 0; i < nF; ++i) {
    const double* row = S->MBi + (long)i * nF;
    const int hi = S->MBi_cols[2 * i + 1];
    double s = 0.0;
    int k = first_at_least(W->nzb, j, S->MBi_cols[2 * i]); /* the row's nonzero columns only */
    for (; k < j && W->nzb[k] <= hi; ++k) s += row[W->nzb[k]] * W->bw[W->nzb[k]];
    X->udd[S->free_dofs[i]] -= s;
  }
  /* the force jump: consistent accelerations (landing: g'' = 0, the others unchanged) */
  if ((st = gap_rates(W, X, xi, irr, W->gtt2, 0))) return st;
  for (i = 0; i < nC; ++i) W->want[i] = W->landing[i] ? -W->gtt2[i] : -(W->gtt2[i] - W->gtt[i]);
  if ((st = complementary3(W, W->G, nC, W->want, W->force, W->held2, W->jump, W->cand, S3_FORCE_JUMP)))
    return st;
  memset(W->tV, 0, sizeof(double) * (size_t)nV);
  memset(W->tF, 0, sizeof(double) * (size_t)nF);
  respond(W, W->jump, W->tV, W->tF);
  for (i = 0; i < nV; ++i) X->qdd[i] += W->tV[i];
  for (i = 0; i < nF; ++i) X->udd[S->free_dofs[i]] += W->tF[i];
  for (i = 0; i < nC; ++i) {
    double lam = W->cand[i] ? W->force[i] + W->jump[i] : 0.0;
    if (i % 4 < 2)
      X->P[2 * (i / 4) + i % 4] = lam;
    else
      X->flange[2 * (i / 4) + i % 4 - 2] = lam;
    dropped[i] = W->active[i] && !W->cand[i];
  }
  return S3_OK;
}
