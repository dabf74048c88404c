// Band kernels of the V-cycle's line smoother (vcycle_preconditioner.hpp): Cholesky
// factorisation and solves of one symmetric positive definite band matrix, and the solve of
// two independent lines at once. Every row of a solve waits on the row before it (a chain of
// dependent sums), so solve_pair interleaves the rows of two lines to give the core
// independent work; each line's arithmetic and its order stay those of solve: the same bits
// (tests/kernels/unit_band_lines.cpp). Pairing the factorisations as well gained nothing
// measurable (clothbench-micro vcycle_factor at 101^2 and 301^2), as the Galerkin values and
// the band's assembly dominate them: they stay one line at a time.
//
// Storage: the lower band, half-bandwidth w, row-major rows of w + 1 entries, entry (r, c) for
// r - w <= c <= r at r * (w + 1) + c - r + w; the factor L overwrites it with 1 / L(r, r) in
// place of each pivot L(r, r), so the solves multiply where they would divide. The factor is
// computed in double; the solves read it as double or as float (the V-cycle keeps its line
// factors rounded to float) and compute in double either way.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

/// Marks the line kernels (band Cholesky, band solves, line residuals): short loops whose
/// sums run in series. GCC's -O3 vectoriser packs them into shuffles that are slower than
/// the scalar loops (perf on paper/box-257, 40 steps, 1 thread: factor_line 1.7x faster
/// without it); the arithmetic and its order, hence the bits, are the same either way.
#if defined(__GNUC__) && !defined(__clang__)
#define CLOTHBENCH_SCALAR_LOOPS __attribute__((optimize("no-tree-vectorize")))
#else
#define CLOTHBENCH_SCALAR_LOOPS
#endif

namespace clothbench::kernels::band {

/// The n x n band overwritten by its factor, row by row from the rows before it; false on a
/// non-positive pivot (the band is then partly factored and must not be solved with).
CLOTHBENCH_SCALAR_LOOPS inline bool cholesky(double* band, std::int64_t n, int w) {
  const std::int64_t row = w + 1;
  for (std::int64_t r = 0; r < n; ++r) {
    const std::int64_t first = std::max<std::int64_t>(0, r - w);
    for (std::int64_t c = first; c <= r; ++c) {
      double sum = band[r * row + c - r + w];
      const std::int64_t from = std::max(first, c - w);
      for (std::int64_t k = from; k < c; ++k)
        sum -= band[r * row + k - r + w] * band[c * row + k - c + w];
      if (c == r) {
        if (!(sum > 0.0) || !std::isfinite(sum)) return false;
        band[r * row + w] = 1.0 / std::sqrt(sum);
      } else {
        band[r * row + c - r + w] = sum * band[c * row + w];
      }
    }
  }
  return true;
}

/// One row of the forward substitution L y = b: x[r] from the rows before it.
template <class Factor>
CLOTHBENCH_SCALAR_LOOPS inline void forward_row(const Factor* band, std::int64_t r, int w,
                                                double* x) {
  const std::int64_t row = w + 1;
  double sum = x[r];
  for (std::int64_t k = std::max<std::int64_t>(0, r - w); k < r; ++k)
    sum -= band[r * row + k - r + w] * x[k];
  x[r] = sum * band[r * row + w];
}

/// One row of the back substitution L^T x = y, by columns of L^T, i.e. along the rows of L as
/// they are stored: once x[r] is known, it leaves the rows above it (the factor is read in the
/// order the forward pass read it, not across rows).
template <class Factor>
CLOTHBENCH_SCALAR_LOOPS inline void backward_row(const Factor* band, std::int64_t r, int w,
                                                 double* x) {
  const std::int64_t row = w + 1;
  const double xr = x[r] * band[r * row + w];
  x[r] = xr;
  const Factor* lr = band + r * row + w - r;  // lr[k] = L(r, k)
  for (std::int64_t k = std::max<std::int64_t>(0, r - w); k < r; ++k) x[k] -= lr[k] * xr;
}

/// Solves L L^T x = b in place with the factor of cholesky.
template <class Factor>
CLOTHBENCH_SCALAR_LOOPS inline void solve(const Factor* band, std::int64_t n, int w, double* x) {
  for (std::int64_t r = 0; r < n; ++r) forward_row(band, r, w, x);
  for (std::int64_t r = n - 1; r >= 0; --r) backward_row(band, r, w, x);
}

/// solve for two independent lines, rows interleaved.
template <class Factor>
CLOTHBENCH_SCALAR_LOOPS inline void solve_pair(const Factor* band_a, std::int64_t n_a, int w_a,
                                               double* x_a, const Factor* band_b, std::int64_t n_b,
                                               int w_b, double* x_b) {
  const std::int64_t both = std::min(n_a, n_b);
  for (std::int64_t r = 0; r < both; ++r) {
    forward_row(band_a, r, w_a, x_a);
    forward_row(band_b, r, w_b, x_b);
  }
  for (std::int64_t r = both; r < n_a; ++r) forward_row(band_a, r, w_a, x_a);
  for (std::int64_t r = both; r < n_b; ++r) forward_row(band_b, r, w_b, x_b);
  for (std::int64_t i = 0; i < both; ++i) {
    backward_row(band_a, n_a - 1 - i, w_a, x_a);
    backward_row(band_b, n_b - 1 - i, w_b, x_b);
  }
  for (std::int64_t r = n_a - 1 - both; r >= 0; --r) backward_row(band_a, r, w_a, x_a);
  for (std::int64_t r = n_b - 1 - both; r >= 0; --r) backward_row(band_b, r, w_b, x_b);
}

}  // namespace clothbench::kernels::band
