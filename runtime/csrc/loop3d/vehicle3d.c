/*
 * The vehicle's dense per-car blocks (block-diagonal by car, found at set-up): y (+)= B x, B the
 * compliance K^^-1 or M^-1 (M, C, K themselves are sparse: csr_mul3).
 */
#include "loop3d.h"

/* Each row's sum runs over the nonzeros of x in order (the zeros add nothing: the same sums as
 * over every column), by columns where x is sparse in the block (the contact forces' loads touch
 * the wheelsets' DOFs only): independent sums, the zero columns skipped. */
void veh_mul3(const setup3d_t* S, const double* blocks, const double* x, double* y, int add) {
  int b, i, j;
  for (b = 0; b < S->nblk; ++b) {
    int s = S->blk_start[b], n = S->blk_start[b + 1] - s, nz = 0;
    const double* B = blocks + S->blk_off[b];
    int cols[n > 0 ? n : 1];
    double acc[n > 0 ? n : 1];
    for (j = 0; j < n; ++j)
      if (x[s + j] != 0.0) cols[nz++] = j;
    if (nz == n) {
      for (i = 0; i < n; ++i) {
        const double* r = B + (long)i * n;
        double a = 0.0;
        for (j = 0; j < n; ++j) a += r[j] * x[s + j];
        y[s + i] = add ? y[s + i] + a : a;
      }
      continue;
    }
    for (i = 0; i < n; ++i) acc[i] = 0.0;
    for (j = 0; j < nz; ++j) {
      const double xj = x[s + cols[j]];
      const double* c = B + cols[j];
      for (i = 0; i < n; ++i) acc[i] += c[(long)i * n] * xj;
    }
    for (i = 0; i < n; ++i) y[s + i] = add ? y[s + i] + acc[i] : acc[i];
  }
}
