/*
 * The workspace of the 3D loop, carved once from the caller's two arrays, and the map from each
 * contact kernel's compressed-column nonzeros to its dense row-major output.
 */
#include "loop3d.h"

#define NOUT 2
#define DENSE SVBI_CONTACT3D_MAX_OUTPUT_DENSE

static double* take_d(double** at, long n, long* count) {
  double* p = *at;
  *count += n;
  if (p) *at += n;
  return p;
}

static int* take_i(int** at, long n, long* count) {
  int* p = *at;
  *count += n;
  if (p) *at += n;
  return p;
}

/* The dense row-major position of every nonzero of every kernel output (CasADi's sparsity:
 * nrow, ncol, colind[ncol + 1], row[nnz]; or nrow, ncol, 1 for a dense output). */
static void kernel_maps(work3d_t* W) {
  int k, o;
  for (k = 0; k < SVBI_CONTACT3D_N_KERNELS; ++k) {
    const svbi_contact3d_kernel* K = &svbi_contact3d_kernels[k];
    for (o = 0; o < NOUT; ++o) {
      int* m = W->map + (k * NOUT + o) * DENSE;
      casadi_int nrow, ncol, c, e;
      const casadi_int* sp;
      W->mapn[k * NOUT + o] = 0;
      W->mapr[k * NOUT + o] = 0;
      if (o >= K->n_out) continue;
      sp = K->sparsity_out(o);
      nrow = sp[0];
      ncol = sp[1];
      W->mapr[k * NOUT + o] = (int)(nrow * ncol);
      if (sp[2] == 1) { /* CasADi's compact form of a dense pattern (a sparse one has colind[0] = 0) */
        for (e = 0; e < nrow * ncol; ++e) m[e] = (int)((e % nrow) * ncol + e / nrow);
        W->mapn[k * NOUT + o] = (int)(nrow * ncol);
        continue;
      }
      for (c = 0; c < ncol; ++c)
        for (e = sp[2 + c]; e < sp[2 + c + 1]; ++e) m[e] = (int)(sp[2 + ncol + 1 + e] * ncol + c);
      W->mapn[k * NOUT + o] = (int)sp[2 + ncol];
    }
  }
}

void w3_carve(const setup3d_t* S, work3d_t* W, double* work, int* iwork, long* nd, long* ni) {
  double* d = work;
  int* i = iwork;
  long cd = 0, ci = 0;
  long nV = S->nV, nF = S->nF, nB = S->nB, nW = S->nW, nC = 4 * S->nW;
  W->S = S;
  W->map = take_i(&i, (long)SVBI_CONTACT3D_N_KERNELS * NOUT * DENSE, &ci);
  W->mapn = take_i(&i, SVBI_CONTACT3D_N_KERNELS * NOUT, &ci);
  W->mapr = take_i(&i, SVBI_CONTACT3D_N_KERNELS * NOUT, &ci);
  W->nz = take_d(&d, NOUT * DENSE, &cd);
  W->kw = take_d(&d, SVBI_CONTACT3D_MAX_SZ_W + 8, &cd);
  W->fV = take_d(&d, nV, &cd);
  W->PtV = take_d(&d, nV, &cd);
  W->QtV = take_d(&d, nV, &cd);
  W->dq0 = take_d(&d, nV, &cd);
  W->dq = take_d(&d, nV, &cd);
  W->dqn = take_d(&d, nV, &cd);
  W->qk = take_d(&d, nV, &cd);
  W->qdk = take_d(&d, nV, &cd);
  W->qddk = take_d(&d, nV, &cd);
  W->gv = take_d(&d, nV, &cd);
  W->tV = take_d(&d, nV, &cd);
  W->AVt = take_d(&d, S->blk_off[S->nblk], &cd);
  W->MVit = take_d(&d, S->blk_off[S->nblk], &cd);
  W->PB = take_d(&d, nB, &cd);
  W->QB = take_d(&d, nB, &cd);
  W->fBfull = take_d(&d, nB, &cd);
  W->fB = take_d(&d, nF, &cd);
  W->uf0 = take_d(&d, nF, &cd);
  W->uk = take_d(&d, nB, &cd);
  W->udk = take_d(&d, nB, &cd);
  W->uddk = take_d(&d, nB, &cd);
  W->bw = take_d(&d, 2 * nF, &cd);
  W->tF = take_d(&d, nF, &cd);
  W->tB = take_d(&d, nB, &cd);
  W->fidx = take_i(&i, nW * 12, &ci);
  W->ondeck = take_i(&i, nW, &ci);
  W->held_of = take_i(&i, nB, &ci);
  W->grad = take_d(&d, nW * 4 * NZ3, &cd);
  W->res = take_d(&d, nW * 4, &cd);
  W->jac = take_d(&d, nW * 4 * NZ3, &cd);
  W->gap = take_d(&d, nW * 4, &cd);
  W->uc0 = take_d(&d, nW * 12, &cd);
  W->pair = take_i(&i, nW * nW, &ci);
  W->sel = take_i(&i, 2 * nW * nW, &ci);
  W->act_of = take_i(&i, nC, &ci);
  W->plist = take_i(&i, nW * nW, &ci);
  W->pstart = take_i(&i, nW + 1, &ci);
  W->seen = take_i(&i, nW + 1, &ci);
  W->ncon = take_i(&i, nW, &ci);
  W->con = take_i(&i, 4 * nW, &ci);
  W->nng = take_i(&i, nW, &ci);
  W->nzg = take_i(&i, 12 * nW, &ci);
  W->nnr = take_i(&i, nW, &ci);
  W->nzr = take_i(&i, 12 * nW, &ci);
  W->gc = take_d(&d, 48 * nW, &cd);
  W->rc = take_d(&d, 48 * nW, &cd);
  W->rv = take_d(&d, 16 * nW, &cd);
  W->Sblk = take_d(&d, 144 * nW * nW, &cd);
  W->SblkT = take_d(&d, 144 * nW * nW, &cd);
  W->hw = take_d(&d, nW * 12, &cd);
  W->hwp = take_d(&d, nW * 12, &cd);
  W->ucn = take_d(&d, nW * 12, &cd);
  W->dqh = take_d(&d, nV, &cd);
  W->uch = take_d(&d, nW * 12, &cd);
  W->hh2 = take_d(&d, nW * 12, &cd);
  W->A = take_d(&d, nC * nC, &cd);
  W->rhs = take_d(&d, nC, &cd);
  W->lam = take_d(&d, nC, &cd);
  W->lamn = take_d(&d, nC, &cd);
  W->start = take_d(&d, nC, &cd);
  W->force = take_d(&d, nC, &cd);
  W->ggap = take_d(&d, nC, &cd);
  W->active = take_i(&i, nC, &ci);
  W->landing = take_i(&i, nC, &ci);
  W->in_contact = take_i(&i, nC, &ci);
  W->idx = take_i(&i, nC, &ci);
  W->piv = take_i(&i, nC, &ci);
  W->lu_last = take_i(&i, nC, &ci);
  W->lu_first = take_i(&i, nC, &ci);
  W->GV = take_d(&d, nC * nV, &cd);
  W->AVm = take_d(&d, nV * nC, &cd);
  W->ABm = take_d(&d, nF * nC, &cd);
  W->G = take_d(&d, nC * nC, &cd);
  W->gt = take_d(&d, nC, &cd);
  W->gtt = take_d(&d, nC, &cd);
  W->gtt2 = take_d(&d, nC, &cd);
  W->want = take_d(&d, nC, &cd);
  W->imp = take_d(&d, nC, &cd);
  W->jump = take_d(&d, nC, &cd);
  W->x0 = take_d(&d, nC, &cd);
  W->y = take_d(&d, nC, &cd);
  W->sub = take_d(&d, nC * nC, &cd);
  W->subr = take_d(&d, nC, &cd);
  W->basic = take_i(&i, nC, &ci);
  W->cand = take_i(&i, nC, &ci);
  W->bad = take_i(&i, nC, &ci);
  W->held2 = take_i(&i, nC, &ci);
  W->nzb = take_i(&i, nF, &ci);
  W->geom = take_d(&d, 8 * nW, &cd);
  W->Q0 = W->Q1 = W->Q2 = 0;
  W->gz = 0;
  *nd = cd;
  *ni = ci;
  if (work && iwork) {
    int j;
    kernel_maps(W);
    for (j = 0; j < NZ3; ++j) W->zero16[j] = 0.0;
    for (j = 0; j < 8 * nW; ++j) W->geom[j] = S->geom[j];
  }
}
