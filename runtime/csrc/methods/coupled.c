/*
 * coupled-dynamic and coupled-classic (svbi.runtime.methods.coupled_dynamic, .classic): the monolithic system
 * (paper Eq. 36) by block ("arrow") elimination, solved anew every step as the method prescribes
 * (docs/c-backend.md, "Structure exploited").
 */
#include "internal.h"

/* Unknowns: DOF blocks (spans, cars, aux points) and multipliers. Each multiplier has up to two  */
/* attachments to DOF blocks: B (its column in the block's rows) and C (its row in the block's    */
/* columns). The blocks are factored every step; the multipliers' Schur complement             */
/* -sum_b C_b A_b^-1 B_b is banded in track order and solved by LU with partial pivoting.       */

/* Track order of the multipliers: contacts front to back merged with the supports (right support */
/* of span s, then its left ones, from the last span to the first). per_contact: 2 (lamV, lamB)  */
/* or 1 (classic P, or none for moving loads: 0).                                                */
static void multiplier_order(const setup_t* S, work_t* w, int per_contact) {
  int k = 0, pos = 0, s, j, ns = S->ns, nc = S->nc;
  int base = per_contact * nc;
  for (s = S->spans - 1; s >= -1; --s) {
    /* supports at x = (s + 1) L: the left ones of span s + 1 were placed; now the right of span s */
    double xs = (s + 1) * S->span_length;
    if (per_contact) {
      while (k < nc && w->ct.cx[S->order[k]] >= xs) {
        int i = S->order[k++];
        if (per_contact == 2) {
          w->cp.mpos[i] = pos++;
          w->cp.mpos[nc + i] = pos++;
        } else {
          w->cp.mpos[i] = pos++;
        }
      }
    }
    if (s < 0) break;
    for (j = 0; j < ns; ++j)
      if (S->sup_x[j] != 0.0) w->cp.mpos[base + s * ns + j] = pos++;
    xs = s * S->span_length;
    if (per_contact) {
      while (k < nc && w->ct.cx[S->order[k]] >= xs) {
        int i = S->order[k++];
        if (per_contact == 2) {
          w->cp.mpos[i] = pos++;
          w->cp.mpos[nc + i] = pos++;
        } else {
          w->cp.mpos[i] = pos++;
        }
      }
    }
    for (j = 0; j < ns; ++j)
      if (S->sup_x[j] == 0.0) w->cp.mpos[base + s * ns + j] = pos++;
  }
  if (per_contact) {
    while (k < nc) {
      int i = S->order[k++];
      if (per_contact == 2) {
        w->cp.mpos[i] = pos++;
        w->cp.mpos[nc + i] = pos++;
      } else {
        w->cp.mpos[i] = pos++;
      }
    }
  }
}

static void extent(int* lo, int* hi, int p) {
  if (p < *lo) *lo = p;
  if (p > *hi) *hi = p;
}

/* Half bandwidth of the multipliers' Schur complement. */
static int multiplier_bandwidth(const setup_t* S, const work_t* w, int per_contact) {
  int bw = 0, s, j, m, k, i, nc = S->nc, ns = S->ns, base = per_contact * nc;
  for (s = 0; s < S->spans; ++s) {
    int lo = w->cp.mpos[base + s * ns], hi = lo;
    for (j = 0; j < ns; ++j) extent(&lo, &hi, w->cp.mpos[base + s * ns + j]);
    for (m = w->ct.sstart[s]; per_contact && m < w->ct.sstart[s + 1]; ++m) {
      int c = w->ct.slist[m];
      extent(&lo, &hi, w->cp.mpos[(per_contact == 2 ? nc : 0) + c]);
    }
    if (hi - lo > bw) bw = hi - lo;
  }
  if (per_contact && !S->moving_load) {
    for (k = 0; k < S->cars; ++k) {
      int lo = w->cp.mpos[k * S->nw], hi = lo;
      for (i = 0; i < S->nw; ++i) extent(&lo, &hi, w->cp.mpos[k * S->nw + i]);
      if (hi - lo > bw) bw = hi - lo;
    }
    if (per_contact == 2 && bw < 1) bw = 1;
  }
  return bw;
}

/* Constants of the coupled steps, once: the dense inverse of the span block K^_B (every span block
 * is the same constant; its Schur entries C_a K^-1 B_b then need no solve), the reciprocal diagonal
 * of its factor (for the solves of all spans at once) and the car's inverse effective matrix. */
int svbi_coupled_init(const setup_t* S, work_t* w) {
  int i, j, nd = S->nd, p = S->band_p;
  for (i = 0; i < nd; ++i) w->cp.Kdinv[i] = 1.0 / w->cp.Kb[(long)i * (p + 1)];
  if (p <= FS_PMAX) svbi_band_unit_factor(w->cp.Kb, nd, p, w->cp.Kfw, w->cp.Kbk, w->cp.Kd2);
  for (j = 0; j < nd; ++j) {
    double* col = w->cp.XB; /* scratch */
    for (i = 0; i < nd; ++i) col[i] = i == j ? 1.0 : 0.0;
    svbi_band_solve(w->cp.Kb, nd, p, col);
    for (i = 0; i < nd; ++i) w->cp.Kinv[(long)i * nd + j] = col[i];
  }
#if !SVBI_MOVING_LOAD
  if (!S->moving_load) {
    double e[NV];
    int d;
    for (j = 0; j < NV; ++j) {
      for (d = 0; d < NV; ++d) e[d] = d == j ? 1.0 : 0.0;
      svbi_dense_solve(w->cp.Kv, NV, e);
      for (d = 0; d < NV; ++d) w->cp.Kvinv[d * NV + j] = e[d];
    }
  }
#endif
  return ST_OK;
}

/* Solve K^_B x_s = f_s for every span at once: f (span after span, nd each) is copied into XB, DOF
 * after DOF over the spans padded to a multiple of SW, and solved there by one lane solve. */
static void span_solve(const setup_t* S, work_t* w, const double* f) {
  int s, i, nd = S->nd, spans = S->spans;
  long pad = (spans + SW - 1) / SW * SW;
  for (i = 0; i < nd; ++i) {
    double* x = w->cp.XB + (long)i * pad;
    for (s = 0; s < spans; ++s) x[s] = f[(long)s * nd + i];
    for (; s < pad; ++s) x[s] = 0.0;
  }
  if (S->band_p <= FS_PMAX) /* the last rows in registers, as localized-dynamic's span solves */
    svbi_band_solve_lanes(w->cp.Kfw, w->cp.Kbk, w->cp.Kd2, nd, S->band_p, w->cp.XB, 0, pad);
  else
    svbi_band_solve_blocked(w->cp.Kb, w->cp.Kdinv, nd, S->band_p, w->cp.XB, pad / SW);
}

/* Eliminate the span blocks: y_s = K^-1 f_s (all spans at once, in XB); for the attachments a, b
 * of span s add -C_a K^-1 B_b to the Schur complement (from the dense K^-1: no solve) and -C_a y_s
 * to the multipliers' right-hand side. The attachments of span s are its support multipliers
 * (B = -D_G e, C = D_G e at the support DOF) and the aux-bridge (or contact) multipliers of the
 * contacts on it (B = D N0, C = -D W_hat over the element's DOFs; structural zeros skipped). */
static void span_blocks(const setup_t* S, work_t* w, int per_contact, int bw, const double* DB_or_sC,
                        int lamB_base) {
  int s, j, k, m, n, q, r, nd = S->nd, ns = S->ns;
  long pad = (S->spans + SW - 1) / SW * SW;
  const double* Ki = w->cp.Kinv;
  span_solve(S, w, w->cp.xB);
  for (s = 0; s < S->spans; ++s) {
    int m0 = w->ct.sstart[s], m1 = per_contact ? w->ct.sstart[s + 1] : m0;
    const double* y = w->cp.XB + s;
    for (m = m0; m < m1; ++m) {
      /* the contacts' B and C entries (structural non-zeros only), by position in the span list */
      int c = w->ct.slist[m];
      const double* row = w->ct.crow + (long)c * ROW_COLS;
      for (q = 0; q < NNZ_N0; ++q) w->cp.ab[m * NE + q] = row[COL_N0 + nz_N0[q]] * DB_or_sC[c];
      for (q = 0; q < NNZ_W_HAT; ++q) w->cp.ac[m * NE + q] = -row[COL_W_HAT + nz_W_hat[q]] * DB_or_sC[c];
    }
    for (j = 0; j < ns; ++j) {
      int idj = per_contact * S->nc + s * ns + j, rj = w->cp.mpos[idj], sj = S->sup[j];
      double dj = w->cp.DG[j];
      w->cp.rl[idj] -= dj * y[(long)sj * pad];
      for (k = 0; k < ns; ++k)
        svbi_gb_add(w->it.band, bw, rj, w->cp.mpos[per_contact * S->nc + s * ns + k],
                    dj * Ki[(long)sj * nd + S->sup[k]] * w->cp.DG[k]);
      for (n = m0; n < m1; ++n) {
        int cb = w->ct.slist[n];
        const double* kr = Ki + (long)sj * nd + w->ct.cfirst[cb];
        double t = 0.0;
        for (r = 0; r < NNZ_N0; ++r) t += kr[nz_N0[r]] * w->cp.ab[n * NE + r];
        svbi_gb_add(w->it.band, bw, rj, w->cp.mpos[lamB_base + cb], -dj * t);
      }
    }
    for (m = m0; m < m1; ++m) {
      int ca = w->ct.slist[m], ida = lamB_base + ca, ra = w->cp.mpos[ida], fa = w->ct.cfirst[ca];
      const double* cq = w->cp.ac + m * NE;
      double cy = 0.0;
      for (q = 0; q < NNZ_W_HAT; ++q) cy += cq[q] * y[(long)(fa + nz_W_hat[q]) * pad];
      w->cp.rl[ida] -= cy;
      for (k = 0; k < ns; ++k) {
        const double* kc = Ki + (long)S->sup[k] * nd + fa; /* K^-1 is symmetric: row for column */
        double t = 0.0;
        for (q = 0; q < NNZ_W_HAT; ++q) t += cq[q] * kc[nz_W_hat[q]];
        svbi_gb_add(w->it.band, bw, ra, w->cp.mpos[per_contact * S->nc + s * ns + k], t * w->cp.DG[k]);
      }
      for (n = m0; n < m1; ++n) {
        int cb = w->ct.slist[n], fb = w->ct.cfirst[cb];
        const double* bq = w->cp.ab + n * NE;
        double t = 0.0;
        for (q = 0; q < NNZ_W_HAT; ++q) {
          const double* kr = Ki + (long)(fa + nz_W_hat[q]) * nd + fb;
          double u = 0.0;
          for (r = 0; r < NNZ_N0; ++r) u += kr[nz_N0[r]] * bq[r];
          t += cq[q] * u;
        }
        svbi_gb_add(w->it.band, bw, ra, w->cp.mpos[lamB_base + cb], -t);
      }
    }
  }
}

/* x_s = K^-1 (f_s - sum_a B_a lambda_a) for every span at once (f_s still in xB). */
static void span_back(const setup_t* S, work_t* w, int per_contact, int lamB_base, const double* DB_or_sC,
                      state_t* X) {
  int s, i, j, m, q, nd = S->nd, ns = S->ns;
  long pad = (S->spans + SW - 1) / SW * SW;
  for (s = 0; s < S->spans; ++s) {
    double* f = w->cp.xB + (long)s * nd;
    for (j = 0; j < ns; ++j) f[S->sup[j]] += w->cp.DG[j] * w->it.bsol[w->cp.mpos[per_contact * S->nc + s * ns + j]];
    for (m = w->ct.sstart[s]; per_contact && m < w->ct.sstart[s + 1]; ++m) {
      int c = w->ct.slist[m];
      const double* N0 = w->ct.crow + (long)c * ROW_COLS + COL_N0;
      double lam = w->it.bsol[w->cp.mpos[lamB_base + c]] * DB_or_sC[c];
      for (q = 0; q < NNZ_N0; ++q) f[w->ct.cfirst[c] + nz_N0[q]] -= N0[nz_N0[q]] * lam;
    }
  }
  span_solve(S, w, w->cp.xB);
  for (i = 0; i < nd; ++i) {
    const double* x = w->cp.XB + (long)i * pad;
    for (s = 0; s < S->spans; ++s) X->uB[(long)s * nd + i] = x[s];
  }
}

/* The multiplier unknowns are increments (svbi.runtime.methods.coupled_dynamic): the force of a multiplier triple
 * (lambda, lambda', lambda'') is D dlambda - H with H = mbar (P~ + c2 Q~ - omega^2 lambda_n) (newmark.h). */
static double lam_H(const setup_t* S, const double* lam, long n, long i, double mbar) {
  return svbi_nm_multiplier_history(S->a2, S->c2, S->w2, lam, n, i, mbar);
}

static void lam_update(const setup_t* S, double* lam, long n, long i, double delta) {
  svbi_nm_multiplier_update(S->a0, S->a1, S->a2, lam, n, i, delta);
}

int svbi_step_coupled(const setup_t* S, state_t* X, work_t* w, int classic) {
  int s, i, j, nd = S->nd, ns = S->ns, nc = S->nc, NS = S->spans * S->ns, status, bw;
  int per_contact = S->moving_load ? 0 : (classic ? 1 : 2);
  int nm = (int)n_multipliers(S);
  svbi_bridge_histories(S, w);
  svbi_support_targets(S, w);
  svbi_group_by_span(S, w);
  for (j = 0; j < ns; ++j) w->cp.DG[j] = classic ? S->sG[j] : S->d * S->mG[j];
  /* span right-hand sides: f = M P + C Q + C T q' (less the support multipliers' history H_G) */
  for (s = 0; s < S->spans; ++s) {
    double* f = w->cp.xB + (long)s * nd;
    svbi_span_load(S, w, s, f);
    for (j = 0; j < ns; ++j) {
      int k = s * ns + j;
      if (!classic) {
        w->cp.HG[k] = lam_H(S, X->lamG, NS, k, S->mG[j]);
        f[S->sup[j]] -= w->cp.HG[k];
      }
      w->cp.rl[per_contact * nc + k] = w->cp.DG[j] * w->sp.qhat[k];
    }
  }
  if (S->moving_load) {
    for (i = 0; i < nc; ++i) {
      if (w->ct.con[i]) {
        const double* N0 = w->ct.crow + (long)i * ROW_COLS + COL_N0;
        double* f = w->cp.xB + (long)w->ct.cspan[i] * nd + w->ct.cfirst[i];
        for (j = 0; j < NE; ++j) f[j] -= N0[j] * S->axle_loads[i];
      }
    }
  }
#if !SVBI_MOVING_LOAD
  else {
    int k, d, m;
    for (i = 0; i < nc; ++i) {
      int wi = i % NW;
      w->it.Pg[i] = svbi_nm_P(S->a0, S->a2, X->ug[i], X->vg[i], X->ag[i]);
      w->it.Qg[i] = svbi_nm_Q(S->a1, X->ug[i], X->vg[i]);
      if (!classic) {
        if (w->ct.con[i]) {
          double num = 0.0, den = 0.0, pw = 1.0, xi = w->ct.cxi[i];
          for (m = 0; m < S->mb_num_n || m < S->mb_den_n; ++m) {
            if (m < S->mb_num_n) num += S->mb_num[m] * pw;
            if (m < S->mb_den_n) den += S->mb_den[m] * pw;
            pw *= xi;
          }
          w->cp.mB[i] = num / den;
        } else {
          w->cp.mB[i] = S->m_g[wi];
        }
        w->it.dV[i] = S->d * w->cp.mB[i]; /* D_B */
        w->cp.HV[i] = lam_H(S, X->lamV, nc, i, S->mV[wi]);
        w->cp.HB[i] = lam_H(S, X->lamB, nc, i, w->cp.mB[i]);
      } else {
        w->it.dV[i] = S->sC;
      }
    }
    /* the vehicle unknowns are the increments over the step (Newmark.update_increment) */
    for (k = 0; k < S->cars; ++k) {
      const double* u = X->uV + (long)k * NV;
      const double* v = X->vV + (long)k * NV;
      const double* a = X->aV + (long)k * NV;
      double* Pt = w->cp.PVh + (long)k * NV;
      double* Qt = w->cp.QVh + (long)k * NV;
      double* f = w->cp.xV + (long)k * NV;
      double PV[NV], QV[NV];
      svbi_vehicle_increment_load(S, u, v, a, Pt, Qt, PV, QV, f);
      if (!classic) {
        for (d = 0; d < NV; ++d) {
          double sh = 0.0;
          for (i = 0; i < NW; ++i) sh += w->cp.HV[k * NW + i] * S->V_W[d * NW + i];
          f[d] -= sh;
        }
      }
      if (S->creep) svbi_creep_vehicle_load(S, X->creep_force, k, f);
      for (i = 0; i < NW; ++i) {
        int c = k * NW + i;
        double wp = wheel(S, PV, i), wq = wheel(S, QV, i), wn = wheel(S, u, i);
        if (classic) {
          /* the wheel itself touches the rail: its histories replace the aux point's */
          w->cp.rl[c] = S->sC * (svbi_row_target(S, w, c, wp, wq) - wn);
        } else {
          double hV = S->p_P * (wp - w->it.Pg[c]) + S->p_Q * (wq - w->it.Qg[c]);
          w->cp.rl[c] = S->d * S->mV[i] * (hV - wn);
          w->cp.rl[nc + c] = w->it.dV[c] * svbi_row_target(S, w, c, w->it.Pg[c], w->it.Qg[c]);
          w->cp.xg[c] = S->m_g[i] * (w->it.Pg[c] - S->gravity) - w->cp.HB[c] + w->cp.HV[c];
        }
      }
    }
    if (S->creep) svbi_creep_bridge_load(S, X->creep_force, w);
    if (!classic) {
      for (i = 0; i < nc; ++i) {
        if (w->ct.con[i]) {
          const double* N0 = w->ct.crow + (long)i * ROW_COLS + COL_N0;
          double* f = w->cp.xB + (long)w->ct.cspan[i] * nd + w->ct.cfirst[i];
          for (j = 0; j < NE; ++j) f[j] += N0[j] * w->cp.HB[i];
        }
      }
    }
  }
#endif

  /* order, bandwidth and elimination */
  multiplier_order(S, w, per_contact);
  bw = multiplier_bandwidth(S, w, per_contact);
  if (bw > S->bw_max) return ST_BANDWIDTH;
  if (bw > nm - 1) bw = nm - 1;
  svbi_gb_zero(w->it.band, nm, bw);
  span_blocks(S, w, per_contact, bw, w->it.dV, per_contact == 2 ? nc : 0);
#if !SVBI_MOVING_LOAD
  if (!S->moving_load) {
    int k, d, a, b;
    double sc = S->sC;
    for (k = 0; k < S->cars; ++k) {
      double* y = w->cp.xV + (long)k * NV;
      double f[NV];
      memcpy(f, y, sizeof f);
      vec_mat(w->cp.Kvinv, f, y); /* y = K^-1 f (K^-1 symmetric): independent axpys, no divisions */
      for (a = 0; a < NW; ++a) {
        int ca = k * NW + a;
        double wy = 0.0, sa = classic ? sc : S->d * S->mV[a];
        for (d = 0; d < NV; ++d) wy += S->V_W[d * NW + a] * y[d];
        w->cp.rl[ca] -= sa * wy;
        for (b = 0; b < NW; ++b) {
          int cb = k * NW + b;
          double sb = classic ? sc : S->d * S->mV[b];
          svbi_gb_add(w->it.band, bw, w->cp.mpos[ca], w->cp.mpos[cb], sa * sb * w->cp.WG[a * NW + b]);
        }
      }
    }
    if (!classic) {
      for (i = 0; i < nc; ++i) {
        double A = S->a0 * S->m_g[i % NW];
        double DV = S->d * S->mV[i % NW], DB = w->it.dV[i];
        double y = w->cp.xg[i] / A;
        int pv = w->cp.mpos[i], pb = w->cp.mpos[nc + i];
        svbi_gb_add(w->it.band, bw, pv, pv, DV * DV / A);
        svbi_gb_add(w->it.band, bw, pv, pb, -DV * DB / A);
        svbi_gb_add(w->it.band, bw, pb, pv, -DB * DV / A);
        svbi_gb_add(w->it.band, bw, pb, pb, DB * DB / A);
        w->cp.rl[i] += DV * y;
        w->cp.rl[nc + i] -= DB * y;
        w->cp.xg[i] = y;
      }
    }
  }
#endif
  status = svbi_gb_factor(w->it.band, nm, bw, w->it.piv);
  if (status) return status;
  for (i = 0; i < nm; ++i) w->it.bsol[w->cp.mpos[i]] = w->cp.rl[i];
  svbi_gb_solve(w->it.band, nm, bw, w->it.piv, w->it.bsol);

  /* back-substitution and updates */
  span_back(S, w, per_contact, per_contact == 2 ? nc : 0, w->it.dV, X);
  svbi_bridge_update(S, w);
  for (s = 0; s < S->spans; ++s)
    for (j = 0; j < ns; ++j)
      if (!classic) lam_update(S, X->lamG, NS, s * ns + j, w->it.bsol[w->cp.mpos[per_contact * nc + s * ns + j]]);
  if (S->moving_load) {
    for (i = 0; i < nc; ++i) {
      X->P[i] = S->axle_loads[i];
      X->PV[i] = S->axle_loads[i];
    }
    return ST_OK;
  }
#if !SVBI_MOVING_LOAD
  {
    int k, d;
    for (k = 0; k < S->cars; ++k) {
      double* u = X->uV + (long)k * NV;
      const double* y = w->cp.xV + (long)k * NV;
      const double* G = w->cp.G;
      const double* Pt = w->cp.PVh + (long)k * NV;
      const double* Qt = w->cp.QVh + (long)k * NV;
      for (d = 0; d < NV; ++d) {
        double du = y[d];
        for (i = 0; i < NW; ++i) {
          double lam = w->it.bsol[w->cp.mpos[k * NW + i]];
          double sb = classic ? S->sC : S->d * S->mV[i];
          du += sb * G[d * NW + i] * lam;
        }
        X->vV[k * NV + d] = svbi_nm_vel(S->a1, du, Qt[d]);
        X->aV[k * NV + d] = svbi_nm_acc(S->a0, du, Pt[d]);
        u[d] += du;
      }
    }
    if (classic) {
      for (k = 0; k < S->cars; ++k) {
        for (i = 0; i < NW; ++i) {
          int c = k * NW + i;
          X->P[c] = S->sC * w->it.bsol[w->cp.mpos[c]];
          X->PV[c] = X->P[c];
          X->ug[c] = wheel(S, X->uV + (long)k * NV, i);
          X->vg[c] = wheel(S, X->vV + (long)k * NV, i);
          X->ag[c] = wheel(S, X->aV + (long)k * NV, i);
        }
      }
    } else {
      for (i = 0; i < nc; ++i) {
        int wi = i % NW;
        double dlamV = w->it.bsol[w->cp.mpos[i]], dlamB = w->it.bsol[w->cp.mpos[nc + i]];
        double DV = S->d * S->mV[wi], DB = w->it.dV[i];
        double A = S->a0 * S->m_g[wi];
        double ug = w->cp.xg[i] - (DV / A) * dlamV + (DB / A) * dlamB;
        X->ug[i] = ug;
        X->vg[i] = svbi_nm_vel(S->a1, ug, w->it.Qg[i]);
        X->ag[i] = svbi_nm_acc(S->a0, ug, w->it.Pg[i]);
        X->PV[i] = DV * dlamV - w->cp.HV[i];
        X->P[i] = DB * dlamB - w->cp.HB[i];
        lam_update(S, X->lamV, nc, i, dlamV);
        lam_update(S, X->lamB, nc, i, dlamB);
      }
    }
    if (S->creep) svbi_creep_update(S, X, w);
  }
#endif
  return ST_OK;
}
