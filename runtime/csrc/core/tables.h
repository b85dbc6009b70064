/*
 * Piecewise-polynomial tables of svbi's C time loop (tables.c): rail profiles, onset ramps and
 * ground-motion records, in scipy.interpolate.PPoly's layout with constant values beyond both ends.
 * Independent of the topology (tests/backends/test_c_numerics.py checks it against scipy.interpolate.PPoly).
 */
#ifndef SVBI_SOLVER_TABLES_H
#define SVBI_SOLVER_TABLES_H

#include "svbi_solver_types.h"

/* Value, first and second derivative of p at x (out[0..2]). */
void svbi_ppoly_eval(const svbi_ppoly* p, double x, double* out);

/* The same at count points x[j]: value, first and second derivative at out[j], out[stride + j],
 * out[2 stride + j]. */
void svbi_ppoly_eval_many(const svbi_ppoly* p, const double* x, int count, double* out, long stride);

#endif /* SVBI_SOLVER_TABLES_H */
