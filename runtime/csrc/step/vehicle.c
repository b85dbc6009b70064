/*
 * The vehicles' pieces shared by the methods: a car's increment load, the creep forces on the wheel
 * spins and on the rail, the creep law at the new state, and the aux-bridge row target h_B. Not
 * compiled in for moving loads (no vehicle DOFs).
 */
#include "internal.h"

#if !SVBI_MOVING_LOAD
/* One car's increment histories P~ = P - a0 u, Q~ = Q - a1 u, the full histories P, Q, and the load
 * f = F - K^T u + M^T P~ + C^T Q~ of its increment equation (svbi.runtime.model.train.increment_load). */
void svbi_vehicle_increment_load(const setup_t* S, const double* u, const double* v, const double* a,
                                 double* Pt, double* Qt, double* PV, double* QV, double* f) {
  double sm[NV], sc[NV], sk[NV];
  int d;
  for (d = 0; d < NV; ++d) {
    Pt[d] = svbi_nm_Pt(S->a2, v[d], a[d]);
    Qt[d] = v[d];
    PV[d] = svbi_nm_full(S->a0, u[d], Pt[d]);
    QV[d] = svbi_nm_full(S->a1, u[d], Qt[d]);
  }
  vec_mat(S->V_K, u, sk);
  vec_mat(S->V_M, Pt, sm);
  vec_mat(S->V_C, Qt, sc);
  for (d = 0; d < NV; ++d) f[d] = S->V_F[d] - sk[d] + sm[d] + sc[d];
}

/* y = x^T A over column d's non-zeros of A (work_t ve.vnz_*, matrix a), for the cars as lanes (x, y
 * [NV][cp]): every lane's sum is vec_mat's without its exact zeros, in the same order over the rows
 * (the same result), for lanes c .. c + K VW in K registers (K a constant where it is inlined). */
static SVBI_ALWAYS_INLINE void vec_mat_chunk(const work_t* w, int a, const double* x, double* y, long cp, long c,
                                             const int K) {
  const int* ptr = w->ve.vnz_ptr + a * (NV + 1);
  const int* idx = w->ve.vnz_idx + a * NV * NV;
  const double* val = w->ve.vnz_val + a * NV * NV;
  int d, k, l;
  for (d = 0; d < NV; ++d) {
    vec_t s[CAR_KMAX];
    for (l = 0; l < K; ++l) s[l] = (vec_t){0.0};
    for (k = ptr[d]; k < ptr[d + 1]; ++k) {
      const double* xr = x + (long)idx[k] * cp + c;
      double v = val[k];
      for (l = 0; l < K; ++l) s[l] += VEC(xr + l * VW) * v;
    }
    for (l = 0; l < K; ++l) VEC(y + (long)d * cp + c + l * VW) = s[l];
  }
}

/* vec_mat_chunk over all the cars, three chunks of VLANES at a time (fewer passes over A). */
static void lanes_vec_mat(const work_t* w, int a, const double* x, double* y, long cp) {
  long c = 0;
  for (; c + 3 * VLANES <= cp; c += 3 * VLANES) vec_mat_chunk(w, a, x, y, cp, c, 3 * VLANES / VW);
  if (cp - c == 2 * VLANES) vec_mat_chunk(w, a, x, y, cp, c, 2 * VLANES / VW);
  else if (cp - c == VLANES) vec_mat_chunk(w, a, x, y, cp, c, VLANES / VW);
}

/* For wheel i, lanes c .. c + K VW: W^T (u + du~), W^T P and W^T Q (P = a0 u + P~, Q = a1 u + Q~). */
static SVBI_ALWAYS_INLINE void wheel_chunk(const setup_t* S, const double* U, const double* Pt, const double* Qt,
                                           const double* DU, double* WT, double* WP, double* WQ, int i, long cp,
                                           long c, const int K) {
  vec_t st[CAR_KMAX], sp[CAR_KMAX], sq[CAR_KMAX];
  int j, l;
  for (l = 0; l < K; ++l) st[l] = sp[l] = sq[l] = (vec_t){0.0};
  for (j = S->VW_ptr[i]; j < S->VW_ptr[i + 1]; ++j) {
    long r = (long)S->VW_idx[j] * cp + c;
    double v = S->VW_val[j];
    for (l = 0; l < K; ++l) {
      vec_t u = VEC(U + r + l * VW);
      st[l] += (u + VEC(DU + r + l * VW)) * v;
      sp[l] += svbi_nm_full_v(S->a0, u, VEC(Pt + r + l * VW)) * v;
      sq[l] += svbi_nm_full_v(S->a1, u, VEC(Qt + r + l * VW)) * v;
    }
  }
  for (l = 0; l < K; ++l) {
    VEC(WT + i * cp + c + l * VW) = st[l];
    VEC(WP + i * cp + c + l * VW) = sp[l];
    VEC(WQ + i * cp + c + l * VW) = sq[l];
  }
}

/* The localized step's vehicle predictors, every car at once as a lane (work_t ve.VL): the increment
 * load f = F - K^T u + M^T P~ + C^T Q~ (+ the creep forces of t_n on the wheel spins), the
 * predictor increment du~ = K^-T f, and for every wheel W^T (u + du~), W^T P and W^T Q. The sums of
 * svbi_vehicle_increment_load and svbi_creep_vehicle_load in their order, less the exact zeros
 * (the same result); P~, Q~ and du~ stay in VL for svbi_vehicle_update. */
void svbi_vehicle_predictors(const setup_t* S, const state_t* X, work_t* w) {
  long cp = w->ve.vcp, o = NV * cp, c;
  double *U = w->ve.VL, *Pt = U + o, *Qt = Pt + o, *F = Qt + o, *DU = F + o;
  double *WT = DU + o, *WP = WT + NW * cp, *WQ = WP + NW * cp;
  int k, d, i, j;
  for (d = 0; d < NV; ++d) {
    for (k = 0; k < S->cars; ++k) {
      double u = X->uV[(long)k * NV + d], v = X->vV[(long)k * NV + d], a = X->aV[(long)k * NV + d];
      U[d * cp + k] = u;
      Pt[d * cp + k] = svbi_nm_Pt(S->a2, v, a);
      Qt[d * cp + k] = v;
    }
    for (; k < cp; ++k) U[d * cp + k] = Pt[d * cp + k] = Qt[d * cp + k] = 0.0;
  }
  lanes_vec_mat(w, 0, U, F, cp);
  for (d = 0; d < NV; ++d)
    for (c = 0; c < cp; ++c) F[d * cp + c] = S->V_F[d] - F[d * cp + c];
  lanes_vec_mat(w, 1, Pt, DU, cp);
  for (c = 0; c < o; ++c) F[c] += DU[c];
  lanes_vec_mat(w, 2, Qt, DU, cp);
  for (c = 0; c < o; ++c) F[c] += DU[c];
  if (S->creep) { /* W_T^V F of t_n, summed as svbi_creep_vehicle_load */
    const double* force = X->creep_force;
    for (c = 0; c < o; ++c) DU[c] = 0.0;
    for (i = 0; i < NW; ++i) {
      for (j = S->VT_ptr[i]; j < S->VT_ptr[i + 1]; ++j) {
        double* row = DU + (long)S->VT_idx[j] * cp;
        double v = S->VT_val[j];
        for (k = 0; k < S->cars; ++k) row[k] += force[k * NW + i] * v;
      }
    }
    for (c = 0; c < o; ++c) F[c] += DU[c];
  }
  lanes_vec_mat(w, 3, F, DU, cp); /* du~ = K^-T f */
  for (i = 0; i < NW; ++i) {
    for (c = 0; c + 3 * VLANES <= cp; c += 3 * VLANES) wheel_chunk(S, U, Pt, Qt, DU, WT, WP, WQ, i, cp, c, 3 * VLANES / VW);
    if (cp - c == 2 * VLANES) wheel_chunk(S, U, Pt, Qt, DU, WT, WP, WQ, i, cp, c, 2 * VLANES / VW);
    else if (cp - c == VLANES) wheel_chunk(S, U, Pt, Qt, DU, WT, WP, WQ, i, cp, c, VLANES / VW);
  }
}

/* The vehicles' back-substitution, every car at once: du = du~ + V_A P_V (P_V in X->PV), then
 * v = a1 du - Q~, a = a0 du - P~, u += du (Newmark.update_increment), into the state. */
void svbi_vehicle_update(const setup_t* S, state_t* X, work_t* w) {
  long cp = w->ve.vcp, o = NV * cp, c;
  double *U = w->ve.VL, *Pt = U + o, *Qt = Pt + o, *DU = Qt + 2 * o;
  double* LP = DU + o + 3L * NW * cp;
  int k, d, i;
  for (i = 0; i < NW; ++i) {
    for (k = 0; k < S->cars; ++k) LP[i * cp + k] = X->PV[k * NW + i];
    for (; k < cp; ++k) LP[i * cp + k] = 0.0;
  }
  for (d = 0; d < NV; ++d) {
    for (c = 0; c < cp; c += VW) {
      vec_t s = {0.0};
      for (i = 0; i < NW; ++i) s += VEC(LP + i * cp + c) * S->V_A[d * NW + i];
      VEC(DU + d * cp + c) += s;
    }
  }
  for (k = 0; k < S->cars; ++k) {
    for (d = 0; d < NV; ++d) {
      double du = DU[d * cp + k];
      X->vV[(long)k * NV + d] = svbi_nm_vel(S->a1, du, Qt[d * cp + k]);
      X->aV[(long)k * NV + d] = svbi_nm_acc(S->a0, du, Pt[d * cp + k]);
      X->uV[(long)k * NV + d] += du;
    }
  }
}

/* f += W_T^V F: the creep forces of t_n on the wheel spins of car k. */
void svbi_creep_vehicle_load(const setup_t* S, const double* force, int k, double* f) {
  int i, j, d;
  double load[NV];
  for (d = 0; d < NV; ++d) load[d] = 0.0;
  for (i = 0; i < NW; ++i)
    for (j = S->VT_ptr[i]; j < S->VT_ptr[i + 1]; ++j) load[S->VT_idx[j]] += force[k * NW + i] * S->VT_val[j];
  for (d = 0; d < NV; ++d) f[d] += load[d];
}

/* Creepage and creep force of every contact at the new state (svbi.runtime.model.wheel_creep): the
 * creepage (W_T^V' u_V' - rail') / v, rail' following the contact (on the bridge
 * W_T^B' u_B' + v W_T^B'' u_B, off it the longitudinal ground), and the force from the generated
 * creep law (Kalker, Shen-Hedrick-Elkins) under the normal load P. It loads the next step. */
void svbi_creep_update(const setup_t* S, state_t* X, const work_t* w) {
  int k, i, q;
  double v = w->ct.v;
  if (v < S->creep_min_speed) { /* crawling or standing: no creep force (wheel_creep.min_speed) */
    for (i = 0; i < S->nc; ++i) X->creepage[i] = X->creep_force[i] = 0.0;
    return;
  }
  for (k = 0; k < S->cars; ++k) {
    for (i = 0; i < NW; ++i) {
      int c = k * NW + i;
      double xi = 0.0, force = 0.0;
      if (S->creep_rolling[i]) {
        double wheel = 0.0, rail;
        for (q = S->VT_ptr[i]; q < S->VT_ptr[i + 1]; ++q) wheel += X->vV[k * NV + S->VT_idx[q]] * S->VT_val[q];
        if (w->ct.con[c]) {
          const double* row = w->ct.crow + (long)c * ROW_COLS;
          int s = w->ct.cspan[c], f = w->ct.cfirst[c];
          double r0 = 0.0, r1 = 0.0;
          for (q = 0; q < NNZ_T0; ++q) r0 += row[COL_T0 + nz_T0[q]] * BR(w->br.bv, s, f + nz_T0[q]);
          for (q = 0; q < NNZ_T1; ++q) r1 += row[COL_T1 + nz_T1[q]] * BR(w->br.bu, s, f + nz_T1[q]);
          rail = r0 + v * r1;
        } else {
          rail = S->creep_ground ? w->ct.ulon[c] : 0.0;
        }
        xi = (wheel - rail) / v;
        if (X->P[c] > 0.0) {
          /* the law's powers of N are powers of its cube root (svbi.codegen.creep.split_creep_force): one cbrt */
          casadi_real in_xi = xi, in_n = X->P[c], in_n3 = svbi_cube_root(X->P[c]), out_f = 0.0;
          const casadi_real* arg[SVBI_CREEP_SPLIT_MAX_SZ_ARG];
          casadi_real* res[SVBI_CREEP_SPLIT_MAX_SZ_RES];
          arg[0] = &in_xi;
          arg[1] = &in_n;
          arg[2] = w->ve.creepc + CREEP_NC * i;
          arg[3] = &in_n3;
          res[0] = &out_f;
          CREEP_KERNEL(FORCE)(arg, res, 0, 0, 0); /* it needs no work arrays (sz_iw = sz_w = 0) */
          force = out_f;
        }
      }
      X->creepage[c] = xi;
      X->creep_force[c] = force;
    }
  }
}

/* fB -= W_T^B F at the contacts on the bridge (span after span layout, every element DOF). */
void svbi_creep_bridge_load(const setup_t* S, const double* force, work_t* w) {
  int c, q;
  for (c = 0; c < S->nc; ++c) {
    if (w->ct.con[c] && force[c] != 0.0) {
      const double* T0 = w->ct.crow + (long)c * ROW_COLS + COL_T0;
      double* f = w->cp.xB + (long)w->ct.cspan[c] * S->nd + w->ct.cfirst[c];
      for (q = 0; q < NE; ++q) f[q] -= T0[q] * force[c];
    }
  }
}

#else
typedef int svbi_no_vehicle; /* ISO C wants a declaration in every translation unit */
#endif
