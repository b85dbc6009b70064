/*
 * Excitations at every step: contact positions, the rail irregularity under every contact and the
 * ground motion under the contacts and at the supports, from tables (tables.c) or from the stream
 * buffers Python fills (docs/c-backend.md, "Excitations: tables or streams").
 */
#include "internal.h"

/* Index of the support line nearest to x (ties go to the one ahead), as numpy.searchsorted(mids, x,
 * side="right"). */
static int nearest_line(const setup_t* S, const excitation_t* E, double x) {
  int lo = 0, hi = S->spans;
  while (lo < hi) {
    int mid = (lo + hi) / 2;
    if (E->mids[mid] <= x)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo;
}

/* q, q', q'' of one ground component (0 vertical, 1 longitudinal) at time t and position x
 * (partial time derivatives at fixed x). */
static void ground_at(const setup_t* S, const excitation_t* E, int which, double t, double x, double* out) {
  int mode = which ? E->gh_mode : E->gv_mode;
  const svbi_ppoly* p = which ? &E->gh : &E->gv;
  if (mode == 1) {
    svbi_ppoly_eval(p, t, out);
  } else if (mode == 2) {
    svbi_ppoly_eval(p, t - (x - E->x_ref) / E->apparent_velocity, out);
  } else if (mode == 4) {
    svbi_ppoly_eval((which ? E->gh_lines : E->gv_lines) + nearest_line(S, E, x), t, out);
  } else {
    out[0] = 0.0;
    out[1] = 0.0;
    out[2] = 0.0;
  }
}

/* Newmark-consistent target q, q', q'' of one support at x (svbi.runtime.model.system.newmark_targets,
 * docs/method.md "Support targets"): h = q - dt^2/4 q'' at t - dt, t, t + dt, combined so that the
 * targets of consecutive steps satisfy Newmark's relations exactly. */
static void support_target(const setup_t* S, const excitation_t* E, int which, double t, double x,
                           double* out) {
  double g[3], h[3], dt = S->dt;
  int k;
  for (k = 0; k < 3; ++k) {
    ground_at(S, E, which, t + (double)(k - 1) * dt, x, g);
    h[k] = g[0] - (0.25 * dt * dt) * g[2];
  }
  out[0] = 0.25 * (h[0] + 2.0 * h[1] + h[2]);
  out[1] = (h[2] - h[0]) / (2.0 * dt);
  out[2] = (h[2] - 2.0 * h[1] + h[0]) / (dt * dt);
}

/* The ground under every contact at t: a travelling wave q(t - (x - x_ref) / c) seen by a point
 * moving at v carries the factor (1 - v / c) and -(a / c) q'; a per-line or synchronous motion none. */
static void ground_under(const setup_t* S, const excitation_t* E, work_t* w, double t) {
  int i, nc = S->nc;
  double f = E->apparent_velocity > 0.0 ? 1.0 - w->ct.v / E->apparent_velocity : 1.0;
  double fa = E->apparent_velocity > 0.0 ? w->ct.a / E->apparent_velocity : 0.0;
  for (i = 0; i < nc; ++i) {
    double q[3];
    ground_at(S, E, 0, t, w->ct.cx[i], q);
    w->ct.under[i] = q[0];
    w->ct.under[nc + i] = E->apparent_velocity > 0.0 ? f * q[1] : q[1];
    w->ct.under[2 * nc + i] = E->apparent_velocity > 0.0 ? f * f * q[2] : q[2];
    if (fa != 0.0) w->ct.under[2 * nc + i] -= fa * q[1];
    ground_at(S, E, 1, t, w->ct.cx[i], q);
    w->ct.ulon[i] = E->apparent_velocity > 0.0 ? f * q[1] : q[1];
  }
}

/* A bridge of substructures: the targets of every support slot at its own position and in its own
 * direction (a pier base's rotation follows no ground), and the ground recorded at every active
 * support (or once, for a synchronous motion). */
static void general_supports(const setup_t* S, const excitation_t* E, work_t* w, double t) {
  int k, NSL = 3 * S->nsub;
  long nrec = n_recorded(S);
  int synchronous = E->gv_mode <= 1 && E->gh_mode <= 1;
  double sync[2][3];
  if (synchronous) { /* one target per direction for every support */
    support_target(S, E, 0, t, 0.0, sync[0]);
    support_target(S, E, 1, t, 0.0, sync[1]);
  }
  for (k = 0; k < NSL; ++k) {
    double q[3] = {0.0, 0.0, 0.0};
    int comp = S->g_slot_comp[k], which = comp == 1 ? 0 : 1;
    if (comp != 2 && S->g_slot_active[k]) { /* an unused slot's target is never read */
      if (synchronous)
        memcpy(q, sync[which], sizeof q);
      else
        support_target(S, E, which, t, S->g_slot_x[k], q);
    }
    w->sp.qs[k] = q[0];
    w->sp.qs[NSL + k] = q[1];
    w->sp.qs[2 * NSL + k] = q[2];
  }
  if (E->ground_per_support) {
    for (k = 0; k < nrec; ++k) {
      double x = S->g_slot_x[S->g_act_slot[k]], qv[3], qh[3];
      ground_at(S, E, 0, t, x, qv);
      ground_at(S, E, 1, t, x, qh);
      w->rc.grec[k] = qv[0];
      w->rc.grec[nrec + k] = qh[0];
    }
  } else {
    double qv[3], qh[3];
    ground_at(S, E, 0, t, 0.0, qv);
    ground_at(S, E, 1, t, 0.0, qh);
    w->rc.grec[0] = qv[0];
    w->rc.grec[1] = qh[0];
  }
}

/* Positions, rail irregularity and ground motion at t = (n + 1) dt. */
void svbi_excite(const setup_t* S, const excitation_t* E, work_t* w, long n, double t) {
  int i, j, s;
  int nc = S->nc, ns = S->ns, NS = (int)n_slots(S);
  long e = n - E->s_n0;
  if (S->acceleration == 0.0) {
    for (i = 0; i < nc; ++i) w->ct.cx[i] = S->start + S->speed * t - S->offsets[i];
    w->ct.v = S->speed;
    w->ct.a = 0.0;
  } else { /* svbi.runtime.model.train.Kinematics: a braking train stands from stop_time on */
    double tm = t < S->stop_time ? t : S->stop_time, travel;
    long k, nrow = (long)(ROW_DEG + 1) * ROW_COLS;
    const double* T0 = S->rows_va;
    travel = S->speed * tm + 0.5 * S->acceleration * tm * tm;
    for (i = 0; i < nc; ++i) w->ct.cx[i] = S->start + travel - S->offsets[i];
    w->ct.v = S->speed + S->acceleration * tm;
    w->ct.a = t < S->stop_time ? S->acceleration : 0.0;
    long nt = S->general ? S->nrclass : 1, tb; /* every row table: nt blocks of T0, T1, T2, Ta */
    for (tb = 0; tb < nt; ++tb) {
      const double *U0 = T0 + 4 * tb * nrow, *U1 = U0 + nrow, *U2 = U1 + nrow, *Ua = U2 + nrow;
      double* out = w->ct.rows_now + tb * nrow;
      for (k = 0; k < nrow; ++k) out[k] = U0[k] + w->ct.v * U1[k] + (w->ct.v * w->ct.v) * U2[k] + w->ct.a * Ua[k];
    }
  }

  /* rail irregularity under every contact */
  if (E->irr_mode == 1) {
    /* the profile at every contact at once (svbi_ppoly_eval_many), then the onset and the start */
    svbi_ppoly_eval_many(&E->irr_base, w->ct.cx, nc, w->ct.rail, nc);
    for (i = 0; i < nc; ++i) {
      double x = w->ct.cx[i], b[3], h[3];
      if (!(x > E->irr_start)) {
        w->ct.rail[i] = 0.0;
        w->ct.rail[nc + i] = 0.0;
        w->ct.rail[2 * nc + i] = 0.0;
        continue;
      }
      if (E->irr_ramp) {
        b[0] = w->ct.rail[i];
        b[1] = w->ct.rail[nc + i];
        b[2] = w->ct.rail[2 * nc + i];
        svbi_ppoly_eval(&E->irr_onset, x, h);
        w->ct.rail[i] = h[0] * b[0];
        w->ct.rail[nc + i] = h[1] * b[0] + h[0] * b[1];
        w->ct.rail[2 * nc + i] = h[2] * b[0] + 2.0 * h[1] * b[1] + h[0] * b[2];
      }
    }
  } else if (E->irr_mode == 2) {
    memcpy(w->ct.rail, E->s_rail + e * 3 * nc, sizeof(double) * 3 * (size_t)nc);
  } else {
    memset(w->ct.rail, 0, sizeof(double) * 3 * (size_t)nc);
  }

  /* ground: under every contact, at every support, and the recorded values */
  if (E->gv_mode == 3 || E->gh_mode == 3) {
    memcpy(w->ct.under, E->s_under + e * 4 * nc, sizeof(double) * 3 * (size_t)nc);
    memcpy(w->ct.ulon, E->s_under + e * 4 * nc + 3 * nc, sizeof(double) * (size_t)nc);
    memcpy(w->sp.qs, E->s_sup + e * 3 * NS, sizeof(double) * 3 * (size_t)NS);
    memcpy(w->rc.grec, E->s_rec + e * 2 * n_recorded(S), sizeof(double) * 2 * (size_t)n_recorded(S));
    return;
  }
  if (E->gv_mode == 0 && E->gh_mode == 0) {
    memset(w->ct.under, 0, sizeof(double) * 3 * (size_t)nc);
    memset(w->ct.ulon, 0, sizeof(double) * (size_t)nc);
    memset(w->sp.qs, 0, sizeof(double) * 3 * (size_t)NS);
    memset(w->rc.grec, 0, sizeof(double) * 2 * (size_t)n_recorded(S));
    return;
  }
  if (S->general) {
    ground_under(S, E, w, t);
    general_supports(S, E, w, t);
    return;
  }
  if (E->gv_mode <= 1 && E->gh_mode <= 1) {
    /* synchronous: one value for every position */
    double qv[3], qh[3], tv[3], th[3];
    ground_at(S, E, 0, t, 0.0, qv);
    ground_at(S, E, 1, t, 0.0, qh);
    support_target(S, E, 0, t, 0.0, tv);
    support_target(S, E, 1, t, 0.0, th);
    for (i = 0; i < nc; ++i) {
      w->ct.under[i] = qv[0];
      w->ct.under[nc + i] = qv[1];
      w->ct.under[2 * nc + i] = qv[2];
      w->ct.ulon[i] = qh[1];
    }
    for (s = 0; s < S->spans; ++s) {
      for (j = 0; j < ns; ++j) {
        const double* q = S->sup_vertical[j] ? tv : th;
        int k = s * ns + j;
        w->sp.qs[k] = q[0];
        w->sp.qs[NS + k] = q[1];
        w->sp.qs[2 * NS + k] = q[2];
      }
    }
    w->rc.grec[0] = qv[0];
    w->rc.grec[1] = qh[0];
    return;
  }
  {
    /* travelling wave q(t - (x - x_ref) / c), seen by a point moving at v with the factor
     * (1 - v / c); or one record per support line, a point taking the nearest line */
    long nrec = n_recorded(S);
    ground_under(S, E, w, t);
    for (s = 0; s < S->spans; ++s) {
      for (j = 0; j < ns; ++j) {
        int k = s * ns + j;
        double x = (double)s * S->span_length + S->sup_x[j];
        double qv[3], qh[3], q[3];
        ground_at(S, E, 0, t, x, qv);
        ground_at(S, E, 1, t, x, qh);
        support_target(S, E, S->sup_vertical[j] ? 0 : 1, t, x, q);
        {
          w->sp.qs[k] = q[0];
          w->sp.qs[NS + k] = q[1];
          w->sp.qs[2 * NS + k] = q[2];
        }
        w->rc.grec[k] = qv[0];
        w->rc.grec[nrec + k] = qh[0];
      }
    }
  }
}
