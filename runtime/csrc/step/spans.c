/*
 * A chain of identical simply supported spans in the localized step (the bridge kind of the paper;
 * svbi.runtime.methods.localized): the factor of one span with its supports held serves every span,
 * the state DOF after DOF over the spans padded to LW lanes (work_t br.blocked), so that every span
 * solves at once (docs/c-backend.md, "Structure exploited"). The predictor, the interface matrix
 * F* + F_B in track order, the correction by the contact forces and the rail's deflection under
 * them; with bridge.c's location and support targets they make the kind's table svbi_kind_spans.
 */
#include "internal.h"

/* The span solve K^_ff X = B for m lanes (svbi_band_solve_lanes with the factor of solver.c). */
static void factor_solve(const setup_t* S, const work_t* w, double* b, const int* rows, long m) {
  svbi_band_solve_lanes(w->br.fw_d, w->br.bk_d, w->br.dinv2, S->nfree, S->band_pf, b, rows, m);
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
    const double* p = w->br.PB + o;
    const double* q = w->br.QB + o;
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
static void spans_predictor(const setup_t* S, work_t* w, const double* creep) {
  int j, k, s, ns = S->ns, NS = S->spans * S->ns;
  long c, m = w->br.pad;
  double* q1 = w->br.qb; /* ns x m */
  double* qh = w->br.qb + ns * m;
  for (j = 0; j < ns; ++j) {
    for (s = 0; s < m; ++s) {
      q1[j * m + s] = s < S->spans ? w->sp.qs[NS + s * ns + j] : 0.0;
      qh[j * m + s] = s < S->spans ? w->sp.qhat[s * ns + j] : 0.0;
    }
  }
  for (k = 0; k < S->nfree; ++k) {
    int row = S->free[k];
    double* restrict f = w->br.bu + (long)row * m;
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
      if (w->ct.con[i] && creep[i] != 0.0) {
        const double* T0 = w->ct.crow + (long)i * ROW_COLS + COL_T0;
        for (q = 0; q < NNZ_T0; ++q) {
          int d = w->ct.cfirst[i] + nz_T0[q];
          if (w->br.freeidx[d] >= 0) w->br.bu[(long)d * m + w->ct.cspan[i]] -= T0[nz_T0[q]] * creep[i];
        }
      }
    }
  }
#else
  (void)creep;
#endif
  factor_solve(S, w, w->br.bu, S->free, m);
  for (j = 0; j < ns; ++j) memcpy(w->br.bu + (long)S->sup[j] * m, qh + j * m, sizeof(double) * (size_t)m);
}

/* u -= S load for the loads N_i force_i of the contacts on the bridge (loaded spans only). */
static void spans_correct(const setup_t* S, work_t* w, const double* force) {
  int s, k, i, c, nl = 0, nf = S->nfree;
  long m = w->br.pad, ml;
  for (s = 0; s < S->spans; ++s) {
    w->br.lidx[s] = w->br.loaded[s] ? nl : -1;
    if (w->br.loaded[s]) w->br.lspan[nl++] = s;
  }
  if (!nl) return;
  ml = (nl + LW - 1) / LW * LW;
  memset(w->br.RF, 0, sizeof(double) * (size_t)nf * (size_t)ml);
  for (c = 0; c < S->nc; ++c) {
    if (w->ct.con[c]) {
      const double* N0 = w->ct.crow + (long)c * ROW_COLS + COL_N0;
      int l = w->br.lidx[w->ct.cspan[c]];
      for (i = 0; i < NNZ_N0; ++i) {
        int f = w->br.freeidx[w->ct.cfirst[c] + nz_N0[i]];
        if (f >= 0) w->br.RF[(long)f * ml + l] += N0[nz_N0[i]] * force[c];
      }
    }
  }
  factor_solve(S, w, w->br.RF, 0, ml);
  if (w->br.lspan[nl - 1] - w->br.lspan[0] == nl - 1) { /* the loaded spans side by side (one train) */
    int s0 = w->br.lspan[0];
    for (k = 0; k < nf; ++k) {
      double* u = w->br.bu + (long)S->free[k] * m + s0;
      const double* r = w->br.RF + (long)k * ml;
      for (i = 0; i + VW <= nl; i += VW) VEC(u + i) -= VEC(r + i);
      for (; i < nl; ++i) u[i] -= r[i];
    }
    return;
  }
  for (k = 0; k < nf; ++k) {
    double* u = w->br.bu + (long)S->free[k] * m;
    const double* r = w->br.RF + (long)k * ml;
    for (i = 0; i < nl; ++i) u[w->br.lspan[i]] -= r[i];
  }
}


/* The contact forces' correction of the prescribed loads (moving loads: no interface). */
static void spans_prescribed(const setup_t* S, work_t* w, const double* force) { spans_correct(S, w, force); }

#if !SVBI_MOVING_LOAD
/* F_B of the contacts on each span, pair by pair: W_hat_i S N0_j^T (a landing wheel's row: N0_i),
 * added to the interface band (svbi_row_S_N0). */
static void span_pairs(const setup_t* S, work_t* w, int bw, const int* landing) {
  int s, nd = S->nd;
  for (s = 0; s < S->spans; ++s) {
    int m1, m2;
    for (m1 = w->ct.sstart[s]; m1 < w->ct.sstart[s + 1]; ++m1) {
      int ci = w->ct.slist[m1], land = landing && landing[ci];
      const double* Wh = w->ct.crow + (long)ci * ROW_COLS + (land ? COL_N0 : COL_W_HAT);
      const int* nzW = land ? nz_N0 : nz_W_hat;
      const int nW = land ? NNZ_N0 : NNZ_W_HAT;
      const double* Srows = S->S + (long)w->ct.cfirst[ci] * nd;
      for (m2 = w->ct.sstart[s]; m2 < w->ct.sstart[s + 1]; ++m2) {
        int cj = w->ct.slist[m2];
        const double* N0 = w->ct.crow + (long)cj * ROW_COLS + COL_N0;
        double fij = svbi_row_S_N0(Wh, nzW, nW, Srows, nd, w->ct.cfirst[cj], N0);
        svbi_gb_add(w->it.band, bw, w->it.cpos[ci], w->it.cpos[cj], fij);
      }
    }
  }
}

/* span_pairs through work_t br.SC: the same products and sums (W_hat_i's entries times the sums over
 * N0_j's), an element's entries side by side in registers. */
static void sc_pairs(const setup_t* S, work_t* w, int bw, const int* landing) {
  enum { NK = NNZ_N0 / VW };
  int s, m1, m2, a, b, v, ncd = w->br.ncd, h = w->br.sc_h;
  for (s = 0; s < S->spans; ++s) {
    for (m1 = w->ct.sstart[s]; m1 < w->ct.sstart[s + 1]; ++m1) {
      int ci = w->ct.slist[m1], pi = w->it.cpos[ci];
      const double* X = w->ct.crow + (long)ci * ROW_COLS + (landing && landing[ci] ? COL_N0 : COL_W_HAT);
      const double* SCi = w->br.SC + (long)(w->ct.cfirst[ci] / (NE / 2)) * h;
      double xc[SC_NNZ_MAX];
      vec_t xv[NK];
      for (a = 0; a < NNZ_N0; ++a) xc[a] = X[nz_N0[a]];
      for (v = 0; v < NK; ++v) xv[v] = VEC(xc + v * VW);
      for (m2 = w->ct.sstart[s]; m2 < w->ct.sstart[s + 1]; ++m2) {
        int cj = w->ct.slist[m2];
        const double* N0 = w->ct.crow + (long)cj * ROW_COLS + COL_N0;
        const double* r = SCi + (long)(w->ct.cfirst[cj] / (NE / 2)) * h * ncd;
        vec_t t[NK];
        double p[SC_NNZ_MAX], fij = 0.0;
        for (v = 0; v < NK; ++v) t[v] = (vec_t){0.0};
        for (b = 0; b < NNZ_N0; ++b) {
          double n = N0[nz_N0[b]];
          for (v = 0; v < NK; ++v) t[v] += VEC(r + (long)b * ncd + v * VW) * n;
        }
        for (v = 0; v < NK; ++v) VEC(p + v * VW) = xv[v] * t[v];
        for (a = 0; a < NNZ_N0; ++a) fij += p[a];
        svbi_gb_add(w->it.band, bw, pi, w->it.cpos[cj], fij);
      }
    }
  }
}

/* The interface's order (track order) and half bandwidth this step: the larger of a car's and the
 * most wheels on one span, less one. */
static int spans_order(const setup_t* S, work_t* w, int* bandwidth) {
  int s, k, nc = S->nc, bw = S->bw_car;
  for (s = 0; s < S->spans; ++s) {
    int run = w->ct.sstart[s + 1] - w->ct.sstart[s];
    if (run - 1 > bw) bw = run - 1;
  }
  if (bw > S->bw_max) return ST_BANDWIDTH;
  if (bw > nc - 1) bw = nc - 1;
  for (k = 0; k < nc; ++k) w->it.cpos[S->order[k]] = k;
  *bandwidth = bw;
  return ST_OK;
}

/* (F* + F_B) P = rhs, banded in track order (w->it.cpos), for the interface of this step; an inactive
 * (airborne) wheel's row is P_i = 0, a landing wheel's the position-level g_{n+1} = 0 (N0 in place
 * of W_hat; svbi.runtime.methods.localized._active_set_solve). */
static int spans_interface(const setup_t* S, work_t* w, int bw, const int* active, const int* landing, double* P) {
  int k, i, j, nc = S->nc, status;
  svbi_gb_zero(w->it.band, nc, bw);
  for (k = 0; k < S->cars; ++k)
    for (i = 0; i < NW; ++i)
      for (j = 0; j < NW; ++j)
        svbi_gb_add(w->it.band, bw, w->it.cpos[k * NW + i], w->it.cpos[k * NW + j], S->V_Fstar[i * NW + j]);
  if (w->br.sc_h)
    sc_pairs(S, w, bw, landing);
  else
    span_pairs(S, w, bw, landing);
  status = svbi_interface_finish(S, w, nc, bw, active, landing);
  if (status) return status;
  for (i = 0; i < nc; ++i) P[i] = w->it.bsol[w->it.cpos[i]];
  return ST_OK;
}

/* The rail's height under contact c (on the bridge) less its deflection under this step's contact
 * forces P on its span: svbi_rail_height - sum_j N0_c S N0_j^T P_j (w->br.bu holds the predictor). */
static double spans_rail_under(const setup_t* S, const work_t* w, const double* P, int c) {
  int m, nd = S->nd, s = w->ct.cspan[c];
  double rail = svbi_rail_height(S, w, c);
  const double* Nc = w->ct.crow + (long)c * ROW_COLS + COL_N0;
  const double* Srows = S->S + (long)w->ct.cfirst[c] * nd;
  for (m = w->ct.sstart[s]; m < w->ct.sstart[s + 1]; ++m) {
    int cj = w->ct.slist[m];
    const double* Nj = w->ct.crow + (long)cj * ROW_COLS + COL_N0;
    rail -= svbi_row_S_N0(Nc, nz_N0, NNZ_N0, Srows, nd, w->ct.cfirst[cj], Nj) * P[cj];
  }
  return rail;
}

/* r + (F_B P)_c for contact c on the bridge: its stabilised row W_hat through the span's S. */
static double spans_add_FB(const setup_t* S, const work_t* w, const double* P, int c, double r) {
  int m, nd = S->nd, s = w->ct.cspan[c];
  const double* Wh = w->ct.crow + (long)c * ROW_COLS + COL_W_HAT;
  const double* Srows = S->S + (long)w->ct.cfirst[c] * nd;
  for (m = w->ct.sstart[s]; m < w->ct.sstart[s + 1]; ++m) {
    int cj = w->ct.slist[m];
    const double* Nj = w->ct.crow + (long)cj * ROW_COLS + COL_N0;
    r += svbi_row_S_N0(Wh, nz_W_hat, NNZ_W_HAT, Srows, nd, w->ct.cfirst[cj], Nj) * P[cj];
  }
  return r;
}
#endif

const svbi_bridge_kind svbi_kind_spans = {
    svbi_locate,
    svbi_support_targets,
    spans_predictor,
    spans_prescribed,
#if SVBI_MOVING_LOAD
    0, 0, 0, 0, 0,
#else
    spans_order,
    spans_interface,
    spans_correct,
    spans_rail_under,
    spans_add_FB,
#endif
};
