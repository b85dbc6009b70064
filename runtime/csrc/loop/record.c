/*
 * Outputs (svbi.runtime.run.results.Recorder.record): one row of every recorded variable written
 * straight into the recorder's arrays, and the gap check of simulate._Guard.check_gaps.
 */
#include "internal.h"

static void worst_of(double* worst, double g) {
  double a = fabs(g);
  if (*worst != *worst) return; /* NaN stays */
  if (a != a || a > *worst) *worst = a;
}

/* svbi.runtime.methods.reactions.support_reactions: what the span's equation of motion leaves over at each
 * support DOF, R = [M a + C (v - T q') + K u]_s + [N P]_s (beyond the dead load, added in Python),
 * over the DOFs where a support row of M, C or K is non-zero (work_t rc.rr_*; the terms left out are
 * exact zeros). */
static void support_reactions(const setup_t* S, const state_t* X, outputs_t* O, const work_t* w, long row) {
  int s, j, d, i, k, nd = S->nd, ns = S->ns, NS = S->spans * S->ns;
  const double* Mr = S->react_rows;
  const double* Cr = S->react_rows + (long)ns * nd;
  const double* Kr = S->react_rows + 2L * ns * nd;
  for (s = 0; s < S->spans; ++s) {
    const double* q1 = w->sp.qs + NS + (long)s * ns;
    for (j = 0; j < ns; ++j) {
      double r = 0.0;
      for (k = w->rc.rr_ptr[j]; k < w->rc.rr_ptr[j + 1]; ++k) {
        d = w->rc.rr_idx[k];
        r += Mr[j * nd + d] * BR(w->br.ba, s, d) + Cr[j * nd + d] * BR(w->br.bv, s, d) +
             Kr[j * nd + d] * BR(w->br.bu, s, d);
      }
      for (i = 0; i < ns; ++i) r -= S->CT[S->sup[j] * ns + i] * q1[i];
      O->support_reaction[row * NS + s * ns + j] = r;
    }
  }
  for (i = 0; i < S->nc; ++i) {
    int c = i, q; /* index order: the sum of the NumPy side (np.add.at) */
    const double* N0;
    if (!w->ct.con[c]) continue;
    N0 = w->ct.crow + (long)c * ROW_COLS + COL_N0;
    for (q = 0; q < NNZ_N0; ++q) {
      int dof = w->ct.cfirst[c] + nz_N0[q];
      for (j = 0; j < ns; ++j)
        if (S->sup[j] == dof) O->support_reaction[row * NS + w->ct.cspan[c] * ns + j] += N0[nz_N0[q]] * X->P[c];
    }
  }
}

int svbi_record(const setup_t* S, const state_t* X, const excitation_t* E, outputs_t* O, const work_t* w,
                  info_t* I) {
  long row = O->row;
  int s, j, i, ns = S->ns, nc = S->nc, NS = S->spans * S->ns;
  double worst_s = 0.0, worst_v = 0.0, worst_b = 0.0;
  O->time[row] = X->t;
  for (s = 0; s < S->spans; ++s) {
    double uz = 0.0, ux = 0.0, az = 0.0;
    const double* mid_w = S->general ? S->g_mid_w + NE * s : S->mid_w; /* its span's element length */
    for (j = 0; j < NE; ++j) uz += BR(w->br.bu, s, S->mid_first + j) * mid_w[j];
    for (j = 0; j < NE; ++j) ux += BR(w->br.bu, s, S->mid_first + j) * S->mid_u[j];
    for (j = 0; j < NE; ++j) az += BR(w->br.ba, s, S->mid_first + j) * mid_w[j];
    O->midspan_uz[row * S->spans + s] = uz;
    O->midspan_ux[row * S->spans + s] = ux;
    O->deck_acceleration[row * S->spans + s] = az;
    O->end_rotation[(row * S->spans + s) * 2] = BR(w->br.bu, s, 2);
    O->end_rotation[(row * S->spans + s) * 2 + 1] = BR(w->br.bu, s, S->nd - 1);
  }
  if (S->general && S->nsub > S->spans) { /* the pier tops */
    int np = S->nsub - S->spans;
    for (j = 0; j < np; ++j) O->pier_top_ux[row * np + j] = BR(w->br.bu, S->spans + j, 3 * S->elements);
  }
  if (E->ground_per_support) {
    long nrec = n_recorded(S);
    for (j = 0; j < nrec; ++j) {
      O->ground_uz[row * nrec + j] = w->rc.grec[j];
      O->ground_ux[row * nrec + j] = w->rc.grec[nrec + j];
    }
  } else {
    O->ground_uz[row] = w->rc.grec[0];
    O->ground_ux[row] = w->rc.grec[1];
  }
  for (i = 0; i < nc; ++i) O->contact_force[row * nc + i] = X->P[i];
  for (i = 0; i < nc; ++i) O->irregularity[row * nc + i] = w->ct.rail[i];
#if !SVBI_MOVING_LOAD
  if (S->creep) {
    for (i = 0; i < nc; ++i) O->creep_force[row * nc + i] = X->creep_force[i];
    for (i = 0; i < nc; ++i) O->creepage[row * nc + i] = X->creepage[i];
  }
#endif
  if (S->general) {
    for (j = 0; j < S->nact; ++j) {
      int k = S->g_act_slot[j];
      double g = w->sp.qs[k] - BR(w->br.bu, k / 3, S->g_slot_dof[k]);
      O->gap_support[row * S->nact + j] = g;
      worst_of(&worst_s, g);
    }
    svbi_general_reactions(S, X, w, O->support_reaction + row * S->nact);
  } else {
    for (s = 0; s < S->spans; ++s) {
      for (j = 0; j < ns; ++j) {
        int k = s * ns + j;
        double g = w->sp.qs[k] - BR(w->br.bu, s, S->sup[j]);
        O->gap_support[row * NS + k] = g;
        worst_of(&worst_s, g);
      }
    }
    support_reactions(S, X, O, w, row);
  }
#if SVBI_MOVING_LOAD
  for (i = 0; i < nc; ++i) {
    O->gap_vehicle[row * nc + i] = 0.0;
    O->gap_bridge[row * nc + i] = 0.0;
  }
#else
  {
    int k;
    for (k = 0; k < S->cars; ++k) {
      for (i = 0; i < NW; ++i) {
        int c = k * NW + i;
        double whl, aux, rail, gv, gb;
        whl = wheel(S, X->uV + (long)k * NV, i);
        aux = S->method == 2 ? whl : X->ug[c];
        rail = svbi_rail_height(S, w, c);
        gv = whl - aux;
        gb = aux - rail;
        O->gap_vehicle[row * nc + c] = gv;
        O->gap_bridge[row * nc + c] = gb;
        if (S->unilateral) { /* uplift: the wheel-rail gap of an airborne wheel */
          O->contact_state[row * nc + c] = X->in_contact[c];
          /* clipped at 0: a wheel that leaves at this step lies within its row's violation */
          O->wheel_uplift[row * nc + c] = X->in_contact[c] || gb < 0.0 ? 0.0 : gb;
        }
        worst_of(&worst_v, gv);
        /* the guard's bridge gap: the constraint violation of the wheels in contact; an airborne
         * wheel's gap is its uplift, and only a flight beyond the limit stops the run */
        if (!S->unilateral || X->in_contact[c])
          worst_of(&worst_b, gb);
        else if (gb > 0.0)
          worst_of(&worst_b, gb);
      }
      if (S->carbody_z >= 0) {
        O->carbody_uz[row * S->cars + k] = X->uV[k * NV + S->carbody_z];
        O->carbody_az[row * S->cars + k] = X->aV[k * NV + S->carbody_z];
      }
      if (S->carbody_theta >= 0) O->carbody_pitch[row * S->cars + k] = X->uV[k * NV + S->carbody_theta];
      /* every body of the car: the Recorder picks body_uz, body_az, body_pitch from these rows */
      for (j = 0; j < NV; ++j) {
        O->vehicle_u[(row * S->cars + k) * NV + j] = X->uV[k * NV + j];
        O->vehicle_a[(row * S->cars + k) * NV + j] = X->aV[k * NV + j];
      }
    }
  }
#endif
  O->row = row + 1;
  /* simulate._Guard.check_gaps, in its order: support, vehicle, bridge */
  if (!(worst_s <= S->gap_limit)) {
    I->quantity = 1;
    I->value = worst_s;
    return ST_GAP_LIMIT;
  }
  if (!(worst_v <= S->gap_limit)) {
    I->quantity = 2;
    I->value = worst_v;
    return ST_GAP_LIMIT;
  }
  if (!(worst_b <= S->gap_limit)) {
    I->quantity = 3;
    I->value = worst_b;
    return ST_GAP_LIMIT;
  }
  return ST_OK;
}
