/*
 * Internal declarations of svbi's C time loop (not part of the public API in solver.h): the
 * workspace layout, the sizes of the topology and the functions the source files share.
 *
 * The topology arrives from two generated headers (svbi generate, committed under generated/):
 * svbi_topology.h (vehicle DOFs per car SVBI_NV, wheels per car SVBI_NW, SVBI_MOVING_LOAD) and
 * svbi_contact_rows.h (the contact-row table: degree in xi, columns, structural non-zeros and the
 * unrolled row evaluation, from the symbolic pipeline). Everything else arrives in the setup struct.
 */
#ifndef SVBI_SOLVER_INTERNAL_H
#define SVBI_SOLVER_INTERNAL_H

#include <math.h>
#include <string.h>

#include "solver.h" /* the library's interface: declared before the pragma below, so it stays visible */

/* Everything else the sources share is internal to the library: hidden, so that its calls are direct
 * (no PLT) and may be inlined within a file. */
#if defined(__GNUC__)
#pragma GCC visibility push(hidden)
#endif

#include "band.h"
#include "newmark.h"
#include "roots.h"
#include "svbi_contact_rows.h"
#include "svbi_topology.h"
#include "tables.h"

#if !SVBI_MOVING_LOAD
#include "creep_split.h" /* the generated creep law, split (svbi.codegen.creep.split_creep_force) */
#define CREEP_NC SVBI_CREEP_SPLIT_COEFFICIENTS_OUT_C_ROWS /* coefficients of the split creep law */
/* The loop reaches the generated creep law through its model table (the acados pattern): another
 * law emitted with the same kernel names and signatures drops in without touching the loop. */
#define CREEP_KERNEL(k) (svbi_creep_split_model_table.kernels[SVBI_CREEP_SPLIT_K_##k].eval)
#define NV SVBI_NV
#define NW SVBI_NW
#endif

#define NE 6 /* DOFs of one bridge element (frame2d) */
#define VLANES 4 /* cars per chunk of the localized vehicles' lane layout (as LW) */
#define SC_NNZ_MAX 8 /* contact-row non-zeros up to which the interface uses work_t br.SC */
#define CAR_KMAX (3 * VLANES / VW) /* registers of three chunks (vehicle.c) */

typedef svbi_solver_setup setup_t;
typedef svbi_solver_state state_t;
typedef svbi_solver_excitation excitation_t;
typedef svbi_solver_outputs outputs_t;
typedef svbi_solver_info info_t;

enum {
  ST_OK = SVBI_SOLVER_STATUS_OK,
  ST_NOT_FINITE = SVBI_SOLVER_STATUS_NOT_FINITE,
  ST_FORCE_LIMIT = SVBI_SOLVER_STATUS_FORCE_LIMIT,
  ST_GAP_LIMIT = SVBI_SOLVER_STATUS_GAP_LIMIT,
  ST_SINGULAR = SVBI_SOLVER_STATUS_SINGULAR,
  ST_BANDWIDTH = SVBI_SOLVER_STATUS_BANDWIDTH,
  ST_NOT_SPD = SVBI_SOLVER_STATUS_NOT_SPD,
  ST_RANGE = SVBI_SOLVER_STATUS_RANGE,
  ST_EVENT = SVBI_SOLVER_STATUS_EVENT
};

/* ============================================================================================== */
/* Workspace: carved out of the caller's two arrays in a fixed order (solver.c, carve).           */

typedef struct svbi_bridge_kind svbi_bridge_kind;

/* Where the contacts are and what lies under them: written by the excitation and the bridge kind's
 * locate, read by every step.
 * used by: excite.c contacts.c bridge.c spans.c substructures.c vehicle.c localized.c coupled.c impact.c
 *          record.c internal.h */
typedef struct {
  double* cx;    /* nc: x */
  double* cxi;   /* nc: local coordinate in the element */
  double* crow;  /* nc x ROW_COLS: contact rows at xi */
  double* rail;  /* 3 x nc: r, r', r'' */
  double* under; /* 3 x nc: ground q, q', q'' under the contact */
  double* ulon;  /* nc: longitudinal ground velocity under the contact (creep off the bridge) */
  int* con;      /* nc: on the bridge */
  int* cspan;    /* nc: span */
  int* cfirst;   /* nc: first span DOF of the element */
  double* rows_now; /* (ROW_DEG + 1) x ROW_COLS: this step's contact rows (a changing speed) */
  double v, a;      /* the train's speed and acceleration at this step */
  int* slist;    /* nc: contacts grouped by span */
  int* sstart;   /* spans + 1 */
} contact_work_t;

/* The support motion of the step: the targets q, q', q'' (the excitation) and q^ (the bridge kind).
 * used by: excite.c bridge.c spans.c substructures.c coupled.c record.c */
typedef struct {
  double* qs;    /* 3 x spans * ns: support targets q, q', q'' */
  double* qhat;  /* spans * ns */
} support_work_t;

/* The bridge state the step works on, its Newmark histories and the chain of spans' factors: the
 * bridge kinds own it; the methods, the recording and the guard read the state.
 * used by: bridge.c spans.c substructures.c contacts.c vehicle.c localized.c impact.c record.c guard.c
 *          internal.h */
typedef struct {
  double* PB;    /* spans x nd */
  double* QB;    /* spans x nd */
  double* fb;    /* nd */
  double* rf;    /* nd */
  double* Lff;   /* nfree x (band_pf + 1): factor of K^ on the free DOFs */
  int* loaded;   /* spans */
  /* the bridge state the step works on. coupled methods: the state itself, span after span.
   * localized-dynamic: DOF after DOF over the spans padded to a multiple of LW ([DOF][pad]), so that
   * one factor solves every span at once with inner loops over LW lanes (vectorised) */
  double* bu;
  double* bv;
  double* ba;
  int blocked;
  int hist;      /* localized: PB, QB already hold this step's histories (set by the last update) */
  long pad;      /* spans padded to a multiple of LW (localized) */
  long nb;       /* entries of bu (with the padding) */
  double* TU;    /* nd x pad (localized) */
  double* TV;
  double* TA;
  double* qb;    /* 2 x ns x pad: q' and q^ of every span */
  double* RF;    /* nfree x pad: free-DOF right-hand sides of the correction (localized) */
  double* dinv2; /* nfree: 1 / L(j, j)^2, L the factor on the free DOFs (factor_solve: K^ = U D^2 U^T) */
  int* freeidx;  /* nd: index among the free DOFs, -1 for a support DOF */
  /* the span compliance S at the contact rows' DOFs (spans.c, sc_pairs): node by node
   * the DOFs where N0 and W_hat may be non-zero (their common pattern, the same at both nodes of an
   * element), transposed, SC[p * ncd + q] = S(dof(q), dof(p)), so that an element's NNZ_N0 DOFs
   * are neighbours. Used when the pattern allows (sc_h: DOFs kept per node, else 0) */
  double* SC;    /* ncd x ncd, ncd = sc_h nd / (NE / 2) */
  int sc_h;
  int ncd;
  int* lidx;     /* spans: index among the loaded spans, -1 if unloaded */
  int* lspan;    /* spans: the loaded spans */
  /* localized: the factor on the free DOFs as the unit triangle U = L D^-1 (D = diag L), dense in
   * its band (zeros where nothing couples, or beyond the matrix): row j's U(j, j - r) at
   * fw_d[j band_pf + r - 1] (forward sweep), column j's U(j + r, j) at bk_d[j band_pf + r - 1]
   * (backward sweep) */
  double* fw_d;  /* nfree x band_pf */
  double* bk_d;  /* nfree x band_pf */
} bridge_work_t;

/* The interface system of a step: contact forces or multipliers, right-hand sides, band and order.
 * used by: spans.c substructures.c interface.c localized.c coupled.c */
typedef struct {
  int* cpos;     /* nc: position in track order */
  double* Pg;    /* nc */
  double* Qg;    /* nc */
  double* pt;    /* nc */
  double* dV;    /* nc */
  double* hB;    /* nc */
  double* rhs;   /* nc */
  double* band;  /* nmult x (3 bw_max + 1) */
  double* bsol;  /* nmult */
  double* Z;     /* attachment vectors of the span blocks */
  int* piv;      /* nmult */
  double* rpiv;  /* nmult: reciprocal pivots of the interface LU (localized) */
  int* aid;      /* ns + nc: attachments' multiplier */
  int* afirst;   /* ns + nc: first span DOF */
  int* alen;     /* ns + nc: number of entries */
} interface_work_t;

/* The localized step's vehicles as lanes, and the creep law.
 * used by: vehicle.c localized.c */
typedef struct {
  /* localized: the cars as lanes (vehicle.c, svbi_vehicle_predictors): u, P~, Q~, f, du as
   * [NV][vcp] and the wheels' W^T u~, W^T P, W^T Q and P_V as [NW][vcp], cars padded to VLANES */
  double* VL;
  long vcp;
  /* vehicles: the non-zeros of V_K, V_M, V_C and V_kinv column by column (y = x^T A, vehicle.c) */
  int* vnz_ptr;  /* 4 x (NV + 1) */
  int* vnz_idx;  /* 4 x NV x NV */
  double* vnz_val; /* 4 x NV x NV */
  double* creepc; /* NW x CREEP_NC: coefficients of the creep law of every wheel */
} vehicle_work_t;

/* The coupled methods: their constant factors (set once by svbi_coupled_init) and scratch; vehicle.c
 * loads the creep forces into xB.
 * used by: coupled.c vehicle.c */
typedef struct {
  double* Kb;    /* nd x (band_p + 1): factor of the span block K^_B (coupled, set once) */
  double* xB;    /* spans x nd: span right-hand sides / solutions (coupled) */
  double* PVh;   /* cars x NV: Newmark history P - a0 u of the vehicle increment */
  double* QVh;   /* cars x NV */
  double* xV;    /* cars x NV (coupled) */
  double* Kv;    /* NV x NV: Cholesky factor of the car's effective matrix (coupled, set once) */
  double* G;     /* NV x NW: K^-1 W, the same for every car (coupled, set once) */
  double* WG;    /* NW x NW: W^T K^-1 W (coupled, set once) */
  double* mB;    /* nc */
  double* HB;    /* nc */
  double* HV;    /* nc */
  double* xg;    /* nc */
  double* rl;    /* nmult: multiplier right-hand sides */
  double* HG;    /* spans * ns */
  int* mpos;     /* nmult: track-order position of each multiplier */
  double* DG;    /* ns: scale of the support rows */
  double* ab;    /* (ns + nc) x NE: attachments' B entries */
  double* ac;    /* (ns + nc) x NE: attachments' C entries */
  double* Kinv;  /* nd x nd: K^_B^-1, dense (row-major, symmetric) */
  double* Kdinv; /* nd: reciprocal diagonal of the span factor Kb */
  double* Kfw;   /* nd x band_p: Kb as a unit triangle (svbi_band_unit_factor; band_p <= FS_PMAX) */
  double* Kbk;   /* nd x band_p */
  double* Kd2;   /* nd */
  double* XB;    /* nd x pad: span right-hand sides, DOF after DOF over the spans padded to SW */
  double* Kvinv; /* NV x NV: inverse of the car's effective matrix */
} coupled_work_t;

/* A bridge of substructures joined by links; the impact reads the link forces.
 * used by: substructures.c impact.c */
typedef struct {
  int* lpos;     /* nlinks: interface position of every link */
  double* lam;   /* nlinks: link forces of the contact forces, Lambda' */
  double* lam0;  /* nlinks: link forces closing the predictor */
  double* LA;    /* nlinks x (band_links + 1): Cholesky factor of A = L S L^T + diag(1/k) */
  double* KF;    /* every kind's banded Cholesky factor of K^ on its free DOFs (layout of g_kff) */
  double* KD;    /* nkind x nd: reciprocal diagonals of those factors */
  double* GB;    /* nd x (nsub + SW): right-hand sides of one kind's members, side by side */
  int* kmem_ptr; /* nkind + 1 */
  int* kmem;     /* nsub: the substructures, kind after kind */
  double* qact;  /* nact: the active supports' q' of the step */
} general_work_t;

/* Unilateral contact: the active set, landings and the plastic impact.
 * used by: localized.c impact.c interface.c */
typedef struct {
  int* active;   /* nc: the active set of a unilateral step's passes */
  int* landing;  /* nc: a landing wheel's row is the position-level g_{n+1} = 0 */
  int* flip;     /* nc: the wheels a pass of a complementarity problem flips */
  int* onrail;   /* nc: the wheels the landing impulses keep on the rail */
  double* P0;    /* nc: the contact forces of t_n (a landing's step impulse) */
  double* rland; /* nc: the landing row's right-hand side */
  double* IG;    /* nc x nc: mass flexibility at the contacts */
  double* IGs;   /* nc x nc: its factor on a subset */
  int* iidx;     /* nc */
  int* idrop;    /* nc: landing wheels let go by the impact */
  int* iunk;     /* nc */
  double *ib, *ib2, *ib3, *iv1, *iv2, *iv3, *iv4; /* nc each */
  double* IdV;   /* cars x NV */
  double* IaV;   /* cars x NV */
  double *dB1, *dB2, *dB3; /* whole-bridge fields (layout of bu) */
  double* LAM;   /* nlinks x (band_links + 1): Cholesky factor of L S_M L^T (springs: 1) */
} unilateral_work_t;

/* The recording: the support rows of the reactions, and the recorded ground (the excitation writes it).
 * used by: record.c excite.c */
typedef struct {
  double* grec;  /* 2 x nrec: ground_uz, ground_ux */
  int* rr_ptr;   /* ns + 1: the support rows' DOFs where M, C or K is non-zero (record.c) */
  int* rr_idx;   /* ns x nd */
} record_work_t;

/* The workspace: one part per concern, each used only by the files its type names (and carved and
 * filled by solver.c; tests/architecture/test_c_layers.py). The parts are plain members: w->br.bu costs what w->bu
 * did (a constant offset). */
typedef struct {
  const svbi_bridge_kind* kind; /* the bridge kind's table (solver.c sets it before the first step) */
  contact_work_t ct;
  support_work_t sp;
  bridge_work_t br;
  interface_work_t it;
  vehicle_work_t ve;
  coupled_work_t cp;
  general_work_t ge;
  unilateral_work_t un;
  record_work_t rc;
} work_t;

/* Element (s, i) of a bridge-state array: span after span, or DOF after DOF over the spans padded
 * to a multiple of LW (localized). */
#define BR(b, s, i) ((b)[w->br.blocked ? (long)(i) * w->br.pad + (s) : (long)(s) * S->nd + (i)])

/* Support slots: ns per span, or three per substructure (general: S->g_slot_*). */
static inline long n_slots(const setup_t* S) { return S->general ? 3L * S->nsub : (long)S->spans * S->ns; }

/* Substructures whose state the loop holds: the spans, and the piers of a general bridge. */
static inline long n_subs(const setup_t* S) { return S->general ? S->nsub : S->spans; }

/* X S N0_j^T for a row X of contact i (non-zeros nzX) and contact j's N0 on the same substructure:
 * Srows is S (row-major, nd x nd) from contact i's first DOF, firstj contact j's first DOF. Each
 * t_a = sum_b S(a, b) N0_b is summed over b in order, but the nX sums run side by side (one N0
 * entry at a time): independent chains instead of one after another (the same result; 2 % of
 * the paper loop, which evaluates this for every pair of contacts on a span). */
static inline double svbi_row_S_N0(const double* X, const int* nzX, int nX, const double* Srows, int nd, int firstj,
                                   const double* N0) {
  int a, b;
  double f = 0.0, t[NE];
  for (a = 0; a < nX; ++a) t[a] = 0.0;
  for (b = 0; b < NNZ_N0; ++b) {
    const double* Sr = Srows + firstj + nz_N0[b];
    double n = N0[nz_N0[b]];
    for (a = 0; a < nX; ++a) t[a] += Sr[(long)nzX[a] * nd] * n;
  }
  for (a = 0; a < nX; ++a) f += X[nzX[a]] * t[a];
  return f;
}

/* Unknowns of the interface system (contact forces, or multipliers; general: and link forces). */
static inline long n_multipliers(const setup_t* S) {
  long NS = (long)S->spans * S->ns;
  if (S->method == 0 && S->general) return (long)S->nc + S->nlinks;
  if (S->method == 0) return S->moving_load ? 1 : S->nc;
  if (S->moving_load) return NS;
  return (S->method == 1 ? 2L * S->nc : (long)S->nc) + NS;
}

/* Recorded ground values per output row (per support). */
static inline long n_recorded(const setup_t* S) { return S->general ? S->nact : (long)S->spans * S->ns; }

/* excite.c: positions, rail irregularity and ground motion at t = (n + 1) dt. */
void svbi_excite(const setup_t* S, const excitation_t* E, work_t* w, long n, double t);

/* contacts.c: a contact's element, local coordinate and rows; the rail's height under it. */
void svbi_place(const setup_t* S, work_t* w, int i, int span, double local, const double* cf);
double svbi_rail_height(const setup_t* S, const work_t* w, int c);

/* The bridge kinds: a chain of identical spans (spans.c, bridge.c) or substructures joined by links
 * (substructures.c). The step reaches its bridge through this table, filled once (the loop picks it at
 * set-up, work_t kind) as acados reaches its integrators: one indirect call per phase of the step
 * costs nothing against the phase (benchmarks/bench_solver.py). The localized step uses every
 * entry; the coupled methods (a chain of spans only) locate through it. */
struct svbi_bridge_kind {
  /* span, element, local coordinate and contact rows of every contact */
  void (*locate)(const setup_t* S, work_t* w);
  /* the support targets q^ from the histories and the support motion of the step */
  void (*targets)(const setup_t* S, work_t* w);
  /* u~ = S f + R q^ with every contact force zero (creep: the forces of t_n on the rail, or NULL) */
  void (*predictor)(const setup_t* S, work_t* w, const double* creep);
  /* u -= S N^T P for prescribed forces P (moving loads) */
  void (*prescribed)(const setup_t* S, work_t* w, const double* P);
  /* vehicles only (NULL for moving loads): */
  /* the interface's order (work_t it.cpos) and half bandwidth of the step */
  int (*order)(const setup_t* S, work_t* w, int* bandwidth);
  /* (F* + F_B) P = rhs, an airborne wheel's row P_i = 0, a landing wheel's g_{n+1} = 0 */
  int (*interface)(const setup_t* S, work_t* w, int bandwidth, const int* active, const int* landing, double* P);
  /* u -= S N^T P for the contact forces of the interface (and the link forces they call up) */
  void (*correct)(const setup_t* S, work_t* w, const double* P);
  /* the rail's height under contact c on the bridge less its deflection under P */
  double (*rail_under)(const setup_t* S, const work_t* w, const double* P, int c);
  /* r + (F_B P)_c, contact c on the bridge */
  double (*add_FB)(const setup_t* S, const work_t* w, const double* P, int c, double r);
};
extern const svbi_bridge_kind svbi_kind_spans;         /* spans.c */
extern const svbi_bridge_kind svbi_kind_substructures; /* substructures.c */

/* bridge.c: contacts on a chain of spans, Newmark histories and update, support targets, span loads. */
void svbi_locate(const setup_t* S, work_t* w);
void svbi_group_by_span(const setup_t* S, work_t* w);
void svbi_bridge_histories(const setup_t* S, work_t* w);
void svbi_support_targets(const setup_t* S, work_t* w);
void svbi_bridge_update_histories(const setup_t* S, work_t* w);
void svbi_span_load(const setup_t* S, const work_t* w, int s, double* f);
void svbi_bridge_update(const setup_t* S, work_t* w);

/* substructures.c: a bridge of substructures joined by links (localized-dynamic; its table above). */
int svbi_general_init(const setup_t* S, work_t* w);
void svbi_general_reactions(const setup_t* S, const state_t* X, const work_t* w, double* out);
double svbi_general_row_link(const setup_t* S, const double* X, const int* nzX, int nX, int s, int first, int l,
                             const double* col_a, const double* col_b);

/* impact.c: the plastic impact of the landing wheels after the localized step. */
int svbi_impact(const setup_t* S, state_t* X, work_t* w, const int* active, const int* landing);

/* interface.c: the localized interface's right-hand sides, airborne rows, LU and solve. */
int svbi_interface_finish(const setup_t* S, work_t* w, int n, int bw, const int* active, const int* landing);

/* localized.c, coupled.c: one step of each method. */
int svbi_step_localized(const setup_t* S, state_t* X, work_t* w);
int svbi_step_coupled(const setup_t* S, state_t* X, work_t* w, int classic);
int svbi_coupled_init(const setup_t* S, work_t* w); /* after Kb, Kv are factored */

/* record.c, guard.c: outputs and the divergence guard. */
int svbi_record(const setup_t* S, const state_t* X, const excitation_t* E, outputs_t* O, const work_t* w,
                info_t* I);
int svbi_guard(const setup_t* S, const state_t* X, const work_t* w, info_t* I);

#if !SVBI_MOVING_LOAD
/* y = x^T A for an NV x NV row-major matrix: the row-vector product of the NumPy backend, summed
 * over j in the same order, as axpys that vectorise over d. */
static inline void vec_mat(const double* A, const double* x, double* y) {
  int j, d;
  for (d = 0; d < NV; ++d) y[d] = 0.0;
  for (j = 0; j < NV; ++j) {
    double xj = x[j];
    const double* row = A + j * NV;
    for (d = 0; d < NV; ++d) y[d] += xj * row[d];
  }
}

/* W_i^T x: the vertical motion of wheel i (column i of W_N^V, exact zeros dropped). */
static inline double wheel(const setup_t* S, const double* x, int i) {
  int k;
  double s = 0.0;
  for (k = S->VW_ptr[i]; k < S->VW_ptr[i + 1]; ++k) s += x[S->VW_idx[k]] * S->VW_val[k];
  return s;
}

/* vehicle.c: the vehicles, the creep law and the aux-bridge row target. */
void svbi_vehicle_increment_load(const setup_t* S, const double* u, const double* v, const double* a,
                                 double* Pt, double* Qt, double* PV, double* QV, double* f);
void svbi_creep_vehicle_load(const setup_t* S, const double* force, int k, double* f);
void svbi_vehicle_predictors(const setup_t* S, const state_t* X, work_t* w);
void svbi_vehicle_update(const setup_t* S, state_t* X, work_t* w);
void svbi_creep_update(const setup_t* S, state_t* X, const work_t* w);
void svbi_creep_bridge_load(const setup_t* S, const double* force, work_t* w);
/* The aux-bridge row target h_B of contact i (on the bridge: the discrete row; off: the ground);
 * inline: it runs for every wheel of every step. */
static inline double svbi_row_target(const setup_t* S, const work_t* w, int i, double Pg, double Qg) {
  int nc = S->nc, k;
  const double* row = w->ct.crow + (long)i * ROW_COLS;
  double r = w->ct.rail[i], r1 = w->ct.rail[nc + i], r2 = w->ct.rail[2 * nc + i];
  if (w->ct.con[i]) {
    int s = w->ct.cspan[i], f = w->ct.cfirst[i];
    double sp = 0.0, sq = 0.0;
    for (k = 0; k < NNZ_C_P_UE; ++k) sp += row[COL_C_P_UE + nz_c_P_ue[k]] * BR(w->br.PB, s, f + nz_c_P_ue[k]);
    for (k = 0; k < NNZ_C_Q_UE; ++k) sq += row[COL_C_Q_UE + nz_c_Q_ue[k]] * BR(w->br.QB, s, f + nz_c_Q_ue[k]);
    return row[COL_C_P_UG] * Pg + row[COL_C_Q_UG] * Qg + sp + sq + row[COL_C_R] * r +
           row[COL_C_R_X] * r1 + row[COL_C_R_XX] * r2;
  } else {
    double v = w->ct.v;
    double q = w->ct.under[i], q1 = w->ct.under[nc + i], q2 = w->ct.under[2 * nc + i];
    double track2 = w->ct.a == 0.0 ? v * v * r2 : v * v * r2 + w->ct.a * r1; /* Z'' = q'' + v^2 r'' + a r' */
    return S->p_P * Pg + S->p_Q * Qg + S->p_q2 * (q2 + track2) + S->p_q1 * (q1 + v * r1) + S->p_q * (q + r);
  }
}

/* The pivoting rule of a complementarity problem solved by complementary sets
 * (svbi.runtime.methods.unilateral.Pivoting): flip every infeasible wheel while their number falls, after
 * PIVOT_TRIES passes without a new lowest count only the lowest-numbered one (Murty's rule, which
 * terminates for the P-matrices of a contact flexibility). */
enum { PIVOT_TRIES = 3 };
typedef struct {
  int n, best, tries, passes;
} pivot_t;

static inline void svbi_pivot_init(pivot_t* p, int n) {
  p->n = n;
  p->best = n + 1;
  p->tries = PIVOT_TRIES;
  p->passes = 0;
}

/* bad[0 .. nc): the infeasible wheels (at least one), left holding the ones to flip. Nonzero past
 * the pass limit (unilateral.pass_limit): the caller hands the step to NumPy, which reports it. */
static inline int svbi_pivot_flips(pivot_t* p, int* bad, int nc) {
  int i, k = 0, first = -1;
  if (++p->passes > 4 * p->n + 16) return 1;
  for (i = 0; i < nc; ++i) {
    if (bad[i] && first < 0) first = i;
    k += bad[i] != 0;
  }
  if (k < p->best) {
    p->best = k;
    p->tries = PIVOT_TRIES;
    return 0;
  }
  if (p->tries > 0) {
    --p->tries;
    return 0;
  }
  for (i = 0; i < nc; ++i) bad[i] = i == first;
  return 0;
}
#endif

#if defined(__GNUC__)
#pragma GCC visibility pop
#endif

#endif /* SVBI_SOLVER_INTERNAL_H */
