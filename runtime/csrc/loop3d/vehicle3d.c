/*
 * The vehicle's dense per-car blocks (block-diagonal by car, found at set-up): y (+)= B x, B the
 * compliance K^^-1 or M^-1 (M, C, K themselves are sparse: csr_mul3).
 */
#include "loop3d.h"

/* The blocks column by column (veh_mul3 takes them so): Bt[j n + i] = B[i n + j], block by block. */
void veh_transpose3(const setup3d_t* S, const double* blocks, double* out) {
  int b, i, j;
  for (b = 0; b < S->nblk; ++b) {
    const int n = S->blk_start[b + 1] - S->blk_start[b];
    const double* B = blocks + S->blk_off[b];
    double* T = out + S->blk_off[b];
    for (i = 0; i < n; ++i)
      for (j = 0; j < n; ++j) T[(long)j * n + i] = B[(long)i * n + j];
  }
}

/* y (+)= B x from the blocks by columns (veh_transpose3). Each row's sum runs over the nonzeros of x
 * in order (the zeros add nothing: the same sums as over every column), as independent sums down
 * the columns (contiguous: vector operations), the zero columns skipped (the contact forces' loads
 * touch the wheelsets' DOFs only). */
void veh_mul3(const setup3d_t* S, const double* blocks_t, const double* x, double* y, int add) {
  int b, i, j;
  for (b = 0; b < S->nblk; ++b) {
    const int s = S->blk_start[b], n = S->blk_start[b + 1] - s;
    const double* Bt = blocks_t + S->blk_off[b];
    double acc[n > 0 ? n : 1];
    for (i = 0; i < n; ++i) acc[i] = 0.0;
    for (j = 0; j < n; ++j) {
      const double xj = x[s + j];
      const double* c = Bt + (long)j * n;
      if (xj == 0.0) continue;
      for (i = 0; i < n; ++i) acc[i] += c[i] * xj;
    }
    if (add)
      for (i = 0; i < n; ++i) y[s + i] += acc[i];
    else
      for (i = 0; i < n; ++i) y[s + i] = acc[i];
  }
}
