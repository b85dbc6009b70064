/*
 * Roots the loop takes every step (roots.c).
 */
#ifndef SVBI_SOLVER_ROOTS_H
#define SVBI_SOLVER_ROOTS_H

/* x^(1/3) for x > 0: within 8e-16 of libm's cbrt over [1e-100, 1e100] (cbrt itself outside). */
double svbi_cube_root(double x);

#endif /* SVBI_SOLVER_ROOTS_H */
