/*
 * A bridge of substructures in the localized method (svbi.runtime.methods.substructures, docs/method.md
 * section 13): spans and pier columns of several kinds, each with its supports held at their targets
 * (u = S f + R q^ per kind), joined by links (girder continuity, bearings on pier tops) whose forces
 * Lambda load both ends. The paper's bridge (identical simply supported spans) is the other kind,
 * spans.c; this file serves every other bridge, through its table svbi_kind_substructures.
 *
 * The link forces are not eliminated with a dense matrix: the interface system of the step carries
 * them as unknowns beside the contact forces, in one band ordered along the bridge (contacts front
 * to back, each link at its support line), so that the cost stays linear in spans, piers and cars:
 *
 *     [ F* + F_B,same   -C_W ] [ P       ]   [ rhs ]
 *     [ -C_N^T           A   ] [ Lambda' ] = [ 0   ]
 *
 * with C_X = X S L^T (X: the rows W_hat or N of the contacts), A = L S L^T + diag(1/k). Eliminating
 * Lambda' gives the NumPy backend's (F* + F_B) P = rhs with F_B = W_hat S_eff N^T; Lambda' are the
 * link forces of the contacts' loads (u = u~ - S (N^T P - L^T Lambda')).
 *
 * The bridge state is substructure after substructure (work_t br.blocked = 0).
 */
#include "internal.h"

static inline const double* kind_S(const setup_t* S, int sub) {
  return S->g_S + (long)S->g_kind[sub] * S->nd * S->nd;
}

/* Span (by the support lines), element, local coordinate and contact rows of every contact
 * (svbi.runtime.model.bridge.Bridge.locate): each span has its own element length and row table. */
static void general_locate(const setup_t* S, work_t* w) {
  int i, spans = S->spans;
  long table = (long)(ROW_DEG + 1) * ROW_COLS;
  const double* line = S->g_line_x;
  for (i = 0; i < S->nc; ++i) {
    double x = w->ct.cx[i];
    int lo = 0, hi = spans + 1, span;
    while (lo < hi) { /* numpy.searchsorted(line, x, side="right") */
      int mid = (lo + hi) / 2;
      if (line[mid] <= x)
        lo = mid + 1;
      else
        hi = mid;
    }
    span = lo - 1;
    if (span < 0) span = 0;
    if (span > spans - 1) span = spans - 1;
    w->ct.con[i] = x >= 0.0 && x < line[spans];
    svbi_place(S, w, i, span, (x - line[span]) * S->g_inv_el[span],
               (S->acceleration == 0.0 ? S->rows : w->ct.rows_now) + S->g_rclass[span] * table);
  }
}

/* The support targets q^ of every slot (the point row of Eq. 22; unused slots get a harmless value:
 * their column of R is zero). */
static void general_targets(const setup_t* S, work_t* w) {
  int k, NSL = 3 * S->nsub, nd = S->nd;
  for (k = 0; k < NSL; ++k) {
    long d = (long)(k / 3) * nd + S->g_slot_dof[k];
    w->sp.qhat[k] = S->p_P * w->br.PB[d] + S->p_Q * w->br.QB[d] + S->p_q2 * w->sp.qs[2 * NSL + k] +
                 S->p_q1 * w->sp.qs[NSL + k] + S->p_q * w->sp.qs[k];
  }
}

/* u[a] -= col_a lambda, u[b] += col_b lambda for every link: u - S L^T lambda. */
static void link_load(const setup_t* S, work_t* w, const double* lambda, double sign) {
  int l, d, nd = S->nd;
  for (l = 0; l < S->nlinks; ++l) {
    double f = sign * lambda[l];
    double* ua = w->br.bu + (long)S->g_lk_a_sub[l] * nd;
    double* ub = w->br.bu + (long)S->g_lk_b_sub[l] * nd;
    const double* ca = S->g_lk_col_a + (long)l * nd;
    const double* cb = S->g_lk_col_b + (long)l * nd;
    if (f == 0.0) continue;
    for (d = 0; d < nd; ++d) ua[d] -= ca[d] * f;
    for (d = 0; d < nd; ++d) ub[d] += cb[d] * f;
  }
}

/* The predictor: every substructure u = S (M P + C Q + C T q' - W_T^B F_creep) + R q^ (supports at
 * their targets), then the links closed on their stabilised rows (Links.targets: the point row of
 * Eq. 22 with no ground for a rigid link, 0 for a spring): Lambda0 = A^-1 (L u - g^). */
static void general_predictor(const setup_t* S, work_t* w, const double* creep) {
  int s, i, j, q, l, k, t, nd = S->nd, NSL = 3 * S->nsub;
  double* f = w->br.fb; /* nd */
  double* q1 = w->ge.qact;
  for (k = 0; k < S->nact; ++k) q1[k] = w->sp.qs[NSL + S->g_act_slot[k]]; /* the active supports' q' */
  for (k = 0; k < S->nkind; ++k) {
    /* the kind's members side by side (GB: free DOF after free DOF, m lanes), one blocked solve */
    int nf = S->g_nfree[k], n0 = w->ge.kmem_ptr[k], count = w->ge.kmem_ptr[k + 1] - n0;
    long m = (count + SW - 1) / SW * SW;
    const int* ptr = S->g_mck_ptr + (long)k * (nd + 1);
    const int* free = S->g_free + (long)k * nd;
    const double* kfs = S->g_kfs + (long)k * nd * 3;
    for (t = 0; t < count; ++t) {
      const double* P;
      const double* Q;
      const double* qh;
      s = w->ge.kmem[n0 + t];
      P = w->br.PB + (long)s * nd;
      Q = w->br.QB + (long)s * nd;
      qh = w->sp.qhat + 3L * s;
      for (i = 0; i < nd; ++i) {
        double v = 0.0;
        long r = (long)s * nd + i;
        for (q = ptr[i]; q < ptr[i + 1]; ++q) v += S->g_m[q] * P[S->g_mck_idx[q]] + S->g_c[q] * Q[S->g_mck_idx[q]];
        for (q = S->g_ct_ptr[r]; q < S->g_ct_ptr[r + 1]; ++q) v += S->g_ct_val[q] * q1[S->g_ct_idx[q]];
        f[i] = v;
      }
#if !SVBI_MOVING_LOAD
      if (creep && s < S->spans) { /* the creep forces of t_n load the rail (svbi.runtime.model.wheel_creep) */
        int a;
        for (a = w->ct.sstart[s]; a < w->ct.sstart[s + 1]; ++a) {
          int c = w->ct.slist[a];
          const double* T0 = w->ct.crow + (long)c * ROW_COLS + COL_T0;
          if (creep[c] == 0.0) continue;
          for (q = 0; q < NNZ_T0; ++q) f[w->ct.cfirst[c] + nz_T0[q]] -= T0[nz_T0[q]] * creep[c];
        }
      }
#else
      (void)creep;
#endif
      /* u = S f + R q^: K^_ff u_f = f_f - K^_fs q^, the supports at q^ */
      for (i = 0; i < nf; ++i)
        w->ge.GB[i * m + t] = f[free[i]] - kfs[3 * i] * qh[0] - kfs[3 * i + 1] * qh[1] - kfs[3 * i + 2] * qh[2];
    }
    for (i = 0; i < nf; ++i)
      for (t = count; t < m; ++t) w->ge.GB[i * m + t] = 0.0;
    svbi_band_solve_blocked(w->ge.KF + S->g_kff_ptr[k], w->ge.KD + (long)k * nd, nf, S->g_pf[k], w->ge.GB, m / SW);
    for (t = 0; t < count; ++t) {
      double* u;
      const int* slot;
      s = w->ge.kmem[n0 + t];
      u = w->br.bu + (long)s * nd;
      slot = S->g_slot_dof + 3L * s;
      for (i = 0; i < nf; ++i) u[free[i]] = w->ge.GB[i * m + t];
      for (j = 0; j < 3; ++j)
        if (S->g_slot_active[3 * s + j]) u[slot[j]] = w->sp.qhat[3L * s + j];
    }
  }
  if (!S->nlinks) return;
  for (l = 0; l < S->nlinks; ++l) {
    long a = (long)S->g_lk_a_sub[l] * nd + S->g_lk_a_dof[l], b = (long)S->g_lk_b_sub[l] * nd + S->g_lk_b_dof[l];
    double target =
        S->g_lk_spring[l] ? 0.0 : S->p_P * (w->br.PB[a] - w->br.PB[b]) + S->p_Q * (w->br.QB[a] - w->br.QB[b]);
    w->ge.lam0[l] = w->br.bu[a] - w->br.bu[b] - target;
  }
  svbi_band_solve(w->ge.LA, S->nlinks, S->band_links, w->ge.lam0);
  link_load(S, w, w->ge.lam0, 1.0);
}

/* X S_sub col over the row X's non-zeros (element DOFs from first), col a column of S. */
static inline double row_dot(const double* X, const int* nzX, int nX, const double* col, int first) {
  int a;
  double f = 0.0;
  for (a = 0; a < nX; ++a) f += X[nzX[a]] * col[first + nzX[a]];
  return f;
}

/* X Z L_l^T for row X of a contact on substructure s at element DOFs from first, Z a compliance
 * given by its columns at the links' ends (col_a, col_b: nlinks x nd): + end a, - end b. */
double svbi_general_row_link(const setup_t* S, const double* X, const int* nzX, int nX, int s, int first, int l,
                             const double* col_a, const double* col_b) {
  double f = 0.0;
  int nd = S->nd;
  if (S->g_lk_a_sub[l] == s) f += row_dot(X, nzX, nX, col_a + (long)l * nd, first);
  if (S->g_lk_b_sub[l] == s) f -= row_dot(X, nzX, nX, col_b + (long)l * nd, first);
  return f;
}

/* X S L_l^T: the effective stiffness's compliance S. */
static double row_link(const setup_t* S, const double* X, const int* nzX, int nX, int s, int first, int l) {
  return svbi_general_row_link(S, X, nzX, nX, s, first, l, S->g_lk_col_a, S->g_lk_col_b);
}

#if !SVBI_MOVING_LOAD
/* Interface positions (contacts in track order, links at their lines, one order along the bridge)
 * and the half bandwidth they give this step. */
static int order_and_bandwidth(const setup_t* S, work_t* w) {
  int i = 0, l = 0, k, s, m, bw = 0, nc = S->nc, nl = S->nlinks;
  for (k = 0; k < nc + nl; ++k) {
    if (l >= nl || (i < nc && w->ct.cx[S->order[i]] >= S->g_lk_x[l]))
      w->it.cpos[S->order[i++]] = k;
    else
      w->ge.lpos[l++] = k;
  }
#if !SVBI_MOVING_LOAD
  for (k = 0; k < S->cars; ++k) {
    int lo = w->it.cpos[k * NW], hi = lo;
    for (i = 1; i < NW; ++i) {
      int p = w->it.cpos[k * NW + i];
      lo = p < lo ? p : lo;
      hi = p > hi ? p : hi;
    }
    if (hi - lo > bw) bw = hi - lo;
  }
#endif
  for (s = 0; s < S->nsub; ++s) {
    int lo = 1 << 30, hi = -1;
    if (s < S->spans) {
      for (m = w->ct.sstart[s]; m < w->ct.sstart[s + 1]; ++m) {
        int p = w->it.cpos[w->ct.slist[m]];
        lo = p < lo ? p : lo;
        hi = p > hi ? p : hi;
      }
    }
    for (m = S->g_sl_ptr[s]; m < S->g_sl_ptr[s + 1]; ++m) {
      int p = w->ge.lpos[S->g_sl_link[m]];
      lo = p < lo ? p : lo;
      hi = p > hi ? p : hi;
    }
    if (hi - lo > bw) bw = hi - lo;
  }
  if (S->nlinks) {
    for (l = 0; l < nl; ++l) {
      int r;
      for (r = 1; r <= S->band_links && l + r < nl; ++r) {
        if (S->g_lk_A[(long)l * (S->band_links + 1) + r] != 0.0) {
          int d = w->ge.lpos[l + r] - w->ge.lpos[l];
          if (d > bw) bw = d;
        }
      }
    }
  }
  return bw;
}

/* The interface system of the step (file comment), banded along the bridge; an inactive (airborne)
 * wheel's row is P_i = 0. P: the contact forces; w->ge.lam: the link forces Lambda'. The order and the
 * half bandwidth are this function's (the links move with the contacts): bandwidth is not used. */
static int general_interface(const setup_t* S, work_t* w, int bandwidth, const int* active, const int* landing,
                             double* P) {
  int i, s, m1, m2, l, status, nc = S->nc, nl = S->nlinks, nd = S->nd, n = nc + nl;
  int bw = order_and_bandwidth(S, w);
  (void)bandwidth; /* ordered and bounded here, pass by pass */
  if (bw > S->bw_max) return ST_BANDWIDTH;
  if (bw > n - 1) bw = n - 1;
  if (bw < 1) bw = n > 1 ? 1 : 0;
  svbi_gb_zero(w->it.band, n, bw);
#if !SVBI_MOVING_LOAD
  {
    int k, j;
    for (k = 0; k < S->cars; ++k)
      for (i = 0; i < NW; ++i)
        for (j = 0; j < NW; ++j)
          svbi_gb_add(w->it.band, bw, w->it.cpos[k * NW + i], w->it.cpos[k * NW + j], S->V_Fstar[i * NW + j]);
  }
#endif
  for (s = 0; s < S->spans; ++s) {
    const double* Sk = kind_S(S, s);
    for (m1 = w->ct.sstart[s]; m1 < w->ct.sstart[s + 1]; ++m1) {
      int ci = w->ct.slist[m1], fi = w->ct.cfirst[ci], land = landing && landing[ci];
      /* a landing wheel's row: N0 in place of W_hat (the position-level g_{n+1} = 0) */
      const double* Wh = w->ct.crow + (long)ci * ROW_COLS + (land ? COL_N0 : COL_W_HAT);
      const int* nzW = land ? nz_N0 : nz_W_hat;
      const int nW = land ? NNZ_N0 : NNZ_W_HAT;
      const double* Ni = w->ct.crow + (long)ci * ROW_COLS + COL_N0;
      const double* Srows = Sk + (long)fi * nd;
      for (m2 = w->ct.sstart[s]; m2 < w->ct.sstart[s + 1]; ++m2) {
        int cj = w->ct.slist[m2];
        const double* N0 = w->ct.crow + (long)cj * ROW_COLS + COL_N0;
        svbi_gb_add(w->it.band, bw, w->it.cpos[ci], w->it.cpos[cj],
                    svbi_row_S_N0(Wh, nzW, nW, Srows, nd, w->ct.cfirst[cj], N0));
      }
      for (m2 = S->g_sl_ptr[s]; m2 < S->g_sl_ptr[s + 1]; ++m2) {
        l = S->g_sl_link[m2];
        svbi_gb_add(w->it.band, bw, w->it.cpos[ci], w->ge.lpos[l], -row_link(S, Wh, nzW, nW, s, fi, l));
        svbi_gb_add(w->it.band, bw, w->ge.lpos[l], w->it.cpos[ci], -row_link(S, Ni, nz_N0, NNZ_N0, s, fi, l));
      }
    }
  }
  for (l = 0; l < nl; ++l) { /* A, from its lower band */
    int r, p = S->band_links;
    const double* col = S->g_lk_A + (long)l * (p + 1);
    svbi_gb_add(w->it.band, bw, w->ge.lpos[l], w->ge.lpos[l], col[0]);
    for (r = 1; r <= p && l + r < nl; ++r) {
      if (col[r] == 0.0) continue;
      svbi_gb_add(w->it.band, bw, w->ge.lpos[l + r], w->ge.lpos[l], col[r]);
      svbi_gb_add(w->it.band, bw, w->ge.lpos[l], w->ge.lpos[l + r], col[r]);
    }
  }
  for (l = 0; l < nl; ++l) w->it.bsol[w->ge.lpos[l]] = 0.0;
  status = svbi_interface_finish(S, w, n, bw, active, landing);
  if (status) return status;
  for (i = 0; i < nc; ++i) P[i] = w->it.bsol[w->it.cpos[i]];
  for (l = 0; l < nl; ++l) w->ge.lam[l] = w->it.bsol[w->ge.lpos[l]];
  return ST_OK;
}

/* (F_NN P)_c: the rail's deflection under contact c from this step's contact forces, through its
 * substructure and the links (the NumPy backend's Bridge compliance pair(N, N) P); with
 * `stabilised`, (F_B P)_c: the same through contact c's stabilised row W_hat in place of N0. */
static double general_deflection(const setup_t* S, const work_t* w, const double* P, int c, int stabilised) {
  int m, s = w->ct.cspan[c], fc = w->ct.cfirst[c], nd = S->nd;
  const double* X = w->ct.crow + (long)c * ROW_COLS + (stabilised ? COL_W_HAT : COL_N0);
  const int* nzX = stabilised ? nz_W_hat : nz_N0;
  const int nX = stabilised ? NNZ_W_HAT : NNZ_N0;
  const double* Srows = kind_S(S, s) + (long)fc * nd;
  double f = 0.0;
  for (m = w->ct.sstart[s]; m < w->ct.sstart[s + 1]; ++m) {
    int cj = w->ct.slist[m];
    const double* Nj = w->ct.crow + (long)cj * ROW_COLS + COL_N0;
    f += svbi_row_S_N0(X, nzX, nX, Srows, nd, w->ct.cfirst[cj], Nj) * P[cj];
  }
  for (m = S->g_sl_ptr[s]; m < S->g_sl_ptr[s + 1]; ++m) {
    int l = S->g_sl_link[m];
    f -= row_link(S, X, nzX, nX, s, fc, l) * w->ge.lam[l];
  }
  return f;
}

#endif

/* u -= S (N^T P - L^T Lambda'): the contact forces and the link forces they call up. */
static void general_correct(const setup_t* S, work_t* w, const double* P) {
  int c, q, d, nd = S->nd;
  for (c = 0; c < S->nc; ++c) {
    if (w->ct.con[c] && P[c] != 0.0) {
      const double* N0 = w->ct.crow + (long)c * ROW_COLS + COL_N0;
      const double* Sk = kind_S(S, w->ct.cspan[c]);
      double* u = w->br.bu + (long)w->ct.cspan[c] * nd;
      for (q = 0; q < NNZ_N0; ++q) {
        /* S is symmetric: its row at the loaded DOF is the column */
        const double* col = Sk + (long)(w->ct.cfirst[c] + nz_N0[q]) * nd;
        double f = N0[nz_N0[q]] * P[c];
        for (d = 0; d < nd; ++d) u[d] -= col[d] * f;
      }
    }
  }
  if (S->nlinks) link_load(S, w, w->ge.lam, -1.0);
}

/* Lambda' = A^-1 C_N^T P for prescribed forces P (moving loads; the interface system's link rows). */
static void general_link_forces(const setup_t* S, work_t* w, const double* P) {
  int c, m, l;
  if (!S->nlinks) return;
  for (l = 0; l < S->nlinks; ++l) w->ge.lam[l] = 0.0;
  for (c = 0; c < S->nc; ++c) {
    int s = w->ct.cspan[c];
    const double* Nc = w->ct.crow + (long)c * ROW_COLS + COL_N0;
    if (!w->ct.con[c]) continue;
    for (m = S->g_sl_ptr[s]; m < S->g_sl_ptr[s + 1]; ++m) {
      l = S->g_sl_link[m];
      w->ge.lam[l] += row_link(S, Nc, nz_N0, NNZ_N0, s, w->ct.cfirst[c], l) * P[c];
    }
  }
  svbi_band_solve(w->ge.LA, S->nlinks, S->band_links, w->ge.lam);
}

/* The prescribed forces' correction (moving loads): the link forces they call up, then u -= S (N^T P
 * - L^T Lambda'). */
static void general_prescribed(const setup_t* S, work_t* w, const double* P) {
  general_link_forces(S, w, P);
  general_correct(S, w, P);
}

#if !SVBI_MOVING_LOAD
/* The interface is ordered and bounded by general_interface itself. */
static int general_order(const setup_t* S, work_t* w, int* bandwidth) {
  (void)S;
  (void)w;
  *bandwidth = 0;
  return ST_OK;
}

/* The rail's height under contact c (on the bridge) less (F_NN P)_c. */
static double general_rail_under(const setup_t* S, const work_t* w, const double* P, int c) {
  return svbi_rail_height(S, w, c) - general_deflection(S, w, P, c, 0);
}

/* r + (F_B P)_c for contact c on the bridge. */
static double general_add_FB(const setup_t* S, const work_t* w, const double* P, int c, double r) {
  return r + general_deflection(S, w, P, c, 1);
}
#endif

const svbi_bridge_kind svbi_kind_substructures = {
    general_locate,
    general_targets,
    general_predictor,
    general_prescribed,
#if SVBI_MOVING_LOAD
    0, 0, 0, 0, 0,
#else
    general_order,
    general_interface,
    general_correct,
    general_rail_under,
    general_add_FB,
#endif
};

/* Factor every kind's K^ on its free DOFs and the link matrix, once (svbi_solver_init). */
int svbi_general_init(const setup_t* S, work_t* w) {
  int k, status;
  memcpy(w->ge.KF, S->g_kff, sizeof(double) * (size_t)S->g_kff_ptr[S->nkind]);
  for (k = 0; k < S->nkind; ++k) {
    int i, p = S->g_pf[k];
    const double* L = w->ge.KF + S->g_kff_ptr[k];
    status = svbi_band_cholesky(w->ge.KF + S->g_kff_ptr[k], S->g_nfree[k], p);
    if (status) return status;
    for (i = 0; i < S->g_nfree[k]; ++i) w->ge.KD[(long)k * S->nd + i] = 1.0 / L[(long)i * (p + 1)];
  }
  { /* the members of every kind */
    int s, n = 0;
    for (k = 0; k < S->nkind; ++k) {
      w->ge.kmem_ptr[k] = n;
      for (s = 0; s < S->nsub; ++s)
        if (S->g_kind[s] == k) w->ge.kmem[n++] = s;
    }
    w->ge.kmem_ptr[S->nkind] = n;
  }
  if (!S->nlinks) return ST_OK;
  memcpy(w->ge.LA, S->g_lk_A, sizeof(double) * (size_t)S->nlinks * (size_t)(S->band_links + 1));
  return svbi_band_cholesky(w->ge.LA, S->nlinks, S->band_links);
}

/* Support reactions of a bridge of substructures (svbi.runtime.methods.reactions.support_reactions): the
 * residual M a + C v - C T q' + K u + N P at every DOF merged with each active support, summed. */
void svbi_general_reactions(const setup_t* S, const state_t* X, const work_t* w, double* out) {
  int k, m, q, c, nd = S->nd, NSL = 3 * S->nsub;
  for (k = 0; k < S->nact; ++k) {
    double r = 0.0;
    for (m = S->g_rx_ptr[k]; m < S->g_rx_ptr[k + 1]; ++m) {
      int s = S->g_rx_sub[m], dof = S->g_rx_dof[m], kind = S->g_kind[s];
      long row = (long)s * nd + dof;
      const int* ptr = S->g_mck_ptr + (long)kind * (nd + 1);
      const double* a = w->br.ba + (long)s * nd;
      const double* v = w->br.bv + (long)s * nd;
      const double* u = w->br.bu + (long)s * nd;
      double f = 0.0;
      for (q = ptr[dof]; q < ptr[dof + 1]; ++q) {
        int j = S->g_mck_idx[q];
        f += S->g_m[q] * a[j] + S->g_c[q] * v[j] + S->g_k[q] * u[j];
      }
      for (q = S->g_ct_ptr[row]; q < S->g_ct_ptr[row + 1]; ++q)
        f -= S->g_ct_val[q] * w->sp.qs[NSL + S->g_act_slot[S->g_ct_idx[q]]];
      if (s < S->spans) { /* the contacts on this span (piers carry none) */
        for (c = w->ct.sstart[s]; c < w->ct.sstart[s + 1]; ++c) {
          int i = w->ct.slist[c];
          if (dof >= w->ct.cfirst[i] && dof < w->ct.cfirst[i] + NE)
            f += w->ct.crow[(long)i * ROW_COLS + COL_N0 + dof - w->ct.cfirst[i]] * X->P[i];
        }
      }
      r += f;
    }
    out[k] = r;
  }
}
