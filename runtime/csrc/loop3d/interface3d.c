/*
 * The interface iteration of LocalizedDynamic3D._solve: predictors of the vehicle (its per-car
 * compliance) and of the span (a band solve), then, with the gradients G and the constraint rows
 * J at the iterate, the contact forces of the active constraints from
 *
 *     (J_V A_V G_V^T + J_B S G_B^T) P = -E + J_V (dq - dq~) + J_B (u - u~),
 *
 * until the update is round-off (coupled3d.Convergence). The first iteration of a pass is Newton's:
 * the matrix is formed at the predictor and factored (lu_factor3); the next ones are chord
 * iterations on those factors (lu_back3): the forces are corrected by minus the residuals at the
 * iterate, linearised to the state the forces give with the gradients there (chord_rhs), with no
 * new Jacobian, matrix or factorisation. The iteration's fixed point is the same (the residuals
 * vanish there whatever matrix corrects them); a chord that shrinks its update less than
 * S->chord_rate is followed by a Newton iteration again, and the rule's stagnation clause is read on
 * Newton iterations only (a slow chord is not round-off). Only what the interface needs is formed:
 * the 4 x 4 blocks of two wheelsets of the same car (A_V) or on the same part of the structure (the
 * compliance S between their elements' DOFs, gathered when an element changes), over a list of the
 * coupled pairs and, in each block, the active constraints and the element DOFs where their rows
 * and gradients are not zero (couple, compact, assemble); it is solved by lu_solve3, which follows
 * the rows' profile (a band: the wheelsets are numbered along the train). The span's
 * displacements are followed at the contact elements' DOFs during the iteration (contact_response:
 * the blocks S_wk of the pair as they are, S being the NumPy step's inverse, not exactly symmetric). The convergence rule's update is measured at the vehicle's DOFs and the contact
 * elements' span DOFs; when it is met there, the new iterate is solved at every span DOF (a band
 * solve) and the rule is taken again over every DOF, as the NumPy step takes it.
 */
#include <math.h>
#include <string.h>

#include "loop3d.h"

/* the deck part of z, z', z'' of wheelset w from the span's iterate (held DOFs: their targets) */
static void deck_z(work3d_t* W, int w, const double* uc, double* z, double* zd, double* zdd) {
  const setup3d_t* S = W->S;
  int j;
  if (W->ondeck[w] < 0) {
    for (j = 0; j < 12; ++j) {
      z[4 + j] = W->gz ? W->gz[12 * w + j] : 0.0;
      zd[4 + j] = W->gz ? W->gz[12 * (S->nW + w) + j] : 0.0;
      zdd[4 + j] = W->gz ? W->gz[12 * (2 * S->nW + w) + j] : 0.0;
    }
    return;
  }
  for (j = 0; j < 12; ++j) {
    int d = S->el_dofs[12 * W->ondeck[w] + j];
    double u = W->fidx[12 * w + j] >= 0 ? uc[12 * w + j] : W->uk[d];
    z[4 + j] = u;
    zd[4 + j] = S->a1 * u - W->QB[d];
    zdd[4 + j] = S->a0 * u - W->PB[d];
  }
  if (W->Q0)
    for (j = 0; j < 12; ++j)
      if (W->fidx[12 * w + j] < 0) {
        const int s = W->held_of[S->el_dofs[12 * W->ondeck[w] + j]];
        if (s >= 0) {
          zd[4 + j] = W->Q1[s];
          zdd[4 + j] = W->Q2[s];
        }
      }
}

/* the vehicle part of z, z', z'' of wheelset w from the vehicle's iterate */
static void veh_z(work3d_t* W, int w, double* z, double* zd, double* zdd) {
  const int* d = W->S->ws_dofs + 4 * w;
  int j;
  for (j = 0; j < 4; ++j) {
    z[j] = W->qk[d[j]];
    zd[j] = W->qdk[d[j]];
    zdd[j] = W->qddk[d[j]];
  }
}

/* rows of every wheelset at the iterate (dq, the span at the contact DOFs uc): those of use */
int iterate_rows3(work3d_t* W, const state3d_t* X, const double* uc, const double* xi, const double* irr,
                  int use) {
  const setup3d_t* S = W->S;
  double z[NZ3], zd[NZ3], zdd[NZ3];
  int i, w, st = 0;
  for (i = 0; i < S->nV; ++i) {
    W->qk[i] = X->q[i] + W->dq[i];
    W->qdk[i] = S->a1 * W->dq[i] - W->QtV[i];
    W->qddk[i] = S->a0 * W->dq[i] - W->PtV[i];
  }
  for (w = 0; w < S->nW; ++w) {
    veh_z(W, w, z, zd, zdd);
    deck_z(W, w, uc, z, zd, zdd);
    st |= rows_needed3(W, w, z, zd, zdd, xi[w], irr + 9 * w, use);
  }
  return st ? S3_KERNEL : S3_OK;
}

/* h_w = G_B,w^T lam_w (12 per wheelset): the contact forces' load on the element */
static void element_loads(const work3d_t* W, const double* lam, double* h) {
  int w, j, k;
  for (w = 0; w < W->S->nW; ++w)
    for (j = 0; j < 12; ++j) {
      double s = 0.0;
      for (k = 0; k < PER_WS; ++k) s += W->grad[(4 * w + k) * NZ3 + 4 + j] * lam[4 * w + k];
      h[12 * w + j] = s;
    }
}

/* the span's responses to element loads h (into W->tF: free DOFs) and, with h2, to h2 (into
 * W->tB's first nF: both right-hand sides in one pass of the band solve); u = predictor + the
 * first (all DOFs; the held ones as set) */
static void full_span(work3d_t* W, const double* h, const double* h2, double* u) {
  const setup3d_t* S = W->S;
  int w, j, i;
  memset(W->tF, 0, sizeof(double) * (size_t)S->nF);
  if (h2) memset(W->tB, 0, sizeof(double) * (size_t)S->nF);
  for (w = 0; w < S->nW; ++w)
    for (j = 0; j < 12; ++j) {
      int f = W->fidx[12 * w + j];
      if (f < 0) continue;
      W->tF[f] += h[12 * w + j];
      if (h2) W->tB[f] += h2[12 * w + j];
    }
  if (h2)
    span_solve3_2(W, W->tF, W->tB);
  else
    span_solve3(W, W->tF);
  for (i = 0; i < S->nF; ++i) u[S->free_dofs[i]] = W->uf0[i] + W->tF[i];
}

static int span_coupled(const work3d_t* W, int a, int b) {
  int i, j;
  if (W->ondeck[a] < 0 || W->ondeck[b] < 0) return 0;
  for (i = 0; i < 12; ++i)
    if (W->fidx[12 * a + i] >= 0)
      for (j = 0; j < 12; ++j)
        if (W->fidx[12 * b + j] >= 0)
          return W->S->comp[W->fidx[12 * a + i]] == W->S->comp[W->fidx[12 * b + j]];
  return 0;
}

/* The couplings of the step's wheelsets and the S blocks between their elements (gathered when an
 * element changes: the workspace keeps them from step to step; sel holds element + 1, 0 none), and
 * the list of coupled pairs; nothing to do while every wheelset is on the elements of the last
 * call (seen: 1 once set, then element + 2 of each wheelset). */
static void couple(work3d_t* W) {
  const setup3d_t* S = W->S;
  const int nW = S->nW, nF = S->nF;
  int w, v, i, j, np = 0;
  for (w = 0; w < nW && W->seen[1 + w] == W->ondeck[w] + 2; ++w) {
  }
  if (w == nW && W->seen[0]) return; /* the elements of the last call: its couplings and blocks */
  for (w = 0; w < nW; ++w) W->seen[1 + w] = W->ondeck[w] + 2;
  W->seen[0] = 1;
  for (w = 0; w < nW; ++w) {
    W->pstart[w] = np;
    for (v = 0; v < nW; ++v) {
      int flag = (S->ws_blk[w] == S->ws_blk[v]) | (span_coupled(W, w, v) << 1);
      int* sel = W->sel + 2 * (w * nW + v);
      W->pair[w * nW + v] = flag;
      if (flag) W->plist[np++] = w * nW + v;
      if ((flag & 2) && (sel[0] != W->ondeck[w] + 1 || sel[1] != W->ondeck[v] + 1)) {
        double *B = W->Sblk + 144 * (w * nW + v), *Bt = W->SblkT + 144 * (w * nW + v);
        for (i = 0; i < 12; ++i) {
          int fi = W->fidx[12 * w + i];
          for (j = 0; j < 12; ++j) {
            int fj = W->fidx[12 * v + j];
            B[12 * i + j] = (fi >= 0 && fj >= 0) ? S->S[(long)fi * nF + fj] : 0.0;
            Bt[12 * j + i] = B[12 * i + j];
          }
        }
        sel[0] = W->ondeck[w] + 1;
        sel[1] = W->ondeck[v] + 1;
      }
    }
  }
  W->pstart[nW] = np;
}

/* Each wheelset's active constraints at the iterate and the nonzeros of their gradients and rows
 * at the element's free DOFs (compact: the interface's blocks and the span's response run over
 * these only; the entries left out multiply the compliance's zeros or are zero themselves). */
static void compact(work3d_t* W) {
  const setup3d_t* S = W->S;
  int w, l, m, j;
  for (w = 0; w < S->nW; ++w) {
    int n = 0, ng = 0, nr = 0;
    int* c = W->con + 4 * w;
    for (l = 0; l < 4; ++l)
      if (W->act_of[4 * w + l] >= 0) c[n++] = l;
    W->ncon[w] = n;
    if (!n) continue;
    for (j = 0; j < 12; ++j) {
      int gz = 0, rz = 0;
      if (W->fidx[12 * w + j] < 0) continue;
      for (m = 0; m < n; ++m) {
        int ia = 4 * w + c[m];
        const double* ra = W->landing[ia] ? W->grad + ia * NZ3 : W->jac + ia * NZ3;
        gz |= W->grad[ia * NZ3 + 4 + j] != 0.0;
        rz |= ra[4 + j] != 0.0;
      }
      if (gz) W->nzg[12 * w + ng++] = j;
      if (rz) W->nzr[12 * w + nr++] = j;
    }
    W->nng[w] = ng;
    W->nnr[w] = nr;
    for (m = 0; m < n; ++m) {
      int ia = 4 * w + c[m];
      const double* ra = W->landing[ia] ? W->grad + ia * NZ3 : W->jac + ia * NZ3;
      for (j = 0; j < ng; ++j) W->gc[48 * w + 12 * m + j] = W->grad[ia * NZ3 + 4 + W->nzg[12 * w + j]];
      for (j = 0; j < nr; ++j) W->rc[48 * w + 12 * m + j] = ra[4 + W->nzr[12 * w + j]];
      for (j = 0; j < 4; ++j) W->rv[16 * w + 4 * m + j] = ra[j];
    }
  }
}

/* The interface matrix over the active constraints (na of them), by the coupled pairs: the block
 * of rows of w and columns of v is J_w A_V,wv G_v^T (same car) + J_w S_wv G_v^T (same part). */
static void assemble(work3d_t* W, int na) {
  const setup3d_t* S = W->S;
  const int nW = S->nW;
  int p, w, i, j, r, m;
  memset(W->A, 0, sizeof(double) * (size_t)na * (size_t)na);
  for (p = 0; p < W->pstart[nW]; ++p) {
    const int wv = W->plist[p], w_ = wv / nW, v = wv % nW, flag = W->pair[wv];
    const int nr = W->ncon[w_], nc = W->ncon[v];
    double blk[16];
    if (!nr || !nc) continue;
    for (i = 0; i < 16; ++i) blk[i] = 0.0;
    if (flag & 1) {
      const int *dw = S->ws_dofs + 4 * w_, *dv = S->ws_dofs + 4 * v;
      int b = S->ws_blk[w_], s0 = S->blk_start[b], nb = S->blk_start[b + 1] - s0;
      const double* AB = S->AV + S->blk_off[b];
      double T[16]; /* A_V,wv G_v,V^T: 4 x nc */
      for (i = 0; i < 4; ++i)
        for (m = 0; m < nc; ++m) {
          const double* g = W->grad + (4 * v + W->con[4 * v + m]) * NZ3;
          double s = 0.0;
          for (j = 0; j < 4; ++j) s += AB[(long)(dw[i] - s0) * nb + (dv[j] - s0)] * g[j];
          T[4 * i + m] = s;
        }
      for (r = 0; r < nr; ++r) {
        const double* ra = W->rv + 16 * w_ + 4 * r;
        for (m = 0; m < nc; ++m) {
          double s = 0.0;
          for (i = 0; i < 4; ++i) s += ra[i] * T[4 * i + m];
          blk[4 * r + m] = s;
        }
      }
    }
    if (flag & 2) {
      const double* B = W->Sblk + 144 * (long)wv;
      const int nzr = W->nnr[w_], nzg = W->nng[v];
      const int *ir = W->nzr + 12 * w_, *jg = W->nzg + 12 * v;
      for (r = 0; r < nr; ++r) {
        const double* rr = W->rc + 48 * w_ + 12 * r;
        double y[12]; /* J_w,B S_wv: whole rows of the block (contiguous: vector operations) */
        for (j = 0; j < 12; ++j) y[j] = 0.0;
        for (i = 0; i < nzr; ++i) {
          const double* Bi = B + 12 * ir[i];
          const double a = rr[i];
          for (j = 0; j < 12; ++j) y[j] += a * Bi[j];
        }
        for (m = 0; m < nc; ++m) {
          const double* gg = W->gc + 48 * v + 12 * m;
          double s = 0.0;
          for (j = 0; j < nzg; ++j) s += y[jg[j]] * gg[j];
          blk[4 * r + m] += s;
        }
      }
    }
    for (r = 0; r < nr; ++r) {
      double* row = W->A + (long)W->act_of[4 * w_ + W->con[4 * w_ + r]] * na;
      for (m = 0; m < nc; ++m) row[W->act_of[4 * v + W->con[4 * v + m]]] = blk[4 * r + m];
    }
  }
  (void)w;
}

/* The span's displacements at the contact elements' free DOFs under the element loads h (the
 * predictor's plus the compliance blocks' response), 12 per wheelset on the deck, into un. */
static void contact_at(work3d_t* W, const double* h, double* out) {
  const int nW = W->S->nW;
  int w, i, j, l;
  for (w = 0; w < nW; ++w) {
    double* un = out + 12 * w;
    if (W->ondeck[w] < 0) continue;
    for (i = 0; i < 12; ++i) un[i] = W->uc0[12 * w + i];
    for (l = W->pstart[w]; l < W->pstart[w + 1]; ++l) {
      const int k = W->plist[l] - w * nW;
      const double* Bt = W->SblkT + 144 * (long)W->plist[l];
      const double* hk = h + 12 * k;
      const int* jg = W->nzg + 12 * k;
      const int ng = W->nng[k];
      double acc[12];
      if (!(W->pair[W->plist[l]] & 2) || !W->ncon[k]) continue;
      for (i = 0; i < 12; ++i) acc[i] = 0.0;
      for (j = 0; j < ng; ++j) { /* twelve independent sums (each in the order of j), by columns of
                                  * the block: contiguous in its transpose, so vector operations */
        const double a = hk[jg[j]];
        const double* c = Bt + 12 * jg[j];
        for (i = 0; i < 12; ++i) acc[i] += c[i] * a;
      }
      for (i = 0; i < 12; ++i) un[i] += acc[i];
    }
  }
}

/* contact_at into ucn; the largest change and size */
static void contact_response(work3d_t* W, const double* h, double* change, double* size) {
  const int nW = W->S->nW;
  int w, i;
  contact_at(W, h, W->uch);
  for (w = 0; w < nW; ++w) {
    const double* un = W->uch + 12 * w;
    if (W->ondeck[w] < 0) continue;
    for (i = 0; i < 12; ++i) {
      double d;
      if (W->fidx[12 * w + i] < 0) continue;
      d = fabs(un[i] - W->ucn[12 * w + i]);
      if (d > *change) *change = d;
      W->ucn[12 * w + i] = un[i];
      if (fabs(un[i]) > *size) *size = fabs(un[i]);
    }
  }
}

/* dq = dq0 + A_V G_V^T lam: the cars' displacements under the contact forces lam along the
 * gradients at the iterate */
static void vehicle_response(work3d_t* W, const double* lam, double* dq) {
  const setup3d_t* S = W->S;
  int w, k, j;
  memset(W->gv, 0, sizeof(double) * (size_t)S->nV);
  for (w = 0; w < S->nW; ++w)
    for (k = 0; k < 4; ++k)
      for (j = 0; j < 4; ++j) W->gv[S->ws_dofs[4 * w + j]] += W->grad[(4 * w + k) * NZ3 + j] * lam[4 * w + k];
  memcpy(dq, W->dq0, sizeof(double) * (size_t)S->nV);
  veh_mul3(S, W->AVt, W->gv, dq, 1);
}

/* The chord's right-hand side: minus the residuals at the iterate x, linearised (with the rows of the
 * last Newton iteration) to the state x^ that the forces lam give with the gradients at x (the
 * iterate took them with the gradients before: without this the chord would lag the turn of the
 * force directions by one iteration, and the forces would stop short of the solution). */
static void chord_rhs(work3d_t* W, int na) {
  const setup3d_t* S = W->S;
  int a, k;
  vehicle_response(W, W->lam, W->dqh);
  element_loads(W, W->lam, W->hh2);
  contact_at(W, W->hh2, W->uch);
  for (a = 0; a < na; ++a) {
    const int ia = W->idx[a], wa = ia / 4;
    const double* ra = W->landing[ia] ? W->grad + ia * NZ3 : W->jac + ia * NZ3;
    const int* da = S->ws_dofs + 4 * wa;
    double r = -(W->landing[ia] ? W->gap[ia] : W->res[ia]);
    for (k = 0; k < 4; ++k) r -= ra[k] * (W->dqh[da[k]] - W->dq[da[k]]);
    if (W->ondeck[wa] >= 0)
      for (k = 0; k < 12; ++k)
        if (W->fidx[12 * wa + k] >= 0) r -= ra[4 + k] * (W->uch[12 * wa + k] - W->ucn[12 * wa + k]);
    W->rhs[a] = r;
  }
}

int interface3(work3d_t* W, const state3d_t* X, const int* el, const double* xi, const double* irr) {
  const setup3d_t* S = W->S;
  const int nW = S->nW, nC = 4 * nW, nV = S->nV, nF = S->nF;
  double last = INFINITY, size0 = 0.0;
  double* hh = W->hw;
  int i, j, a, k, w, na = 0, it, st, full = 0, fresh = 1;
  (void)el;
  /* predictors */
  veh_mul3(S, W->AVt, W->fV, W->dq0, 0);
  memcpy(W->uf0, W->fB, sizeof(double) * (size_t)nF);
  span_solve3(W, W->uf0);
  memcpy(W->dq, W->dq0, sizeof(double) * (size_t)nV);
  memset(W->uk, 0, sizeof(double) * (size_t)S->nB);
  if (W->Q0)
    for (i = 0; i < S->nS; ++i) W->uk[S->held[i]] = W->Q0[i];
  for (i = 0; i < nF; ++i) {
    W->uk[S->free_dofs[i]] = W->uf0[i];
    if (fabs(W->uf0[i]) > size0) size0 = fabs(W->uf0[i]);
  }
  if (W->Q0)
    for (i = 0; i < S->nS; ++i)
      if (fabs(W->Q0[i]) > size0) size0 = fabs(W->Q0[i]);
  for (w = 0; w < nW; ++w)
    for (j = 0; j < 12; ++j) {
      int f = W->fidx[12 * w + j];
      W->uc0[12 * w + j] = f >= 0 ? W->uf0[f] : 0.0;
    }
  memcpy(W->ucn, W->uc0, sizeof(double) * (size_t)(12 * nW));
  memset(W->hwp, 0, sizeof(double) * (size_t)(12 * nW));
  for (i = 0; i < nC; ++i) {
    W->lam[i] = 0.0;
    W->act_of[i] = -1;
    if (W->active[i]) {
      W->act_of[i] = na;
      W->idx[na++] = i;
    }
  }
  couple(W);
  for (it = 0; it < NEWTON_ITERATIONS3; ++it) {
    double change = 0.0, size;
    const int newton = fresh;
    W->iterations++;
    st = iterate_rows3(W, X, W->ucn, xi, irr, newton ? ROWS_ITERATE : ROWS_CHORD);
    if (st) return st;
    compact(W);
    if (newton) {
      /* the interface matrix over the active constraints at the iterate, factored, and the new
       * forces from its right-hand side */
      for (a = 0; a < na; ++a) {
        int ia = W->idx[a], wa = ia / 4;
        const double* ra = W->landing[ia] ? W->grad + ia * NZ3 : W->jac + ia * NZ3;
        double Ea = W->landing[ia] ? W->gap[ia] : W->res[ia];
        double r = -Ea;
        const int* da = S->ws_dofs + 4 * wa;
        for (k = 0; k < 4; ++k) r += ra[k] * (W->dq[da[k]] - W->dq0[da[k]]);
        for (k = 0; k < 12; ++k)
          if (W->fidx[12 * wa + k] >= 0) r += ra[4 + k] * (W->ucn[12 * wa + k] - W->uc0[12 * wa + k]);
        W->rhs[a] = r;
      }
      assemble(W, na);
      if (na && lu_factor3(W->A, na, W->piv, W->lu_last, W->lu_first)) return S3_SINGULAR;
      if (na) lu_back3(W->A, na, W->piv, W->lu_last, W->lu_first, W->rhs);
      for (i = 0; i < nC; ++i) W->lamn[i] = 0.0;
      for (a = 0; a < na; ++a) W->lamn[W->idx[a]] = W->rhs[a];
      W->factorizations++;
      fresh = !S->chord;
    } else {
      /* a chord iteration: the correction of the forces by the factored matrix of the last Newton
       * iteration, from the residuals at the iterate (the solution is where they vanish, whatever
       * matrix corrects them: only the rate of convergence depends on it) */
      chord_rhs(W, na);
      lu_back3(W->A, na, W->piv, W->lu_last, W->lu_first, W->rhs);
      for (i = 0; i < nC; ++i) W->lamn[i] = 0.0;
      for (a = 0; a < na; ++a) W->lamn[W->idx[a]] = W->lam[W->idx[a]] + W->rhs[a];
    }
    /* the responses: vehicle (all DOFs), span at the contact DOFs */
    vehicle_response(W, W->lamn, W->dqn);
    element_loads(W, W->lamn, hh);
    size = 0.0;
    contact_response(W, hh, &change, &size);
    for (i = 0; i < nV; ++i) {
      double d = fabs(W->dqn[i] - W->dq[i]), q = fabs(X->q[i] + W->dqn[i]);
      if (d > change) change = d;
      if (q > size) size = q;
      W->dq[i] = W->dqn[i];
    }
    memcpy(W->lam, W->lamn, sizeof(double) * (size_t)nC);
    if (size0 > size) size = size0;
    if (size < 1e-300) size = 1e-300;
    if (!newton && change > NEWTON_TOLERANCE3 * size && change > S->chord_rate * last) {
      /* the chord contracts too slowly (the matrix has aged): a Newton iteration next, and no
       * stagnation read into a slow chord */
      fresh = 1;
      memcpy(W->hwp, hh, sizeof(double) * (size_t)(12 * nW));
      last = change;
      continue;
    }
    if (change <= NEWTON_TOLERANCE3 * size ||
        (newton && change <= STAGNATION3 * size && change > 0.5 * last)) {
      /* stopping by the contact DOFs: the rule again over every DOF of the span, as the NumPy step
       * (the new iterate in full by one band solve, its change from the last by another) */
      double cu = 0.0, su = 0.0;
      for (w = 0; w < 12 * nW; ++w) W->hwp[w] = hh[w] - W->hwp[w];
      full_span(W, hh, W->hwp, W->uk);
      for (i = 0; i < nF; ++i) {
        if (fabs(W->tB[i]) > cu) cu = fabs(W->tB[i]);
      }
      for (i = 0; i < S->nB; ++i)
        if (fabs(W->uk[i]) > su) su = fabs(W->uk[i]);
      if (cu > change) change = cu;
      size = su;
      for (i = 0; i < nV; ++i)
        if (fabs(X->q[i] + W->dq[i]) > size) size = fabs(X->q[i] + W->dq[i]);
      if (size < 1e-300) size = 1e-300;
      memcpy(W->hwp, hh, sizeof(double) * (size_t)(12 * nW));
      if (change <= NEWTON_TOLERANCE3 * size ||
          (newton && change <= STAGNATION3 * size && change > 0.5 * last)) {
        last = change;
        full = 1;
        break;
      }
    } else {
      memcpy(W->hwp, hh, sizeof(double) * (size_t)(12 * nW));
    }
    last = change;
  }
  /* the span's displacements at every DOF: the predictor and the response to the contact loads */
  if (!full) {
    element_loads(W, W->lam, hh);
    full_span(W, hh, 0, W->uk);
  }
  return S3_OK;
}
