/*
 * The Newmark (gamma = 1/2, beta = 1/4) time loop of svbi: the entry points of solver.h, the
 * workspace and the loop driver. It reproduces the NumPy reference backend (svbi.runtime.methods.localized,
 * .coupled, .classic) step for step; docs/c-backend.md describes the data layout and the structure
 * it exploits:
 *
 *  - localized-dynamic (localized.c): each car's effective matrix and wheel flexibility, and the
 *    factors of the bridge with its supports held, are constant (on a chain of spans one factor
 *    serves every span). Each step solves one banded interface system for the contact forces, in
 *    track order. The bridge kind (spans.c or substructures.c) reaches the step through its table,
 *    picked here once per call (bridge_view).
 *  - coupled-dynamic and coupled-classic (coupled.c): the monolithic system (paper Eq. 36) is
 *    refactored every step by a block ("arrow") sparse LU: span blocks (banded Cholesky), car blocks
 *    (dense Cholesky) and aux points first, then the multipliers' Schur complement, banded in track
 *    order, by LU with partial pivoting.
 *
 * Every formula comes from svbi's symbolic pipeline: the contact rows are polynomials in the local
 * coordinate xi whose coefficients arrive in setup->rows, the point rows as their coefficients, the
 * creep law from the generated creep_split kernels. Nothing here allocates memory.
 */
#include "internal.h"

#if SVBI_MOVING_LOAD
#define SVBI_CREEP_NC 0
#else
#define SVBI_CREEP_NC CREEP_NC
#endif

/* ============================================================================================== */
/* Workspace: carved out of the caller's two arrays in a fixed order (work_t in internal.h); with */
/* NULL bases it counts.                                                                          */

typedef struct {
  double* d;
  int* i;
  long nd;
  long ni;
} carver_t;

static double* take_d(carver_t* c, long n) {
  double* p = c->d ? c->d + c->nd : 0;
  c->nd += n > 0 ? n : 1;
  return p;
}

static int* take_i(carver_t* c, long n) {
  int* p = c->i ? c->i + c->ni : 0;
  c->ni += n > 0 ? n : 1;
  return p;
}

/* work_t br.sc_h: the DOFs per node of SC, where N0 and W_hat share their non-zeros, NNZ_N0 / 2 at
 * each node of an element in the same place, in whole registers (localized, plain spans); else 0. */
static int sc_dofs_per_node(const setup_t* S) {
#if SVBI_MOVING_LOAD
  (void)S;
  return 0;
#else
  int a, h = NNZ_N0 / 2;
  int same = S->method == 0 && !S->general && S->nd % (NE / 2) == 0 && NNZ_N0 == NNZ_W_HAT && NNZ_N0 % 2 == 0 &&
             NNZ_N0 % VW == 0 && NNZ_N0 <= SC_NNZ_MAX;
  for (a = 0; same && a < NNZ_N0; ++a) same = nz_N0[a] == nz_W_hat[a];
  for (a = 0; same && a < h; ++a) same = nz_N0[a] < NE / 2 && nz_N0[a + h] == nz_N0[a] + NE / 2;
  return same ? h : 0;
#endif
}

static void carve(const setup_t* S, carver_t* c, work_t* w) {
  long nc = S->nc, nd = S->nd, spans = S->spans, NS = (long)S->spans * S->ns, NSL = n_slots(S);
  long subs = n_subs(S);
  long nm = n_multipliers(S);
  long nv = SVBI_NV;
  w->ct.cx = take_d(c, nc);
  w->ct.cxi = take_d(c, nc);
  w->ct.crow = take_d(c, nc * ROW_COLS);
  w->ct.rail = take_d(c, 3 * nc);
  w->ct.under = take_d(c, 3 * nc);
  w->ct.ulon = take_d(c, nc);
  w->ct.con = take_i(c, nc);
  w->ct.cspan = take_i(c, nc);
  w->ct.cfirst = take_i(c, nc);
  w->it.cpos = take_i(c, nc);
  w->un.active = take_i(c, nc);
  w->ct.rows_now = take_d(c, (S->general ? S->nrclass : 1) * (ROW_DEG + 1) * ROW_COLS);
  w->sp.qs = take_d(c, 3 * NSL);
  w->rc.grec = take_d(c, 2 * n_recorded(S));
  w->sp.qhat = take_d(c, NSL);
  w->br.PB = take_d(c, subs * nd);
  w->br.QB = take_d(c, subs * nd);
  w->br.fb = take_d(c, nd);
  w->br.rf = take_d(c, nd);
  w->br.Lff = take_d(c, (long)S->nfree * (S->band_pf + 1));
  w->cp.Kb = take_d(c, nd * (S->band_p + 1));
  w->cp.xB = take_d(c, spans * nd);
  w->br.loaded = take_i(c, spans);
  w->cp.PVh = take_d(c, S->cars * nv);
  w->cp.QVh = take_d(c, S->cars * nv);
  w->ve.vcp = (S->cars + VLANES - 1) / VLANES * VLANES;
  w->ve.VL = take_d(c, S->method == 0 && nv ? (5 * nv + 4L * S->nw) * w->ve.vcp : 0);
  w->cp.xV = take_d(c, S->cars * nv);
  w->cp.Kv = take_d(c, nv * nv);
  w->cp.G = take_d(c, nv * (nv ? S->nw : 0));
  w->cp.WG = take_d(c, nv ? S->nw * S->nw : 0);
  w->it.Pg = take_d(c, nc);
  w->it.Qg = take_d(c, nc);
  w->it.pt = take_d(c, nc);
  w->it.dV = take_d(c, nc);
  w->it.hB = take_d(c, nc);
  w->it.rhs = take_d(c, nc);
  w->cp.mB = take_d(c, nc);
  w->cp.HB = take_d(c, nc);
  w->cp.HV = take_d(c, nc);
  w->cp.xg = take_d(c, nc);
  w->it.band = take_d(c, nm * (3L * S->bw_max + 1));
  w->it.bsol = take_d(c, nm);
  w->cp.rl = take_d(c, nm);
  w->cp.HG = take_d(c, NS);
  w->it.Z = take_d(c, S->method == 0 ? 0 : (NS + nc) * nd);
  w->it.piv = take_i(c, nm);
  w->it.rpiv = take_d(c, S->method == 0 ? nm : 0);
  w->cp.mpos = take_i(c, nm);
  w->ct.slist = take_i(c, nc);
  w->ct.sstart = take_i(c, spans + 1);
  w->cp.DG = take_d(c, S->ns);
  w->cp.ab = take_d(c, (S->ns + nc) * NE);
  w->cp.ac = take_d(c, (S->ns + nc) * NE);
  w->it.aid = take_i(c, S->ns + nc);
  w->it.afirst = take_i(c, S->ns + nc);
  w->it.alen = take_i(c, S->ns + nc);
  {
    long padded = S->method == 0 && !S->general ? (spans + LW - 1) / LW * LW : 0;
    w->br.TU = take_d(c, padded * nd);
    w->br.TV = take_d(c, padded * nd);
    w->br.TA = take_d(c, padded * nd);
    w->br.qb = take_d(c, 2L * S->ns * (padded > 0 ? padded : LW));
    w->br.RF = take_d(c, padded * (long)S->nfree);
    if (padded) {
      /* the Newmark histories of the blocked state */
      w->br.PB = take_d(c, padded * nd);
      w->br.QB = take_d(c, padded * nd);
    }
  }
  w->br.dinv2 = take_d(c, S->nfree);
  w->br.freeidx = take_i(c, nd);
  w->br.sc_h = sc_dofs_per_node(S);
  w->br.ncd = w->br.sc_h * (S->nd / (NE / 2));
  w->br.SC = take_d(c, (long)w->br.ncd * w->br.ncd);
  w->rc.rr_ptr = take_i(c, S->general ? 0 : S->ns + 1);
  w->rc.rr_idx = take_i(c, S->general ? 0 : (long)S->ns * nd);
  w->br.lidx = take_i(c, spans);
  w->br.lspan = take_i(c, spans);
  {
    int blocked = S->method == 0 && !S->general;
    long nz = blocked ? (long)S->nfree * S->band_pf : 0;
    w->br.fw_d = take_d(c, nz);
    w->br.bk_d = take_d(c, nz);
  }
  w->ve.creepc = take_d(c, nv ? S->nw * SVBI_CREEP_NC : 0);
  w->ve.vnz_ptr = take_i(c, 4 * (nv + 1));
  w->ve.vnz_idx = take_i(c, 4 * nv * nv);
  w->ve.vnz_val = take_d(c, 4 * nv * nv);
  {
    /* coupled methods (coupled.c) */
    long on = S->method != 0, cpad = on ? (spans + SW - 1) / SW * SW : 0;
    w->cp.Kinv = take_d(c, on * nd * nd);
    w->cp.Kdinv = take_d(c, on * nd);
    w->cp.Kfw = take_d(c, on * nd * S->band_p);
    w->cp.Kbk = take_d(c, on * nd * S->band_p);
    w->cp.Kd2 = take_d(c, on * nd);
    w->cp.XB = take_d(c, cpad * nd);
    w->cp.Kvinv = take_d(c, on * nv * nv);
  }
  {
    /* a bridge of substructures (substructures.c) */
    long nl = S->general ? S->nlinks : 0;
    w->ge.lpos = take_i(c, nl);
    w->ge.lam = take_d(c, nl);
    w->ge.lam0 = take_d(c, nl);
    w->ge.LA = take_d(c, nl * (S->band_links + 1));
    w->ge.KF = take_d(c, S->general ? S->g_kff_ptr[S->nkind] : 0);
    w->ge.KD = take_d(c, S->general ? S->nkind * nd : 0);
    w->ge.GB = take_d(c, S->general ? nd * (S->nsub + SW) : 0);
    w->ge.kmem_ptr = take_i(c, S->general ? S->nkind + 1 : 0);
    w->ge.kmem = take_i(c, S->general ? S->nsub : 0);
    w->ge.qact = take_d(c, S->general ? S->nact : 0);
  }
  {
    /* unilateral contact, localized (impact.c) */
    long u = S->unilateral, lanes = (spans + LW - 1) / LW * LW; /* the blocked layout's spans */
    long field = u ? (lanes > subs ? lanes : subs) * nd : 0;
    w->un.landing = take_i(c, nc);
    w->un.flip = take_i(c, nc);
    w->un.onrail = take_i(c, nc);
    w->un.P0 = take_d(c, nc);
    w->un.rland = take_d(c, nc);
    w->un.IG = take_d(c, u * nc * nc);
    w->un.IGs = take_d(c, u * nc * nc);
    w->un.iidx = take_i(c, nc);
    w->un.idrop = take_i(c, nc);
    w->un.iunk = take_i(c, nc);
    w->un.ib = take_d(c, nc);
    w->un.ib2 = take_d(c, nc);
    w->un.ib3 = take_d(c, nc);
    w->un.iv1 = take_d(c, nc);
    w->un.iv2 = take_d(c, nc);
    w->un.iv3 = take_d(c, nc);
    w->un.iv4 = take_d(c, nc);
    w->un.IdV = take_d(c, u * S->cars * nv);
    w->un.IaV = take_d(c, u * S->cars * nv);
    w->un.dB1 = take_d(c, field);
    w->un.dB2 = take_d(c, field);
    w->un.dB3 = take_d(c, field);
    w->un.LAM = take_d(c, u && S->general ? (long)S->nlinks * (S->band_links + 1) : 0);
  }
}

int svbi_solver_workspace(const setup_t* S, long* n_double, long* n_int) {
  carver_t c = {0, 0, 0, 0};
  work_t w;
  carve(S, &c, &w);
  *n_double = c.nd;
  *n_int = c.ni;
  return ST_OK;
}

static work_t workspace(const setup_t* S, double* work, int* iwork) {
  carver_t c = {work, iwork, 0, 0};
  work_t w;
  carve(S, &c, &w);
  return w;
}

int svbi_solver_init(const setup_t* S, double* work, int* iwork) {
  work_t w = workspace(S, work, iwork);
  int k, status;
  for (k = 0; k < S->nd; ++k) w.br.freeidx[k] = -1;
  for (k = 0; k < S->nfree; ++k) w.br.freeidx[S->free[k]] = k;
  if (w.br.sc_h) { /* work_t br.SC */
    int a, b, h = w.br.sc_h, nd = S->nd;
    for (a = 0; a < w.br.ncd; ++a)
      for (b = 0; b < w.br.ncd; ++b)
        w.br.SC[(long)a * w.br.ncd + b] = S->S[(long)((b / h) * (NE / 2) + nz_N0[b % h]) * nd + (a / h) * (NE / 2) + nz_N0[a % h]];
  }
  if (!S->general) { /* the support rows' non-zeros (record.c, support_reactions) */
    int j, d, n = 0, nd = S->nd, ns = S->ns;
    for (j = 0; j < ns; ++j) {
      w.rc.rr_ptr[j] = n;
      for (d = 0; d < nd; ++d) {
        long o = (long)j * nd + d, a = (long)ns * nd;
        if (S->react_rows[o] != 0.0 || S->react_rows[a + o] != 0.0 || S->react_rows[2 * a + o] != 0.0) w.rc.rr_idx[n++] = d;
      }
    }
    w.rc.rr_ptr[ns] = n;
  }
#if !SVBI_MOVING_LOAD
  if (!S->moving_load) {
    /* the non-zeros of the car's constant matrices, column by column (vehicle.c, lanes_vec_mat) */
    const double* mats[4];
    int a, j, d;
    mats[0] = S->V_K;
    mats[1] = S->V_M;
    mats[2] = S->V_C;
    mats[3] = S->method == 0 ? S->V_kinv : 0;
    for (a = 0; a < 4; ++a) {
      int* ptr = w.ve.vnz_ptr + a * (NV + 1);
      int* idx = w.ve.vnz_idx + a * NV * NV;
      double* val = w.ve.vnz_val + a * NV * NV;
      int n = 0;
      for (d = 0; d < NV; ++d) {
        ptr[d] = n;
        for (j = 0; mats[a] && j < NV; ++j) {
          if (mats[a][j * NV + d] != 0.0) {
            idx[n] = j;
            val[n++] = mats[a][j * NV + d];
          }
        }
      }
      ptr[NV] = n;
    }
  }
  if (S->creep) {
    /* the parameter-only part of every wheel's creep law, once */
    for (k = 0; k < S->nw; ++k) {
      const casadi_real* arg[SVBI_CREEP_SPLIT_MAX_SZ_ARG] = {0};
      casadi_real* res[SVBI_CREEP_SPLIT_MAX_SZ_RES] = {0};
      casadi_int iw[SVBI_CREEP_SPLIT_MAX_SZ_IW] = {0};
      casadi_real wk[SVBI_CREEP_SPLIT_MAX_SZ_W];
      arg[0] = S->creep_params + 8 * k;
      res[0] = w.ve.creepc + CREEP_NC * k;
      status = CREEP_KERNEL(COEFFICIENTS)(arg, res, iw, wk, 0);
      if (status) return ST_NOT_FINITE;
    }
  }
#endif
  if (S->method != 0) {
    /* coupled: every span block is the same constant K^_B; factor it once */
    memcpy(w.cp.Kb, S->Khat_band, sizeof(double) * (size_t)S->nd * (size_t)(S->band_p + 1));
    status = svbi_band_cholesky(w.cp.Kb, S->nd, S->band_p);
    if (status) return status;
  }
#if !SVBI_MOVING_LOAD
  if (S->method != 0 && !S->moving_load) {
    /* coupled: every car's effective matrix is the same constant; factor it and K^-1 W once */
    int i, a, b, d;
    memcpy(w.cp.Kv, S->V_khat, sizeof(double) * NV * NV);
    status = svbi_dense_cholesky(w.cp.Kv, NV);
    if (status) return status;
    for (i = 0; i < NW; ++i) {
      double g[NV];
      for (d = 0; d < NV; ++d) g[d] = S->V_W[d * NW + i];
      svbi_dense_solve(w.cp.Kv, NV, g);
      for (d = 0; d < NV; ++d) w.cp.G[d * NW + i] = g[d];
    }
    for (a = 0; a < NW; ++a) {
      for (b = 0; b < NW; ++b) {
        double wg = 0.0;
        for (d = 0; d < NV; ++d) wg += S->V_W[d * NW + a] * w.cp.G[d * NW + b];
        w.cp.WG[a * NW + b] = wg;
      }
    }
  }
#endif
  if (S->method != 0) {
    status = svbi_coupled_init(S, &w);
    if (status) return status;
  }
  if (S->unilateral && S->general && S->nlinks) { /* the rigid links' mass matrix (impact.c) */
    memcpy(w.un.LAM, S->I_lk_A, sizeof(double) * (size_t)S->nlinks * (size_t)(S->band_links + 1));
    status = svbi_band_cholesky(w.un.LAM, S->nlinks, S->band_links);
    if (status) return status;
  }
  if (S->general) {
    status = svbi_general_init(S, &w);
    if (status) return status;
  } else if (S->method == 0) {
    memcpy(w.br.Lff, S->Khat_ff_band, sizeof(double) * (size_t)S->nfree * (size_t)(S->band_pf + 1));
    status = svbi_band_cholesky(w.br.Lff, S->nfree, S->band_pf);
    if (status) return status;
    if (S->band_pf > FS_PMAX) return ST_BANDWIDTH;
    svbi_band_unit_factor(w.br.Lff, S->nfree, S->band_pf, w.br.fw_d, w.br.bk_d, w.br.dinv2);
  }
  return ST_OK;
}

/* The bridge state the steps work on (blocked copies for localized-dynamic on a chain of spans)
 * and the bridge kind's table. */
static void bridge_view(const setup_t* S, state_t* X, work_t* w) {
  w->kind = S->general ? &svbi_kind_substructures : &svbi_kind_spans;
  if (S->method == 0 && !S->general) {
    long s, i, nd = S->nd;
    w->br.pad = (S->spans + LW - 1) / LW * LW;
    w->br.nb = w->br.pad * nd;
    memset(w->br.TU, 0, sizeof(double) * (size_t)w->br.nb);
    memset(w->br.TV, 0, sizeof(double) * (size_t)w->br.nb);
    memset(w->br.TA, 0, sizeof(double) * (size_t)w->br.nb);
    for (s = 0; s < S->spans; ++s) {
      for (i = 0; i < nd; ++i) {
        long k = i * w->br.pad + s;
        w->br.TU[k] = X->uB[s * nd + i];
        w->br.TV[k] = X->vB[s * nd + i];
        w->br.TA[k] = X->aB[s * nd + i];
      }
    }
    w->br.bu = w->br.TU;
    w->br.bv = w->br.TV;
    w->br.ba = w->br.TA;
    w->br.blocked = 1;
    w->br.hist = 0;
  } else {
    w->br.bu = X->uB;
    w->br.bv = X->vB;
    w->br.ba = X->aB;
    w->br.blocked = 0;
    w->br.hist = 0;
    w->br.nb = n_subs(S) * S->nd;
  }
}

static void bridge_store(const setup_t* S, state_t* X, const work_t* w) {
  if (S->method == 0 && !S->general) {
    long s, i, nd = S->nd;
    for (s = 0; s < S->spans; ++s) {
      for (i = 0; i < nd; ++i) {
        long k = i * w->br.pad + s;
        X->uB[s * nd + i] = w->br.TU[k];
        X->vB[s * nd + i] = w->br.TV[k];
        X->aB[s * nd + i] = w->br.TA[k];
      }
    }
  }
}

int svbi_solver_run(const setup_t* S, state_t* X, const excitation_t* E, outputs_t* O, double* work,
                    int* iwork, long n0, long count, info_t* I) {
  work_t w = workspace(S, work, iwork);
  long n;
  int status = ST_OK, i;
  I->status = ST_OK;
  I->quantity = 0;
  I->value = 0.0;
  /* never write past the outputs: steps within the run, rows within the buffers */
  if (n0 < 0 || count < 0 || n0 + count > S->steps ||
      O->row + (n0 + count) / S->output_every - n0 / S->output_every > O->nout) {
    I->status = ST_RANGE;
    return ST_RANGE;
  }
  bridge_view(S, X, &w);
  for (n = n0; n < n0 + count; ++n) {
    double t = (double)(n + 1) * S->dt;
    svbi_excite(S, E, &w, n, t);
    w.kind->locate(S, &w);
    if (S->method == 0)
      status = svbi_step_localized(S, X, &w);
    else
      status = svbi_step_coupled(S, X, &w, S->method == 2);
    X->t = t;
    I->step = n;
    if (!status) status = svbi_guard(S, X, &w, I);
    if (status) break;
    for (i = 0; i < S->nc; ++i) O->forces[(n + 1) * S->nc + i] = X->P[i];
    if (S->unilateral) memcpy(O->contact_steps + (n + 1) * S->nc, X->in_contact, (size_t)S->nc);
    I->steps_done = n + 1;
    if ((n + 1) % S->output_every == 0) {
      status = svbi_record(S, X, E, O, &w, I);
      if (status) break;
    }
  }
  bridge_store(S, X, &w);
  I->status = status;
  return status;
}
