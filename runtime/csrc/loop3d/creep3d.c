/*
 * The explicit creep forces at the end of a step and their generalised loads, which act in the next
 * step (_Step3D._creep): the creepages of both contacts, the creep law (Kalker with
 * Shen-Hedrick-Elkins saturation) under each closed contact's normal force, and the loads along
 * the generated load directions.
 */
#include <string.h>

#include "loop3d.h"

static int creep_forces(work3d_t* W, int w, const double* creepage, double normal, double* F) {
  const casadi_real* arg[SVBI_CONTACT3D_MAX_SZ_ARG];
  casadi_real* res[SVBI_CONTACT3D_MAX_SZ_RES];
  double f[3];
  int e;
  const int* m = W->map + (SVBI_CONTACT3D_K_CREEP_FORCES * 2) * SVBI_CONTACT3D_MAX_OUTPUT_DENSE;
  arg[0] = creepage;
  arg[1] = &normal;
  arg[2] = W->S->material + 10 * w;
  res[0] = W->nz;
  if (svbi_contact3d_creep_forces(arg, res, W->kiw, W->kw, 0)) return S3_KERNEL;
  f[0] = f[1] = f[2] = 0.0;
  for (e = 0; e < W->mapn[SVBI_CONTACT3D_K_CREEP_FORCES * 2]; ++e) f[m[e]] = W->nz[e];
  memcpy(F, f, sizeof f);
  return S3_OK;
}

int creep3(work3d_t* W, state3d_t* X, const int* el, const double* xi, const double* irr) {
  const setup3d_t* S = W->S;
  const int nW = S->nW;
  double z[NZ3], zd[NZ3], cr[6], D[2][NZ3 * 3], c[4] = {S->c1, S->c0, 0.0, 0.0};
  int w, k, i;
  (void)el;
  memset(X->creep, 0, sizeof(double) * (size_t)(6 * nW));
  memset(X->creep_V, 0, sizeof(double) * (size_t)S->nV);
  memset(X->creep_B, 0, sizeof(double) * (size_t)S->nB);
  if (!S->creep) return S3_OK;
  for (w = 0; w < nW; ++w) {
    double* F = X->creep + 6 * w;
    const double* g = W->gz;
    zvec3(W, w, X->q, X->u, g, z);
    zvec3(W, w, X->qd, X->ud, g ? g + 12 * nW : 0, zd);
    if (kcall3(W, SVBI_CONTACT3D_K_CREEPAGES, w, z, zd, W->zero16, xi[w], irr + 9 * w, c, cr, 0))
      return S3_KERNEL;
    for (k = 0; k < 2; ++k) {
      double load = X->contact[4 * w + k] ? X->P[2 * w + k] : 0.0;
      if (load <= 0.0) continue;
      if (creep_forces(W, w, cr + 3 * k, load, F + 3 * k)) return S3_KERNEL;
    }
    if (kcall3(W, SVBI_CONTACT3D_K_CREEP_LOAD_DIRECTIONS, w, z, W->zero16, W->zero16, xi[w], irr + 9 * w, c,
               D[0], D[1]))
      return S3_KERNEL;
    for (i = 0; i < NZ3; ++i) {
      double gen = 0.0;
      for (k = 0; k < 3; ++k) gen += D[0][i * 3 + k] * F[k];
      {
        double g2 = 0.0;
        for (k = 0; k < 3; ++k) g2 += D[1][i * 3 + k] * F[3 + k];
        gen += g2;
      }
      if (i < 4)
        X->creep_V[S->ws_dofs[4 * w + i]] += gen;
      else if (W->ondeck[w] >= 0)
        X->creep_B[S->el_dofs[12 * W->ondeck[w] + i - 4]] += gen;
    }
  }
  return S3_OK;
}
