/*
 * localized-dynamic (svbi.runtime.methods.localized): each car's effective matrix and wheel flexibility,
 * and the factor of the bridge span with its supports held, are constant (one factor serves every
 * span, every span at once). Each step solves one banded interface system for the contact forces,
 * in track order (docs/c-backend.md, "Structure exploited").
 */
#include "internal.h"

/* The span solve K^_ff X = B for m lanes (svbi_band_solve_lanes with the factor of solver.c). */
static void factor_solve(const setup_t* S, const work_t* w, double* b, const int* rows, long m) {
  svbi_band_solve_lanes(w->fw_d, w->bk_d, w->dinv2, S->nfree, S->band_pf, b, rows, m);
}

/* Row k (span DOF row) of the predictor's right-hand side f_f - K^_fs q^, f = M P + C Q + C T q',
 * for lanes c .. c + W of every span (W <= 3 LW, a constant where it is inlined), accumulated in
 * registers (vec_t) in the order of the sums (exact zeros skipped: C T is half empty, K^_fs nearly all;
 * M and C share one pattern, C = alpha M + beta K: one pass over it). */
static SVBI_ALWAYS_INLINE void rhs_lanes(const setup_t* S, const work_t* w, const double* q1, const double* qh,
                                         int k, int row, long m, long c, const int W, double* restrict f) {
  enum { KMAX = 3 * LW / VW };
  const int K = W / VW; /* registers */
  int i, j, l, ns = S->ns, i0 = S->MC_ptr[row], i1 = S->MC_ptr[row + 1];
  const double* ct = S->CT + row * ns;
  const double* kf = S->Khat_fs + k * ns;
  vec_t a[KMAX];
  for (l = 0; l < K; ++l) a[l] = (vec_t){0.0};
  for (j = 0; j < ns; ++j) {
    const double* q = q1 + j * m + c;
    double v = ct[j];
    if (v == 0.0) continue;
    for (l = 0; l < K; ++l) a[l] += v * VEC(q + l * VW);
  }
  for (i = i0; i < i1; ++i) {
    double vm = S->MC_m[i], vc = S->MC_c[i];
    long o = (long)S->MC_idx[i] * m + c;
    const double* p = w->PB + o;
    const double* q = w->QB + o;
    for (l = 0; l < K; ++l) a[l] += vm * VEC(p + l * VW) + vc * VEC(q + l * VW);
  }
  for (j = 0; j < ns; ++j) {
    const double* q = qh + j * m + c;
    double v = kf[j];
    if (v == 0.0) continue;
    for (l = 0; l < K; ++l) a[l] -= v * VEC(q + l * VW);
  }
  for (l = 0; l < K; ++l) VEC(f + c + l * VW) = a[l];
}

/* Localized: u = S f + R q^ for every span at once: the free DOFs solve K^_ff u_f = f_f - K^_fs q^
 * with f = M P + C Q + C T q', and the support DOFs take their targets. Each row of f is described
 * once (its non-zeros) and accumulated in registers, a few spans at a time, straight into u. */
static void localized_predictor(const setup_t* S, work_t* w, const double* creep) {
  int j, k, s, ns = S->ns, NS = S->spans * S->ns;
  long c, m = w->pad;
  double* q1 = w->qb; /* ns x m */
  double* qh = w->qb + ns * m;
  for (j = 0; j < ns; ++j) {
    for (s = 0; s < m; ++s) {
      q1[j * m + s] = s < S->spans ? w->qs[NS + s * ns + j] : 0.0;
      qh[j * m + s] = s < S->spans ? w->qhat[s * ns + j] : 0.0;
    }
  }
  for (k = 0; k < S->nfree; ++k) {
    int row = S->free[k];
    double* restrict f = w->bu + (long)row * m;
    /* three groups of LW lanes at a time (as the solves), then the rest: fewer passes over the
     * row's description */
    for (c = 0; c + 3 * LW <= m; c += 3 * LW) rhs_lanes(S, w, q1, qh, k, row, m, c, 3 * LW, f);
    if (m - c == 2 * LW) rhs_lanes(S, w, q1, qh, k, row, m, c, 2 * LW, f);
    else if (m - c == LW) rhs_lanes(S, w, q1, qh, k, row, m, c, LW, f);
  }
#if !SVBI_MOVING_LOAD
  if (creep) {
    /* the creep forces of t_n load the rail: -W_T^B F (svbi.runtime.model.wheel_creep) */
    int i, q;
    for (i = 0; i < S->nc; ++i) {
      if (w->con[i] && creep[i] != 0.0) {
        const double* T0 = w->crow + (long)i * ROW_COLS + COL_T0;
        for (q = 0; q < NNZ_T0; ++q) {
          int d = w->cfirst[i] + nz_T0[q];
          if (w->freeidx[d] >= 0) w->bu[(long)d * m + w->cspan[i]] -= T0[nz_T0[q]] * creep[i];
        }
      }
    }
  }
#else
  (void)creep;
#endif
  factor_solve(S, w, w->bu, S->free, m);
  for (j = 0; j < ns; ++j) memcpy(w->bu + (long)S->sup[j] * m, qh + j * m, sizeof(double) * (size_t)m);
}

/* u -= S load for the loads N_i force_i of the contacts on the bridge (loaded spans only). */
static void localized_correct(const setup_t* S, work_t* w, const double* force) {
  int s, k, i, c, nl = 0, nf = S->nfree;
  long m = w->pad, ml;
  for (s = 0; s < S->spans; ++s) {
    w->lidx[s] = w->loaded[s] ? nl : -1;
    if (w->loaded[s]) w->lspan[nl++] = s;
  }
  if (!nl) return;
  ml = (nl + LW - 1) / LW * LW;
  memset(w->RF, 0, sizeof(double) * (size_t)nf * (size_t)ml);
  for (c = 0; c < S->nc; ++c) {
    if (w->con[c]) {
      const double* N0 = w->crow + (long)c * ROW_COLS + COL_N0;
      int l = w->lidx[w->cspan[c]];
      for (i = 0; i < NNZ_N0; ++i) {
        int f = w->freeidx[w->cfirst[c] + nz_N0[i]];
        if (f >= 0) w->RF[(long)f * ml + l] += N0[nz_N0[i]] * force[c];
      }
    }
  }
  factor_solve(S, w, w->RF, 0, ml);
  if (w->lspan[nl - 1] - w->lspan[0] == nl - 1) { /* the loaded spans side by side (one train) */
    int s0 = w->lspan[0];
    for (k = 0; k < nf; ++k) {
      double* u = w->bu + (long)S->free[k] * m + s0;
      const double* r = w->RF + (long)k * ml;
      for (i = 0; i + VW <= nl; i += VW) VEC(u + i) -= VEC(r + i);
      for (; i < nl; ++i) u[i] -= r[i];
    }
    return;
  }
  for (k = 0; k < nf; ++k) {
    double* u = w->bu + (long)S->free[k] * m;
    const double* r = w->RF + (long)k * ml;
    for (i = 0; i < nl; ++i) u[w->lspan[i]] -= r[i];
  }
}

#if !SVBI_MOVING_LOAD
/* F_B of the contacts on each span, pair by pair: W_hat_i S N0_j^T (a landing wheel's row: N0_i),
 * added to the interface band (svbi_row_S_N0). */
static void span_pairs(const setup_t* S, work_t* w, int bw, const int* landing) {
  int s, nd = S->nd;
  for (s = 0; s < S->spans; ++s) {
    int m1, m2;
    for (m1 = w->sstart[s]; m1 < w->sstart[s + 1]; ++m1) {
      int ci = w->slist[m1], land = landing && landing[ci];
      const double* Wh = w->crow + (long)ci * ROW_COLS + (land ? COL_N0 : COL_W_HAT);
      const int* nzW = land ? nz_N0 : nz_W_hat;
      const int nW = land ? NNZ_N0 : NNZ_W_HAT;
      const double* Srows = S->S + (long)w->cfirst[ci] * nd;
      for (m2 = w->sstart[s]; m2 < w->sstart[s + 1]; ++m2) {
        int cj = w->slist[m2];
        const double* N0 = w->crow + (long)cj * ROW_COLS + COL_N0;
        double fij = svbi_row_S_N0(Wh, nzW, nW, Srows, nd, w->cfirst[cj], N0);
        svbi_gb_add(w->band, bw, w->cpos[ci], w->cpos[cj], fij);
      }
    }
  }
}

/* span_pairs through work_t SC: the same products and sums (W_hat_i's entries times the sums over
 * N0_j's), an element's entries side by side in registers. */
static void sc_pairs(const setup_t* S, work_t* w, int bw, const int* landing) {
  enum { NK = NNZ_N0 / VW };
  int s, m1, m2, a, b, v, ncd = w->ncd, h = w->sc_h;
  for (s = 0; s < S->spans; ++s) {
    for (m1 = w->sstart[s]; m1 < w->sstart[s + 1]; ++m1) {
      int ci = w->slist[m1], pi = w->cpos[ci];
      const double* X = w->crow + (long)ci * ROW_COLS + (landing && landing[ci] ? COL_N0 : COL_W_HAT);
      const double* SCi = w->SC + (long)(w->cfirst[ci] / (NE / 2)) * h;
      double xc[SC_NNZ_MAX];
      vec_t xv[NK];
      for (a = 0; a < NNZ_N0; ++a) xc[a] = X[nz_N0[a]];
      for (v = 0; v < NK; ++v) xv[v] = VEC(xc + v * VW);
      for (m2 = w->sstart[s]; m2 < w->sstart[s + 1]; ++m2) {
        int cj = w->slist[m2];
        const double* N0 = w->crow + (long)cj * ROW_COLS + COL_N0;
        const double* r = SCi + (long)(w->cfirst[cj] / (NE / 2)) * h * ncd;
        vec_t t[NK];
        double p[SC_NNZ_MAX], fij = 0.0;
        for (v = 0; v < NK; ++v) t[v] = (vec_t){0.0};
        for (b = 0; b < NNZ_N0; ++b) {
          double n = N0[nz_N0[b]];
          for (v = 0; v < NK; ++v) t[v] += VEC(r + (long)b * ncd + v * VW) * n;
        }
        for (v = 0; v < NK; ++v) VEC(p + v * VW) = xv[v] * t[v];
        for (a = 0; a < NNZ_N0; ++a) fij += p[a];
        svbi_gb_add(w->band, bw, pi, w->cpos[cj], fij);
      }
    }
  }
}

/* (F* + F_B) P = rhs, banded in track order (w->cpos), for the interface of this step; an inactive
 * (airborne) wheel's row is P_i = 0, a landing wheel's the position-level g_{n+1} = 0 (N0 in place
 * of W_hat; svbi.runtime.methods.localized._active_set_solve). */
static int interface_solve(const setup_t* S, work_t* w, int bw, const int* active, const int* landing, double* P) {
  int k, i, j, nc = S->nc, status;
  if (S->general) return svbi_general_interface(S, w, active, landing, P);
  svbi_gb_zero(w->band, nc, bw);
  for (k = 0; k < S->cars; ++k)
    for (i = 0; i < NW; ++i)
      for (j = 0; j < NW; ++j)
        svbi_gb_add(w->band, bw, w->cpos[k * NW + i], w->cpos[k * NW + j], S->V_Fstar[i * NW + j]);
  if (w->sc_h)
    sc_pairs(S, w, bw, landing);
  else
    span_pairs(S, w, bw, landing);
  status = svbi_interface_finish(S, w, nc, bw, active, landing);
  if (status) return status;
  for (i = 0; i < nc; ++i) P[i] = w->bsol[w->cpos[i]];
  return ST_OK;
}

/* The uplift of contact c at t_{n+1} predicted from the interface solution P, before anything is
 * committed (svbi.runtime.methods.unilateral.predicted_uplift): its aux point u_g = p~ + c_g (P - P_V), and
 * the rail N0 u~_B - sum_j N0_c S N0_j^T P_j over the contacts on its span (u~_B the predictor), or
 * the ground off the bridge, plus the irregularity. */
static double predicted_uplift(const setup_t* S, const work_t* w, const double* P, int c) {
  int k = c / NW, i = c % NW, j, m, nd = S->nd;
  double pv = 0.0, ug, rail = svbi_rail_height(S, w, c); /* w->bu still holds the predictor */
  for (j = 0; j < NW; ++j) {
    int cj = k * NW + j;
    pv += (S->c_g[j] * P[cj] - w->dV[cj]) * S->V_B[i * NW + j];
  }
  ug = w->pt[c] + S->c_g[i] * (P[c] - pv);
  if (w->con[c] && S->general) return ug - (rail - svbi_general_deflection(S, w, P, c, 0));
  if (w->con[c]) { /* less the rail's deflection under this step's contact forces */
    const double* Nc = w->crow + (long)c * ROW_COLS + COL_N0;
    int s = w->cspan[c];
    const double* Srows = S->S + (long)w->cfirst[c] * nd;
    for (m = w->sstart[s]; m < w->sstart[s + 1]; ++m) {
      int cj = w->slist[m];
      const double* Nj = w->crow + (long)cj * ROW_COLS + COL_N0;
      rail -= svbi_row_S_N0(Nc, nz_N0, NNZ_N0, Srows, nd, w->cfirst[cj], Nj) * P[cj];
    }
  }
  return ug - rail;
}

/* The complementarity gap of contact c (svbi.runtime.methods.unilateral.ActiveSet.gap): for a wheel in
 * contact at t_n the residual of its stabilised row, (F* + F_B)_c P - rhs_c = u_g - (W_hat u_B + h_B)
 * at t_{n+1}; for a wheel airborne at t_n its predicted uplift. */
static double row_gap(const setup_t* S, const work_t* w, const double* P, int c, int stabilised) {
  int k = c / NW, i = c % NW, j, m, nd = S->nd;
  double r = 0.0;
  if (!stabilised) return predicted_uplift(S, w, P, c);
  for (j = 0; j < NW; ++j) r += S->V_Fstar[i * NW + j] * P[k * NW + j];
  if (w->con[c] && S->general) {
    r += svbi_general_deflection(S, w, P, c, 1);
  } else if (w->con[c]) {
    const double* Wh = w->crow + (long)c * ROW_COLS + COL_W_HAT;
    int s = w->cspan[c];
    const double* Srows = S->S + (long)w->cfirst[c] * nd;
    for (m = w->sstart[s]; m < w->sstart[s + 1]; ++m) {
      int cj = w->slist[m];
      const double* Nj = w->crow + (long)cj * ROW_COLS + COL_N0;
      r += svbi_row_S_N0(Wh, nz_W_hat, NNZ_W_HAT, Srows, nd, w->cfirst[cj], Nj) * P[cj];
    }
  }
  return r - w->rhs[c];
}
#endif

int svbi_step_localized(const setup_t* S, state_t* X, work_t* w) {
  int nc = S->nc;
  /* the histories of this step come from the last step's update (merged pass), or afresh */
  if (!w->hist) svbi_bridge_histories(S, w);
  if (S->general)
    svbi_general_targets(S, w);
  else
    svbi_support_targets(S, w);
  w->hist = 1;
  svbi_group_by_span(S, w);
#if SVBI_MOVING_LOAD
  if (S->general)
    svbi_general_predictor(S, w, 0);
  else
    localized_predictor(S, w, 0);
#else
  if (S->general)
    svbi_general_predictor(S, w, S->creep ? X->creep_force : 0);
  else
    localized_predictor(S, w, S->creep ? X->creep_force : 0);
#endif
#if SVBI_MOVING_LOAD
  {
    int i;
    for (i = 0; i < nc; ++i) w->rhs[i] = w->con[i] ? S->axle_loads[i] : 0.0;
    if (S->general) {
      svbi_general_link_forces(S, w, w->rhs);
      svbi_general_correct(S, w, w->rhs);
    } else {
      localized_correct(S, w, w->rhs);
    }
    svbi_bridge_update_histories(S, w);
    for (i = 0; i < nc; ++i) {
      X->P[i] = S->axle_loads[i];
      X->PV[i] = S->axle_loads[i];
    }
  }
  return ST_OK;
#else
  {
    int k, i, j, m, s, bw, status;
    /* vehicle predictors (all contact forces zero) and the wheel-aux targets. The vehicles solve
     * for the increment over the step (Newmark.update_increment), every car at once as a lane. */
    svbi_vehicle_predictors(S, X, w);
    for (k = 0; k < S->cars; ++k) {
      long cp = w->vcp;
      const double* WT = w->VL + 5L * NV * cp;
      const double *WP = WT + NW * cp, *WQ = WP + NW * cp;
      for (i = 0; i < NW; ++i) {
        int c = k * NW + i;
        double wt = WT[i * cp + k], wp = WP[i * cp + k], wq = WQ[i * cp + k], hV;
        w->Pg[c] = svbi_nm_P(S->a0, S->a2, X->ug[c], X->vg[c], X->ag[c]);
        w->Qg[c] = svbi_nm_Q(S->a1, X->ug[c], X->vg[c]);
        w->pt[c] = (w->Pg[c] - S->gravity) / S->a0;
        hV = S->p_P * (wp - w->Pg[c]) + S->p_Q * (wq - w->Qg[c]);
        w->dV[c] = wt - w->pt[c] - hV;
      }
    }
    /* right-hand side of the interface: h_B - p~ + W_hat^T u~_B - c_g B d_V */
    for (k = 0; k < S->cars; ++k) {
      for (i = 0; i < NW; ++i) {
        int c = k * NW + i;
        double bd = 0.0, wu = 0.0;
        for (j = 0; j < NW; ++j) bd += w->dV[k * NW + j] * S->V_B[i * NW + j];
        if (w->con[c]) {
          const double* Wh = w->crow + (long)c * ROW_COLS + COL_W_HAT;
          for (m = 0; m < NNZ_W_HAT; ++m) wu += Wh[nz_W_hat[m]] * BR(w->bu, w->cspan[c], w->cfirst[c] + nz_W_hat[m]);
        }
        w->hB[c] = svbi_row_target(S, w, c, w->Pg[c], w->Qg[c]);
        w->rhs[c] = w->hB[c] - w->pt[c] + wu - S->c_g[i] * bd;
        if (S->unilateral) { /* a landing row: the rail height r (+ q off the bridge) less N0 u~_B */
          double nu = 0.0;
          if (w->con[c]) {
            const double* N0 = w->crow + (long)c * ROW_COLS + COL_N0;
            for (m = 0; m < NNZ_N0; ++m) nu += N0[nz_N0[m]] * BR(w->bu, w->cspan[c], w->cfirst[c] + nz_N0[m]);
          }
          w->rland[c] = (w->con[c] ? w->rail[c] : w->under[c] + w->rail[c]) - w->pt[c] + nu - S->c_g[i] * bd;
        }
      }
    }
    /* interface matrix F* + F_B, banded in track order (a general bridge: with its links) */
    bw = 0; /* a general bridge orders and bounds its interface itself (general.c) */
    if (!S->general) {
      bw = S->bw_car;
      for (s = 0; s < S->spans; ++s) {
        int run = w->sstart[s + 1] - w->sstart[s];
        if (run - 1 > bw) bw = run - 1;
      }
      if (bw > S->bw_max) return ST_BANDWIDTH;
      if (bw > nc - 1) bw = nc - 1;
      for (k = 0; k < nc; ++k) w->cpos[S->order[k]] = k;
    }
    if (!S->unilateral) {
      status = interface_solve(S, w, bw, 0, 0, X->P);
      if (status) return status;
    } else {
      /* the contact state of the step, one complementarity problem over all wheels
       * (svbi.runtime.methods.unilateral.ActiveSet.update), pass by pass: a wheel in the set whose force
       * goes tensile is released, a free wheel whose gap would close joins it (a wheel airborne
       * at t_n lands: its row the position-level g_{n+1} = 0, then the plastic impact, impact.c);
       * the pivoting rule of pivot_t; the step is solved again after every change */
      pivot_t pv;
      for (i = 0; i < nc; ++i) {
        w->active[i] = X->in_contact[i];
        w->landing[i] = 0;
        w->P0[i] = X->P[i];
      }
      svbi_pivot_init(&pv, nc);
      for (;;) {
        int nbad = 0;
        status = interface_solve(S, w, bw, w->active, w->landing, X->P);
        if (status) return status;
        for (i = 0; i < nc; ++i) { /* all from this pass's P, before any flip */
          w->flip[i] = w->active[i] ? X->P[i] < 0.0 : row_gap(S, w, X->P, i, X->in_contact[i]) < 0.0;
          nbad += w->flip[i];
        }
        if (!nbad) break;
        if (svbi_pivot_flips(&pv, w->flip, nc)) return ST_EVENT; /* NumPy reports a set that does not settle */
        for (i = 0; i < nc; ++i) {
          if (w->flip[i]) w->active[i] = !w->active[i];
          w->landing[i] = w->active[i] && !X->in_contact[i];
        }
      }
    }

    /* back-substitution: wheel-aux forces, aux points, vehicles, bridge */
    for (k = 0; k < S->cars; ++k) {
      for (i = 0; i < NW; ++i) {
        int c = k * NW + i;
        double pv = 0.0;
        for (j = 0; j < NW; ++j) {
          int cj = k * NW + j;
          pv += (S->c_g[j] * X->P[cj] - w->dV[cj]) * S->V_B[i * NW + j];
        }
        X->PV[c] = pv;
      }
      for (i = 0; i < NW; ++i) {
        int c = k * NW + i;
        double ug = w->pt[c] + S->c_g[i] * (X->P[c] - X->PV[c]);
        X->ug[c] = ug;
        X->vg[c] = svbi_nm_vel(S->a1, ug, w->Qg[c]);
        X->ag[c] = svbi_nm_acc(S->a0, ug, w->Pg[c]);
      }
    }
    svbi_vehicle_update(S, X, w);
    if (S->general)
      svbi_general_correct(S, w, X->P);
    else
      localized_correct(S, w, X->P);
    svbi_bridge_update_histories(S, w);
    if (S->unilateral) {
      int landed = 0;
      for (i = 0; i < nc; ++i) landed |= w->landing[i];
      for (i = 0; i < nc; ++i) w->idrop[i] = 0;
      if (landed) { /* the plastic impact at t_{n+1}; the next step's histories afresh */
        status = svbi_impact(S, X, w, w->active, w->landing);
        if (status) return status;
        w->hist = 0;
      }
      for (i = 0; i < nc; ++i) X->in_contact[i] = (unsigned char)(w->active[i] && !w->idrop[i]);
    }
    if (S->creep) svbi_creep_update(S, X, w);
  }
  return ST_OK;
#endif
}
