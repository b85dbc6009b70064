/*
 * Where a contact is: its element and local coordinate on a span with the contact rows there (the
 * generated row evaluation), and the rail's height under it. Shared by both bridge kinds and by
 * every method.
 */
#include "internal.h"

/* Contact i at the local coordinate local (in elements) of span span: its element (clamped to the
 * span), xi and contact rows from the row table cf (the generated unrolled evaluation). */
void svbi_place(const setup_t* S, work_t* w, int i, int span, double local, const double* cf) {
  int p;
  double element = floor(local), xi, pw[ROW_DEG + 1];
  if (element < 0.0) element = 0.0;
  if (element > S->elements - 1) element = (double)(S->elements - 1);
  xi = local - element;
  if (xi < 0.0) xi = 0.0;
  if (xi > 1.0) xi = 1.0;
  w->ct.cspan[i] = span;
  w->ct.cfirst[i] = 3 * (int)element;
  w->ct.cxi[i] = xi;
  pw[0] = 1.0;
  for (p = 1; p <= ROW_DEG; ++p) pw[p] = pw[p - 1] * xi;
  svbi_contact_rows(pw, cf, w->ct.crow + (long)i * ROW_COLS); /* generated: the structural non-zeros */
}

#if !SVBI_MOVING_LOAD
/* Height of the rail under contact c at the step's time: N0 u_B + r on the bridge, q + r off it. */
double svbi_rail_height(const setup_t* S, const work_t* w, int c) {
  double rail;
  int j;
  (void)S;
  if (w->ct.con[c]) {
    const double* N0 = w->ct.crow + (long)c * ROW_COLS + COL_N0;
    rail = 0.0;
    for (j = 0; j < NNZ_N0; ++j) rail += N0[nz_N0[j]] * BR(w->br.bu, w->ct.cspan[c], w->ct.cfirst[c] + nz_N0[j]);
  } else {
    rail = w->ct.under[c];
  }
  return rail + w->ct.rail[c];
}
#endif
