/*
 * Bridge pieces shared by the methods: where every contact is on a chain of spans, the contacts
 * grouped by span, the bridge's Newmark histories and update (newmark.h; either bridge kind), the
 * support targets and the span loads of a chain of spans.
 */
#include "internal.h"

/* Span, element, local coordinate and contact rows of every contact (svbi.runtime.model.bridge.locate). */
void svbi_locate(const setup_t* S, work_t* w) {
  int i;
  const double* cf = S->acceleration == 0.0 ? S->rows : w->ct.rows_now;
  for (i = 0; i < S->nc; ++i) {
    double x = w->ct.cx[i];
    double span_f = floor(x * S->inv_span_length), span;
    w->ct.con[i] = span_f >= 0.0 && span_f < (double)S->spans;
    span = span_f < 0.0 ? 0.0 : (span_f > S->spans - 1 ? (double)(S->spans - 1) : span_f);
    svbi_place(S, w, i, (int)span, (x - span * S->span_length) * S->inv_element_length, cf);
  }
}

/* Contacts grouped by span (in track order), for the span blocks. */
void svbi_group_by_span(const setup_t* S, work_t* w) {
  int k, s;
  for (s = 0; s <= S->spans; ++s) w->ct.sstart[s] = 0;
  for (k = 0; k < S->nc; ++k) {
    int i = S->order[k];
    if (w->ct.con[i]) w->ct.sstart[w->ct.cspan[i] + 1] += 1;
  }
  for (s = 0; s < S->spans; ++s) w->ct.sstart[s + 1] += w->ct.sstart[s];
  for (s = 0; s < S->spans; ++s) w->br.loaded[s] = w->ct.sstart[s];
  for (k = 0; k < S->nc; ++k) {
    int i = S->order[k];
    if (w->ct.con[i]) w->ct.slist[w->br.loaded[w->ct.cspan[i]]++] = i;
  }
  for (s = 0; s < S->spans; ++s) w->br.loaded[s] = w->ct.sstart[s + 1] > w->ct.sstart[s];
}


/* Newmark histories of the bridge (either kind: every DOF of the state the step works on). */
void svbi_bridge_histories(const setup_t* S, work_t* w) {
  long i, n = w->br.nb;
  for (i = 0; i < n; ++i) {
    w->br.PB[i] = svbi_nm_P(S->a0, S->a2, w->br.bu[i], w->br.bv[i], w->br.ba[i]);
    w->br.QB[i] = svbi_nm_Q(S->a1, w->br.bu[i], w->br.bv[i]);
  }
}

/* The support targets q^ of a chain of spans (row of svbi.codegen.constraints) from the histories
 * PB, QB and the support motion of the step. */
void svbi_support_targets(const setup_t* S, work_t* w) {
  int s, j, ns = S->ns, NS = S->spans * S->ns;
  for (s = 0; s < S->spans; ++s) {
    for (j = 0; j < ns; ++j) {
      int k = s * ns + j;
      w->sp.qhat[k] = S->p_P * BR(w->br.PB, s, S->sup[j]) + S->p_Q * BR(w->br.QB, s, S->sup[j]) +
                   S->p_q2 * w->sp.qs[2 * NS + k] + S->p_q1 * w->sp.qs[NS + k] + S->p_q * w->sp.qs[k];
    }
  }
}

/* The span load f = C T q' + M P + C Q of span s (span after span layout), row by row in one pass
 * over M and C's common pattern (setup MC_*; C = alpha M + beta K), as spans.c's rhs_lanes. */
void svbi_span_load(const setup_t* S, const work_t* w, int s, double* f) {
  int i, j, k, nd = S->nd, ns = S->ns, NS = S->spans * S->ns;
  const double* P = w->br.PB + (long)s * nd;
  const double* Q = w->br.QB + (long)s * nd;
  const double* q1 = w->sp.qs + NS + (long)s * ns;
  for (i = 0; i < nd; ++i) {
    double v = 0.0;
    for (j = 0; j < ns; ++j) v += S->CT[i * ns + j] * q1[j];
    for (k = S->MC_ptr[i]; k < S->MC_ptr[i + 1]; ++k) v += S->MC_m[k] * P[S->MC_idx[k]] + S->MC_c[k] * Q[S->MC_idx[k]];
    f[i] = v;
  }
}

/* svbi_bridge_update followed by the histories of the next step (svbi_bridge_histories without
 * the support targets) in one pass: the same values, read once. */
void svbi_bridge_update_histories(const setup_t* S, work_t* w) {
  long i, n = w->br.nb;
  double a0 = S->a0, a1 = S->a1, a2 = S->a2;
  double* restrict u = w->br.bu;
  double* restrict v = w->br.bv;
  double* restrict a = w->br.ba;
  double* restrict P = w->br.PB;
  double* restrict Q = w->br.QB;
  for (i = 0; i < n; ++i) {
    double vi = svbi_nm_vel(a1, u[i], Q[i]), ai = svbi_nm_acc(a0, u[i], P[i]);
    v[i] = vi;
    a[i] = ai;
    P[i] = svbi_nm_P(a0, a2, u[i], vi, ai);
    Q[i] = svbi_nm_Q(a1, u[i], vi);
  }
}

/* The Newmark update of the bridge from its new displacements. */
void svbi_bridge_update(const setup_t* S, work_t* w) {
  long i, n = w->br.nb;
  for (i = 0; i < n; ++i) {
    w->br.bv[i] = svbi_nm_vel(S->a1, w->br.bu[i], w->br.QB[i]);
    w->br.ba[i] = svbi_nm_acc(S->a0, w->br.bu[i], w->br.PB[i]);
  }
}
