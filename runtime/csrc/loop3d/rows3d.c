/*
 * The contact kernels of one wheelset (generated/contact3d, CasADi's calling convention): one call
 * with its outputs scattered dense, row-major (as the NumPy module returns them); the four
 * constraints' rows of _Step3D._rows_at that each use needs (gradients, stabilised residuals and their
 * Jacobians, gaps).
 */
#include <string.h>

#include "loop3d.h"

#define DENSE SVBI_CONTACT3D_MAX_OUTPUT_DENSE

int kcall3(work3d_t* W, int k, int w, const double* z, const double* zd, const double* zdd, double xi,
           const double* irr, const double* coef, double* out0, double* out1) {
  const svbi_contact3d_kernel* K = &svbi_contact3d_kernels[k];
  const casadi_real* arg[SVBI_CONTACT3D_MAX_SZ_ARG];
  casadi_real* res[SVBI_CONTACT3D_MAX_SZ_RES];
  double* out[2];
  int o, e;
  arg[0] = z;
  arg[1] = zd;
  arg[2] = zdd;
  arg[3] = z + 4;
  arg[4] = zd + 4;
  arg[5] = zdd + 4;
  arg[6] = &xi;
  arg[7] = W->geom + 8 * w;
  arg[8] = irr;
  arg[9] = coef;
  res[0] = W->nz;
  res[1] = W->nz + DENSE;
  if (K->eval(arg, res, W->kiw, W->kw, 0)) return S3_KERNEL;
  out[0] = out0;
  out[1] = out1;
  for (o = 0; o < K->n_out; ++o) {
    const int* m = W->map + (k * 2 + o) * DENSE;
    const double* nz = W->nz + o * DENSE;
    if (W->mapn[k * 2 + o] < W->mapr[k * 2 + o]) /* a dense pattern writes every entry */
      memset(out[o], 0, sizeof(double) * (size_t)W->mapr[k * 2 + o]);
    for (e = 0; e < W->mapn[k * 2 + o]; ++e) out[o][m[e]] = nz[e];
  }
  return S3_OK;
}

/* z of wheelset w: its four DOFs of q and the element's 12 of u (or the ground's rigid element). */
void zvec3(const work3d_t* W, int w, const double* q, const double* u, const double* ground, double* z) {
  const setup3d_t* S = W->S;
  const int* d = S->ws_dofs + 4 * w;
  int j;
  for (j = 0; j < 4; ++j) z[j] = q[d[j]];
  if (W->ondeck[w] >= 0) {
    const int* e = S->el_dofs + 12 * W->ondeck[w];
    for (j = 0; j < 12; ++j) z[4 + j] = u[e[j]];
  } else {
    for (j = 0; j < 12; ++j) z[4 + j] = ground ? ground[12 * w + j] : 0.0;
  }
}

/* The gradients of wheelset w's four constraints (normal left, right, flange left, right) into
 * W->grad: all the impact's flexibility reads of its rows. */
int gradients3(work3d_t* W, int w, const double* z, const double* zd, const double* zdd, double xi,
               const double* irr) {
  const setup3d_t* S = W->S;
  double c[4] = {S->c1, S->c0, 0.0, 0.0};
  double* g = W->grad + 4 * NZ3 * w;
  int st = 0;
  st |= kcall3(W, SVBI_CONTACT3D_K_NORMAL_GAP_GRADIENTS, w, z, zd, zdd, xi, irr, c, g, 0);
  st |= kcall3(W, SVBI_CONTACT3D_K_FLANGE_GAP_GRADIENTS, w, z, zd, zdd, xi, irr, c, g + 2 * NZ3, 0);
  return st ? S3_KERNEL : S3_OK;
}

/* Only the rows a use needs: ITERATE, the rows of the active constraints
 * (gradients; the stabilised residual and its Jacobian, or the gap of a landing one; the inactive
 * ones' gradients zero: they carry no force); CHORD, those without the Jacobians (an iteration on
 * the interface matrix already factored); CHECK, what the active set reads of the inactive ones
 * (the stabilised residual of one in contact at t_n, the gap of one that was not). */
int rows_needed3(work3d_t* W, int w, const double* z, const double* zd, const double* zdd, double xi,
                 const double* irr, int use) {
  const setup3d_t* S = W->S;
  double c[4] = {S->c1, S->c0, 0.0, 0.0}, cj[4] = {S->c1, S->c0, S->a1, S->a0};
  double* g = W->grad + 4 * NZ3 * w;
  double* j = W->jac + 4 * NZ3 * w;
  double* r = W->res + 4 * w;
  double* gp = W->gap + 4 * w;
  const int* act = W->active + 4 * w;
  const int* land = W->landing + 4 * w;
  const int* in = W->in_contact + 4 * w;
  int st = 0, h;
  for (h = 0; h < 2; ++h) { /* normal pair, flange pair */
    const int a0 = act[2 * h], a1 = act[2 * h + 1];
    int need_res, need_gap, need_grad;
    if (use != ROWS_CHECK) {
      need_grad = a0 || a1;
      need_res = (a0 && !land[2 * h]) || (a1 && !land[2 * h + 1]);
      need_gap = (a0 && land[2 * h]) || (a1 && land[2 * h + 1]);
    } else {
      need_grad = 0;
      need_res = (!a0 && in[2 * h]) || (!a1 && in[2 * h + 1]);
      need_gap = (!a0 && !in[2 * h]) || (!a1 && !in[2 * h + 1]);
    }
    if (need_grad)
      st |= kcall3(W, h ? SVBI_CONTACT3D_K_FLANGE_GAP_GRADIENTS : SVBI_CONTACT3D_K_NORMAL_GAP_GRADIENTS, w, z, zd,
                   zdd, xi, irr, c, g + 2 * h * NZ3, 0);
    else if (use != ROWS_CHECK)
      memset(g + 2 * h * NZ3, 0, sizeof(double) * 2 * NZ3);
    if (need_res) {
      st |= kcall3(W, h ? SVBI_CONTACT3D_K_FLANGE_RESIDUALS : SVBI_CONTACT3D_K_NORMAL_RESIDUALS, w, z, zd, zdd, xi,
                   irr, c, r + 2 * h, 0);
      if (use == ROWS_ITERATE)
        st |= kcall3(W,
                     h ? SVBI_CONTACT3D_K_FLANGE_RESIDUAL_JACOBIANS : SVBI_CONTACT3D_K_NORMAL_RESIDUAL_JACOBIANS,
                     w, z, zd, zdd, xi, irr, cj, j + 2 * h * NZ3, 0);
    }
    if (need_gap)
      st |= kcall3(W, h ? SVBI_CONTACT3D_K_FLANGE_GAPS : SVBI_CONTACT3D_K_NORMAL_GAPS, w, z, zd, zdd, xi, irr, c,
                   gp + 2 * h, 0);
  }
  return st ? S3_KERNEL : S3_OK;
}
