/*
 * The perfectly plastic impact of landing wheels at t_{n+1} (svbi.runtime.methods.unilateral.Impact,
 * docs/method.md section 12, step 4), after the localized step's Newmark update: the landing wheels
 * lose their relative normal velocity (an impulse through the mass flexibility G at the contacts),
 * then the accelerations become consistent with the landing wheels staying on the rail (a force
 * jump J through the same G); a landing wheel whose consistent force would be tensile touches with
 * zero relative velocity and leaves at once.
 *
 * G = W^T M_V^-1 W per car (full vehicle mass: the aux point rides its wheel during the impact) plus
 * N_i^T S_M N_j between contacts on one substructure, S_M the bridge's mass compliance with its
 * supports held; on a bridge with links, less the path through the rigid links
 * (C_N A_M^-1 C_N^T, A_M = L S_M L^T: a bearing spring passes no impulse). An event step, so the
 * bridge fields are whole-bridge products; nothing here runs on a step without a landing.
 */
#include "internal.h"

#if !SVBI_MOVING_LOAD

/* N0, N1 = dN0/dx and N2 = d2N0/dx2 under contact c: N0 from its contact rows, N1 and N2 from the
 * generated shape tables of its span's element length (I_shapes, polynomials in xi). */
static void shape_rows(const setup_t* S, const work_t* w, int c, double* N0, double* N1, double* N2) {
  int p, j, cls = S->general ? S->g_rclass[w->ct.cspan[c]] : 0;
  const double* t1 = S->I_shapes + (long)cls * 2 * (ROW_DEG + 1) * NE;
  const double* t2 = t1 + (ROW_DEG + 1) * NE;
  double xi = w->ct.cxi[c], pw[ROW_DEG + 1];
  pw[0] = 1.0;
  for (p = 1; p <= ROW_DEG; ++p) pw[p] = pw[p - 1] * xi;
  for (j = 0; j < NE; ++j) {
    double d1 = 0.0, d2 = 0.0;
    for (p = 0; p <= ROW_DEG; ++p) {
      d1 += t1[p * NE + j] * pw[p];
      d2 += t2[p * NE + j] * pw[p];
    }
    N0[j] = w->ct.crow[(long)c * ROW_COLS + COL_N0 + j];
    N1[j] = d1;
    N2[j] = d2;
  }
}

static inline const double* mass_compliance(const setup_t* S, int sub) {
  return S->I_SM + (S->general ? (long)S->g_kind[sub] * S->nd * S->nd : 0L);
}

static inline double dot_el(const work_t* w, const setup_t* S, const double* X, const double* b, int c) {
  int j;
  double f = 0.0;
  for (j = 0; j < NE; ++j) f += X[j] * BR(b, w->ct.cspan[c], w->ct.cfirst[c] + j);
  return f;
}

/* out = S_M,eff F for whole-bridge arrays in the loop's layout (BR): every substructure's mass
 * compliance, then the rigid links closed (the NumPy SubstructureCompliance.field). */
static void mass_field(const setup_t* S, work_t* w, const double* F, double* out) {
  int s, i, j, l, nd = S->nd, subs = (int)n_subs(S);
  memset(out, 0, sizeof(double) * (size_t)w->br.nb); /* the blocked layout's padding lanes stay 0 */
  for (s = 0; s < subs; ++s) {
    const double* SM = mass_compliance(S, s);
    const double* fs = w->br.fb;
    if (w->br.blocked) {
      for (j = 0; j < nd; ++j) w->br.fb[j] = BR(F, s, j);
    } else {
      fs = F + (long)s * nd;
    }
    for (i = 0; i < nd; ++i) {
      double v = 0.0;
      for (j = 0; j < nd; ++j) v += SM[(long)i * nd + j] * fs[j];
      BR(out, s, i) = v;
    }
  }
  if (!S->general || !S->nlinks) return;
  for (l = 0; l < S->nlinks; ++l) {
    double gap = BR(out, S->g_lk_a_sub[l], S->g_lk_a_dof[l]) - BR(out, S->g_lk_b_sub[l], S->g_lk_b_dof[l]);
    w->ge.lam0[l] = S->g_lk_spring[l] ? 0.0 : gap; /* a spring passes no impulse */
  }
  svbi_band_solve(w->un.LAM, S->nlinks, S->band_links, w->ge.lam0);
  for (l = 0; l < S->nlinks; ++l) {
    const double* ca = S->I_lk_col_a + (long)l * nd;
    const double* cb = S->I_lk_col_b + (long)l * nd;
    for (i = 0; i < nd; ++i) BR(out, S->g_lk_a_sub[l], i) -= ca[i] * w->ge.lam0[l];
    for (i = 0; i < nd; ++i) BR(out, S->g_lk_b_sub[l], i) += cb[i] * w->ge.lam0[l];
  }
}

/* F = sum_i N_i f_i over the contacts on the bridge (whole bridge, BR layout). */
static void contact_load(const setup_t* S, work_t* w, const double* f, double* F) {
  int c, j;
  memset(F, 0, sizeof(double) * (size_t)w->br.nb);
  for (c = 0; c < S->nc; ++c) {
    if (!w->ct.con[c] || f[c] == 0.0) continue;
    for (j = 0; j < NE; ++j)
      BR(F, w->ct.cspan[c], w->ct.cfirst[c] + j) += w->ct.crow[(long)c * ROW_COLS + COL_N0 + j] * f[c];
  }
}

/* The mass flexibility G (nc x nc, dense, row-major) at the contacts. */
static void flexibility(const setup_t* S, work_t* w, double* G) {
  int i, j, l, m, nc = S->nc, nd = S->nd;
  memset(G, 0, sizeof(double) * (size_t)nc * (size_t)nc);
  for (i = 0; i < nc; ++i)
    for (j = 0; j < NW; ++j) G[(long)i * nc + (i / NW) * NW + j] = S->I_GV[(i % NW) * NW + j];
  for (i = 0; i < nc; ++i) {
    const double* Ni = w->ct.crow + (long)i * ROW_COLS + COL_N0;
    const double* SM;
    if (!w->ct.con[i]) continue;
    SM = mass_compliance(S, w->ct.cspan[i]);
    for (j = 0; j < nc; ++j) {
      const double* Nj = w->ct.crow + (long)j * ROW_COLS + COL_N0;
      if (!w->ct.con[j] || w->ct.cspan[j] != w->ct.cspan[i]) continue;
      G[(long)i * nc + j] += svbi_row_S_N0(Ni, nz_N0, NNZ_N0, SM + (long)w->ct.cfirst[i] * nd, nd, w->ct.cfirst[j], Nj);
    }
  }
  if (!S->general || !S->nlinks) return;
  /* less C_N A_M^-1 C_N^T, column by column: x = A_M^-1 (C_N^T)_j, then G_ij -= (C_N)_i x */
  for (j = 0; j < nc; ++j) {
    int sj = w->ct.cspan[j];
    const double* Nj = w->ct.crow + (long)j * ROW_COLS + COL_N0;
    if (!w->ct.con[j]) continue;
    for (l = 0; l < S->nlinks; ++l) w->ge.lam[l] = 0.0;
    for (m = S->g_sl_ptr[sj]; m < S->g_sl_ptr[sj + 1]; ++m) {
      l = S->g_sl_link[m];
      w->ge.lam[l] = svbi_general_row_link(S, Nj, nz_N0, NNZ_N0, sj, w->ct.cfirst[j], l, S->I_lk_col_a, S->I_lk_col_b);
    }
    svbi_band_solve(w->un.LAM, S->nlinks, S->band_links, w->ge.lam);
    for (i = 0; i < nc; ++i) {
      int si = w->ct.cspan[i];
      const double* Ni = w->ct.crow + (long)i * ROW_COLS + COL_N0;
      double g = 0.0;
      if (!w->ct.con[i]) continue;
      for (m = S->g_sl_ptr[si]; m < S->g_sl_ptr[si + 1]; ++m) {
        l = S->g_sl_link[m];
        g += svbi_general_row_link(S, Ni, nz_N0, NNZ_N0, si, w->ct.cfirst[i], l, S->I_lk_col_a, S->I_lk_col_b) *
             w->ge.lam[l];
      }
      G[(long)i * nc + j] -= g;
    }
  }
}

/* Solve G[u, u] x_u = r_u for the contacts with mask[i] (dense Cholesky: G is a flexibility). */
static int solve_on(const setup_t* S, work_t* w, const double* G, const int* mask, const double* r, double* x) {
  int i, j, n = 0, nc = S->nc, status;
  for (i = 0; i < nc; ++i)
    if (mask[i]) w->un.iidx[n++] = i;
  for (i = 0; i < nc; ++i) x[i] = 0.0;
  if (!n) return ST_OK;
  for (i = 0; i < n; ++i)
    for (j = 0; j < n; ++j) w->un.IGs[(long)i * n + j] = G[(long)w->un.iidx[i] * nc + w->un.iidx[j]];
  status = svbi_dense_cholesky(w->un.IGs, n);
  if (status) return ST_SINGULAR;
  for (i = 0; i < n; ++i) w->un.ib[i] = r[w->un.iidx[i]];
  svbi_dense_solve(w->un.IGs, n, w->un.ib);
  for (i = 0; i < n; ++i) x[w->un.iidx[i]] = w->un.ib[i];
  return ST_OK;
}

/* y with z = x0 + y >= 0, w = G y - want >= 0, z w = 0 over the candidates, the others at z = 0
 * (y = -x0) (svbi.runtime.methods.unilateral.complementary_solve): the complementary sets pass by pass,
 * each solved on its basic set (w = 0 there), flipped by the rule of pivot_t. `basic` returns the
 * candidates with w = 0; the rest have z = 0. */
static int complementary_solve(const setup_t* S, work_t* w, const double* G, const double* want, const double* x0,
                               const int* cand, double* y, int* basic) {
  int i, j, nc = S->nc, status, ncand = 0;
  pivot_t pv;
  for (i = 0; i < nc; ++i) {
    basic[i] = cand[i];
    ncand += cand[i] != 0;
  }
  svbi_pivot_init(&pv, ncand);
  for (;;) {
    int nbad = 0;
    for (i = 0; i < nc; ++i) { /* want_b - G_bf y_f, y_f = -x0_f */
      double r = 0.0;
      if (basic[i])
        for (j = 0; j < nc; ++j)
          if (!basic[j]) r += G[(long)i * nc + j] * -x0[j];
      w->un.ib3[i] = want[i] - r;
    }
    status = solve_on(S, w, G, basic, w->un.ib3, y);
    if (status) return status;
    for (i = 0; i < nc; ++i)
      if (!basic[i]) y[i] = -x0[i];
    for (i = 0; i < nc; ++i) {
      int bad = 0;
      if (basic[i]) {
        bad = x0[i] + y[i] < 0.0;
      } else if (cand[i]) {
        double g = 0.0;
        for (j = 0; j < nc; ++j) g += G[(long)i * nc + j] * y[j];
        bad = g - want[i] < 0.0;
      }
      w->un.flip[i] = bad;
      nbad += bad;
    }
    if (!nbad) return ST_OK;
    if (svbi_pivot_flips(&pv, w->un.flip, nc)) return ST_EVENT;
    for (i = 0; i < nc; ++i)
      if (w->un.flip[i]) basic[i] = !basic[i];
  }
}

/* The rail's velocity and acceleration under every contact (total time derivatives). */
static void rail_rates(const setup_t* S, work_t* w, double* rv, double* ra) {
  int c, nc = S->nc;
  double v = w->ct.v, a = w->ct.a;
  for (c = 0; c < nc; ++c) {
    double N0[NE], N1[NE], N2[NE], r1 = w->ct.rail[nc + c], r2 = w->ct.rail[2 * nc + c];
    if (w->ct.con[c]) {
      double n1u;
      shape_rows(S, w, c, N0, N1, N2);
      n1u = dot_el(w, S, N1, w->br.bu, c);
      rv[c] = dot_el(w, S, N0, w->br.bv, c) + v * n1u + v * r1;
      ra[c] = dot_el(w, S, N0, w->br.ba, c) + 2.0 * v * dot_el(w, S, N1, w->br.bv, c) +
              v * v * dot_el(w, S, N2, w->br.bu, c) + v * v * r2;
      if (a != 0.0) ra[c] += a * (n1u + r1);
    } else {
      rv[c] = w->ct.under[nc + c] + v * r1;
      ra[c] = w->ct.under[2 * nc + c] + v * v * r2;
      if (a != 0.0) ra[c] += a * r1;
    }
  }
}

/* dv = M^-1 W f per car (f: per contact), added to the cars' x (scaled by sign). */
static void cars_add(const setup_t* S, const double* f, double* x) {
  int k, d, i;
  for (k = 0; k < S->cars; ++k)
    for (d = 0; d < NV; ++d) {
      double s = 0.0;
      for (i = 0; i < NW; ++i) s += S->I_MinvW[d * NW + i] * f[k * NW + i];
      x[(long)k * NV + d] += s;
    }
}

int svbi_impact(const setup_t* S, state_t* X, work_t* w, const int* active, const int* landing) {
  int i, k, d, status, nc = S->nc, subs = (int)n_subs(S), nd = S->nd;
  long n;
  double* G = w->un.IG;
  double* rv = w->un.iv1;
  double* ra = w->un.iv2;
  double* imp = w->un.iv3;
  double* J = w->un.iv4;
  double* dV = w->un.IdV;  /* cars x NV: the velocity jump of the cars */
  double* aV0 = w->un.IaV; /* cars x NV: the damping force's answer to it */
  flexibility(S, w, G);

  /* velocity jump: landing wheels lose their relative normal velocity, the others keep theirs;
   * the impulses may take back what the step's own impulse (the trapezoid of its force)
   * overshot, never more: a wheel that would need a tensile total leaves the rail */
  rail_rates(S, w, rv, ra);
  for (i = 0; i < nc; ++i) {
    w->un.ib2[i] = landing[i] ? -(X->vg[i] - rv[i]) : 0.0;
    w->un.iv4[i] = active[i] ? 0.5 * S->dt * (w->un.P0[i] + X->P[i]) : 0.0;
  }
  status = complementary_solve(S, w, G, w->un.ib2, w->un.iv4, active, imp, w->un.onrail);
  if (status) return status;
  memset(dV, 0, sizeof(double) * (size_t)S->cars * NV);
  cars_add(S, imp, dV);
  for (n = 0; n < (long)S->cars * NV; ++n) X->vV[n] += dV[n];
  for (i = 0; i < nc; ++i) X->vg[i] += wheel(S, dV + (long)(i / NW) * NV, i % NW);
  contact_load(S, w, imp, w->un.dB1);
  mass_field(S, w, w->un.dB1, w->un.dB2); /* dvB = -dB2 */
  for (n = 0; n < w->br.nb; ++n) {
    w->un.dB2[n] = -w->un.dB2[n];
    w->br.bv[n] += w->un.dB2[n];
  }

  /* accelerations consistent with the post-impact state (landing wheels: g'' = 0) */
  rail_rates(S, w, rv, ra);
  for (k = 0; k < S->cars; ++k) /* da_V0 = -M^-1 C dv_V */
    for (d = 0; d < NV; ++d) {
      double s = 0.0;
      int e;
      for (e = 0; e < NV; ++e) s += S->I_MinvC[d * NV + e] * dV[(long)k * NV + e];
      aV0[(long)k * NV + d] = -s;
    }
  /* da_B0 = -S_M C dv_B (the bridge's damping force follows its velocity jump) */
  memset(w->un.dB1, 0, sizeof(double) * (size_t)w->br.nb);
  for (k = 0; k < subs; ++k) {
    int j, q;
    for (j = 0; j < nd; ++j) {
      double s = 0.0;
      if (S->general) {
        const int* ptr = S->g_mck_ptr + (long)S->g_kind[k] * (nd + 1);
        for (q = ptr[j]; q < ptr[j + 1]; ++q) s += S->g_c[q] * BR(w->un.dB2, k, S->g_mck_idx[q]);
      } else {
        for (q = S->C_ptr[j]; q < S->C_ptr[j + 1]; ++q) s += S->C_val[q] * BR(w->un.dB2, k, S->C_idx[q]);
      }
      BR(w->un.dB1, k, j) = s;
    }
  }
  mass_field(S, w, w->un.dB1, w->un.dB3);
  for (n = 0; n < w->br.nb; ++n) w->un.dB3[n] = -w->un.dB3[n]; /* da_B0 */
  for (i = 0; i < nc; ++i) {
    double dg0 = wheel(S, aV0 + (long)(i / NW) * NV, i % NW);
    if (w->ct.con[i]) dg0 -= dot_el(w, S, w->ct.crow + (long)i * ROW_COLS + COL_N0, w->un.dB3, i);
    w->un.ib2[i] = (landing[i] ? -(X->ag[i] - ra[i]) : 0.0) - dg0; /* want */
  }
  /* the force jump J: forces P + J >= 0 on the wheels the impulses kept on the rail, the others
   * let go (J = -P); a wheel whose consistent force would be tensile leaves at once */
  status = complementary_solve(S, w, G, w->un.ib2, X->P, w->un.onrail, J, w->un.iunk);
  if (status) return status;
  for (i = 0; i < nc; ++i) w->un.idrop[i] = active[i] && !w->un.iunk[i];
  cars_add(S, J, aV0); /* da_V = da_V0 + M^-1 W J */
  for (n = 0; n < (long)S->cars * NV; ++n) X->aV[n] += aV0[n];
  for (i = 0; i < nc; ++i) X->ag[i] += wheel(S, aV0 + (long)(i / NW) * NV, i % NW);
  contact_load(S, w, J, w->un.dB1);
  mass_field(S, w, w->un.dB1, w->un.dB2);
  for (n = 0; n < w->br.nb; ++n) w->br.ba[n] += w->un.dB3[n] - w->un.dB2[n];
  for (i = 0; i < nc; ++i) {
    X->P[i] = w->un.iunk[i] ? X->P[i] + J[i] : 0.0;
    X->PV[i] = X->P[i] - S->m_g[i % NW] * (X->ag[i] + S->gravity);
  }
  return ST_OK;
}
#else
typedef int svbi_no_impact; /* ISO C wants a declaration in every translation unit */
#endif
