/*
 * The vehicle's matrices, block-diagonal by car (checked at set-up): y (+)= B x, B one of the
 * per-block dense arrays (M, C, K, the compliance K^^-1, M^-1).
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
