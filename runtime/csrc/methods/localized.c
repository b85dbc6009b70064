/*
 * localized-dynamic (svbi.runtime.methods.localized): each car's effective matrix and wheel flexibility,
 * and the bridge's factors with its supports held, are constant. Each step solves one banded
 * interface system for the contact forces, in track order (docs/c-backend.md, "Structure
 * exploited"). The bridge kind (a chain of spans, spans.c; substructures joined by links,
 * substructures.c) reaches the step through its table (work_t kind, set by the loop).
 */
#include "internal.h"

#if !SVBI_MOVING_LOAD
/* The uplift of contact c at t_{n+1} predicted from the interface solution P, before anything is
 * committed (svbi.runtime.methods.unilateral.predicted_uplift): its aux point u_g = p~ + c_g (P - P_V), and
 * the rail N0 u~_B - sum_j N0_c S N0_j^T P_j over the contacts on its span and the links (u~_B the
 * predictor; the bridge kind's rail_under), or the ground off the bridge, plus the irregularity. */
static double predicted_uplift(const setup_t* S, const work_t* w, const double* P, int c) {
  int k = c / NW, i = c % NW, j;
  double pv = 0.0, ug, rail = w->ct.con[c] ? w->kind->rail_under(S, w, P, c) : svbi_rail_height(S, w, c);
  for (j = 0; j < NW; ++j) {
    int cj = k * NW + j;
    pv += (S->c_g[j] * P[cj] - w->it.dV[cj]) * S->V_B[i * NW + j];
  }
  ug = w->it.pt[c] + S->c_g[i] * (P[c] - pv);
  return ug - rail;
}

/* The complementarity gap of contact c (svbi.runtime.methods.unilateral.ActiveSet.gap): for a wheel in
 * contact at t_n the residual of its stabilised row, (F* + F_B)_c P - rhs_c = u_g - (W_hat u_B + h_B)
 * at t_{n+1}; for a wheel airborne at t_n its predicted uplift. */
static double row_gap(const setup_t* S, const work_t* w, const double* P, int c, int stabilised) {
  int k = c / NW, i = c % NW, j;
  double r = 0.0;
  if (!stabilised) return predicted_uplift(S, w, P, c);
  for (j = 0; j < NW; ++j) r += S->V_Fstar[i * NW + j] * P[k * NW + j];
  if (w->ct.con[c]) r = w->kind->add_FB(S, w, P, c, r);
  return r - w->it.rhs[c];
}
#endif

int svbi_step_localized(const setup_t* S, state_t* X, work_t* w) {
  int nc = S->nc;
  /* the histories of this step come from the last step's update (merged pass), or afresh */
  const svbi_bridge_kind* kind = w->kind;
  if (!w->br.hist) svbi_bridge_histories(S, w);
  kind->targets(S, w);
  w->br.hist = 1;
  svbi_group_by_span(S, w);
#if SVBI_MOVING_LOAD
  kind->predictor(S, w, 0);
#else
  kind->predictor(S, w, S->creep ? X->creep_force : 0);
#endif
#if SVBI_MOVING_LOAD
  {
    int i;
    for (i = 0; i < nc; ++i) w->it.rhs[i] = w->ct.con[i] ? S->axle_loads[i] : 0.0;
    kind->prescribed(S, w, w->it.rhs);
    svbi_bridge_update_histories(S, w);
    for (i = 0; i < nc; ++i) {
      X->P[i] = S->axle_loads[i];
      X->PV[i] = S->axle_loads[i];
    }
  }
  return ST_OK;
#else
  {
    int k, i, j, m, bw, status;
    /* vehicle predictors (all contact forces zero) and the wheel-aux targets. The vehicles solve
     * for the increment over the step (Newmark.update_increment), every car at once as a lane. */
    svbi_vehicle_predictors(S, X, w);
    for (k = 0; k < S->cars; ++k) {
      long cp = w->ve.vcp;
      const double* WT = w->ve.VL + 5L * NV * cp;
      const double *WP = WT + NW * cp, *WQ = WP + NW * cp;
      for (i = 0; i < NW; ++i) {
        int c = k * NW + i;
        double wt = WT[i * cp + k], wp = WP[i * cp + k], wq = WQ[i * cp + k], hV;
        w->it.Pg[c] = svbi_nm_P(S->a0, S->a2, X->ug[c], X->vg[c], X->ag[c]);
        w->it.Qg[c] = svbi_nm_Q(S->a1, X->ug[c], X->vg[c]);
        w->it.pt[c] = (w->it.Pg[c] - S->gravity) / S->a0;
        hV = S->p_P * (wp - w->it.Pg[c]) + S->p_Q * (wq - w->it.Qg[c]);
        w->it.dV[c] = wt - w->it.pt[c] - hV;
      }
    }
    /* right-hand side of the interface: h_B - p~ + W_hat^T u~_B - c_g B d_V */
    for (k = 0; k < S->cars; ++k) {
      for (i = 0; i < NW; ++i) {
        int c = k * NW + i;
        double bd = 0.0, wu = 0.0;
        for (j = 0; j < NW; ++j) bd += w->it.dV[k * NW + j] * S->V_B[i * NW + j];
        if (w->ct.con[c]) {
          const double* Wh = w->ct.crow + (long)c * ROW_COLS + COL_W_HAT;
          for (m = 0; m < NNZ_W_HAT; ++m)
            wu += Wh[nz_W_hat[m]] * BR(w->br.bu, w->ct.cspan[c], w->ct.cfirst[c] + nz_W_hat[m]);
        }
        w->it.hB[c] = svbi_row_target(S, w, c, w->it.Pg[c], w->it.Qg[c]);
        w->it.rhs[c] = w->it.hB[c] - w->it.pt[c] + wu - S->c_g[i] * bd;
        if (S->unilateral) { /* a landing row: the rail height r (+ q off the bridge) less N0 u~_B */
          double nu = 0.0;
          if (w->ct.con[c]) {
            const double* N0 = w->ct.crow + (long)c * ROW_COLS + COL_N0;
            for (m = 0; m < NNZ_N0; ++m) nu += N0[nz_N0[m]] * BR(w->br.bu, w->ct.cspan[c], w->ct.cfirst[c] + nz_N0[m]);
          }
          w->un.rland[c] =
              (w->ct.con[c] ? w->ct.rail[c] : w->ct.under[c] + w->ct.rail[c]) - w->it.pt[c] + nu - S->c_g[i] * bd;
        }
      }
    }
    /* interface matrix F* + F_B, banded in track order (a general bridge: with its links) */
    status = kind->order(S, w, &bw);
    if (status) return status;
    if (!S->unilateral) {
      status = kind->interface(S, w, bw, 0, 0, X->P);
      if (status) return status;
    } else {
      /* the contact state of the step, one complementarity problem over all wheels
       * (svbi.runtime.methods.unilateral.ActiveSet.update), pass by pass: a wheel in the set whose force
       * goes tensile is released, a free wheel whose gap would close joins it (a wheel airborne
       * at t_n lands: its row the position-level g_{n+1} = 0, then the plastic impact, impact.c);
       * the pivoting rule of pivot_t; the step is solved again after every change */
      pivot_t pv;
      for (i = 0; i < nc; ++i) {
        w->un.active[i] = X->in_contact[i];
        w->un.landing[i] = 0;
        w->un.P0[i] = X->P[i];
      }
      svbi_pivot_init(&pv, nc);
      for (;;) {
        int nbad = 0;
        status = kind->interface(S, w, bw, w->un.active, w->un.landing, X->P);
        if (status) return status;
        for (i = 0; i < nc; ++i) { /* all from this pass's P, before any flip */
          w->un.flip[i] = w->un.active[i] ? X->P[i] < 0.0 : row_gap(S, w, X->P, i, X->in_contact[i]) < 0.0;
          nbad += w->un.flip[i];
        }
        if (!nbad) break;
        if (svbi_pivot_flips(&pv, w->un.flip, nc)) return ST_EVENT; /* NumPy reports a set that does not settle */
        for (i = 0; i < nc; ++i) {
          if (w->un.flip[i]) w->un.active[i] = !w->un.active[i];
          w->un.landing[i] = w->un.active[i] && !X->in_contact[i];
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
          pv += (S->c_g[j] * X->P[cj] - w->it.dV[cj]) * S->V_B[i * NW + j];
        }
        X->PV[c] = pv;
      }
      for (i = 0; i < NW; ++i) {
        int c = k * NW + i;
        double ug = w->it.pt[c] + S->c_g[i] * (X->P[c] - X->PV[c]);
        X->ug[c] = ug;
        X->vg[c] = svbi_nm_vel(S->a1, ug, w->it.Qg[c]);
        X->ag[c] = svbi_nm_acc(S->a0, ug, w->it.Pg[c]);
      }
    }
    svbi_vehicle_update(S, X, w);
    kind->correct(S, w, X->P);
    svbi_bridge_update_histories(S, w);
    if (S->unilateral) {
      int landed = 0;
      for (i = 0; i < nc; ++i) landed |= w->un.landing[i];
      for (i = 0; i < nc; ++i) w->un.idrop[i] = 0;
      if (landed) { /* the plastic impact at t_{n+1}; the next step's histories afresh */
        status = svbi_impact(S, X, w, w->un.active, w->un.landing);
        if (status) return status;
        w->br.hist = 0;
      }
      for (i = 0; i < nc; ++i) X->in_contact[i] = (unsigned char)(w->un.active[i] && !w->un.idrop[i]);
    }
    if (S->creep) svbi_creep_update(S, X, w);
  }
  return ST_OK;
#endif
}
