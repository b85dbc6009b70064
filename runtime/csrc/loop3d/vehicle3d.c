/*
 * The vehicle's dense per-car blocks (block-diagonal by car, found at set-up): y (+)= B x, B the
 * compliance K^^-1 or M^-1 (M, C, K themselves are sparse: csr_mul3).
 */
#include "loop3d.h"

void veh_mul3(const setup3d_t* S, const double* blocks, const double* x, double* y, int add) {
  int b, i, j;
  for (b = 0; b < S->nblk; ++b) {
    int s = S->blk_start[b], n = S->blk_start[b + 1] - s;
    const double* B = blocks + S->blk_off[b];
    for (i = 0; i < n; ++i) {
      const double* r = B + (long)i * n;
      double acc = 0.0;
      for (j = 0; j < n; ++j) acc += r[j] * x[s + j];
      y[s + i] = add ? y[s + i] + acc : acc;
    }
  }
}
