/*
 * Newmark's relations (gamma = 1/2, beta = 1/4; svbi.runtime.methods.newmark), the one place they are
 * written. With a0 = 4 / dt^2, a1 = 2 / dt, a2 = 4 / dt (setup a0, a1, a2), the state (u, v, a) of
 * t_n gives the histories
 *
 *     P = a0 u + a2 v + a,    Q = a1 u + v,
 *
 * and the new displacement u of t_{n+1} the new rates
 *
 *     v = a1 u - Q,           a = a0 u - P.
 *
 * An unknown solved for as an increment du over the step (the vehicles, the coupled multipliers)
 * has the increment histories P~ = a2 v + a, Q~ = v (P = a0 u + P~, Q = a1 u + Q~) and the new
 * rates v = a1 du - Q~, a = a0 du - P~.
 *
 * Each function is the expression the loop evaluates, in its order of operations (the same bits
 * wherever it is inlined). The lane loops of four doubles (vec_t) write the same expressions on
 * vectors: svbi_nm_*_v.
 */
#ifndef SVBI_NEWMARK_H
#define SVBI_NEWMARK_H

#include "band.h" /* vec_t */

/* P = a0 u + a2 v + a: the acceleration history. */
static inline double svbi_nm_P(double a0, double a2, double u, double v, double a) { return a0 * u + a2 * v + a; }

/* Q = a1 u + v: the velocity history. */
static inline double svbi_nm_Q(double a1, double u, double v) { return a1 * u + v; }

/* P~ = a2 v + a: the acceleration history of an increment (P = a0 u + P~). */
static inline double svbi_nm_Pt(double a2, double v, double a) { return a2 * v + a; }

/* a = a0 u - P: the new acceleration from the new displacement (or increment) u and the history P. */
static inline double svbi_nm_acc(double a0, double u, double P) { return a0 * u - P; }

/* v = a1 u - Q: the new velocity from the new displacement (or increment) u and the history Q. */
static inline double svbi_nm_vel(double a1, double u, double Q) { return a1 * u - Q; }

/* The full histories of an increment unknown from its increment histories: P = a0 u + P~ (a = a0)
 * and Q = a1 u + Q~ (a = a1); and on lanes (vec_t). */
static inline double svbi_nm_full(double a, double u, double tilde) { return a * u + tilde; }
static inline vec_t svbi_nm_full_v(double a, vec_t u, vec_t tilde) { return a * u + tilde; }

/*
 * The force of a multiplier solved for as an increment (svbi.runtime.methods.coupled_dynamic, the
 * constraint stabilised by Baumgarte's terms with omega = kappa / dt and damping ratio zeta; setup
 * c2 = 2 zeta omega, w2 = omega^2): its history H = mbar (P~ + c2 Q~ - omega^2 lambda_n) from the
 * triple (lambda, lambda', lambda'') at lam[i], lam[n + i], lam[2 n + i], and the update of the
 * triple by the increment delta.
 */
static inline double svbi_nm_multiplier_history(double a2, double c2, double w2, const double* lam, long n, long i,
                                                double mbar) {
  double P = svbi_nm_Pt(a2, lam[n + i], lam[2 * n + i]), Q = lam[n + i];
  return mbar * (P + c2 * Q - w2 * lam[i]);
}

static inline void svbi_nm_multiplier_update(double a0, double a1, double a2, double* lam, long n, long i,
                                             double delta) {
  double P = svbi_nm_Pt(a2, lam[n + i], lam[2 * n + i]), Q = lam[n + i];
  lam[i] += delta;
  lam[n + i] = svbi_nm_vel(a1, delta, Q);
  lam[2 * n + i] = svbi_nm_acc(a0, delta, P);
}

#endif /* SVBI_NEWMARK_H */
