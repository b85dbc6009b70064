/*
 * Zero-phase filtering of the contact forces (svbi.runtime.force_filter): scipy.signal.sosfiltfilt
 * with odd padding, for m channels held row after row (one row a time step), arithmetic for
 * arithmetic. SciPy filters each channel on its own (its Cython sosfilt, transposed direct form II);
 * here the channels are the inner loop, so that a row of them is one vectorised pass: the same
 * operations on every channel, in the same order (svbi builds it with contraction off: the same
 * bits; tests/run/test_force_filter.py).
 */
#include <string.h>

/* One pass of the cascade over rows 0 .. N - 1 (forward) or N - 1 .. 0 (backward) of y (N x m, in
 * place), the state z (nsec x 2 x m) starting at zi[s][j] times the first row the pass reads. */
static void cascade(double* y, long N, long m, const double* sos, int nsec, const double* zi, double* z,
                    int backward) {
  long r, c;
  int s;
  const double* first = y + (backward ? N - 1 : 0) * m;
  for (s = 0; s < nsec; ++s)
    for (c = 0; c < m; ++c) {
      z[(2 * s) * m + c] = zi[2 * s] * first[c];
      z[(2 * s + 1) * m + c] = zi[2 * s + 1] * first[c];
    }
  for (r = 0; r < N; ++r) {
    double* row = y + (backward ? N - 1 - r : r) * m;
    for (s = 0; s < nsec; ++s) {
      const double b0 = sos[6 * s], b1 = sos[6 * s + 1], b2 = sos[6 * s + 2];
      const double a1 = sos[6 * s + 4], a2 = sos[6 * s + 5];
      double* z0 = z + (2 * s) * m;
      double* z1 = z + (2 * s + 1) * m;
      for (c = 0; c < m; ++c) {
        double x_cur = row[c], x_new = b0 * x_cur + z0[c];
        z0[c] = b1 * x_cur - a1 * x_new + z1[c];
        z1[c] = b2 * x_cur - a2 * x_new;
        row[c] = x_new;
      }
    }
  }
}

/* sosfiltfilt(sos, x, axis=0, padlen=padlen) of the m channels x[r * ldx + c] (n rows), keeping rows
 * 0, every, 2 every, ... (k of them) in out[i * ldo + c]. zi is sosfilt_zi(sos) (nsec x 2); work
 * holds (n + 2 padlen) m + 2 nsec m doubles. 0 < padlen < n. */
void svbi_sosfiltfilt(const double* x, long ldx, long n, long m, const double* sos, int nsec, const double* zi,
                      long padlen, long every, long k, double* out, long ldo, double* work) {
  long N = n + 2 * padlen, r, c, i;
  double* y = work;
  double* z = work + N * m;
  const double* x0 = x;
  const double* xe = x + (n - 1) * ldx;
  for (r = 0; r < padlen; ++r) { /* odd extension: 2 x[0] - x[padlen - r] */
    const double* xr = x + (padlen - r) * ldx;
    for (c = 0; c < m; ++c) y[r * m + c] = 2.0 * x0[c] - xr[c];
  }
  for (r = 0; r < n; ++r) memcpy(y + (padlen + r) * m, x + r * ldx, sizeof(double) * (size_t)m);
  for (r = 0; r < padlen; ++r) { /* 2 x[n - 1] - x[n - 2 - r] */
    const double* xr = x + (n - 2 - r) * ldx;
    for (c = 0; c < m; ++c) y[(padlen + n + r) * m + c] = 2.0 * xe[c] - xr[c];
  }
  cascade(y, N, m, sos, nsec, zi, z, 0);
  cascade(y, N, m, sos, nsec, zi, z, 1);
  for (i = 0; i < k; ++i) memcpy(out + i * ldo, y + (padlen + i * every) * m, sizeof(double) * (size_t)m);
}
