/*
 * Roots the loop takes every step (roots.h). Independent of the topology (tests/backends/test_c_numerics.py
 * checks them against libm).
 */
#include "roots.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

/* The cube root of a contact force x > 0 (the creep law's N^(1/3)): a first guess from the
 * exponent bits (the exponent divided by 3), then three Halley steps y (y^3 + 2x) / (2y^3 + x), each
 * tripling the correct digits (3 % -> 1e-5 -> 1e-15 -> round-off): within 8e-16 of libm's cbrt over
 * [1e-100, 1e100] (2e7 random samples; tests/backends/test_c_numerics.py checks it). libm's cbrt (with its
 * frexp and scalbn) took 4 % of the paper loop. Forces outside that range go to cbrt. */
double svbi_cube_root(double x) {
  uint64_t bits;
  double y, y3;
  int k;
  if (!(x >= 1e-100 && x <= 1e100)) return cbrt(x);
  memcpy(&bits, &x, sizeof bits);
  bits = bits / 3 + UINT64_C(0x2A9F7893782DA1CE);
  memcpy(&y, &bits, sizeof y);
  for (k = 0; k < 3; ++k) {
    y3 = y * y * y;
    y = y * (y3 + 2.0 * x) / (2.0 * y3 + x);
  }
  return y;
}
