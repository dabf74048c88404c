// The V-cycle smoother's band kernels (kernels/band_lines.hpp): the Cholesky factor solves the
// band system, a non-positive pivot is reported, and the solve of two lines at once gives
// each line the bits of its own solve whatever the two lengths and widths.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "kernels/band_lines.hpp"

namespace clothbench {
namespace {

namespace band = kernels::band;

/// Entry (r, c), r - w <= c <= r, of the lower band as band_lines.hpp stores it.
double& at(std::vector<double>& b, int w, std::int64_t r, std::int64_t c) {
  return b[static_cast<std::size_t>(r * (w + 1) + c - r + w)];
}

/// A random symmetric, strictly diagonally dominant (so positive definite) n x n band.
std::vector<double> random_band(std::int64_t n, int w, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> b(static_cast<std::size_t>(n * (w + 1)), 0.0);
  for (std::int64_t r = 0; r < n; ++r) {
    for (std::int64_t c = std::max<std::int64_t>(0, r - w); c < r; ++c) at(b, w, r, c) = u(rng);
  }
  for (std::int64_t r = 0; r < n; ++r) {
    double off = 0.0;
    for (std::int64_t c = std::max<std::int64_t>(0, r - w); c <= std::min(n - 1, r + w); ++c) {
      if (c != r) off += std::abs(c < r ? at(b, w, r, c) : at(b, w, c, r));
    }
    at(b, w, r, r) = off + 0.5 + 0.5 * std::abs(u(rng));
  }
  return b;
}

/// y = A x with A the symmetric matrix of the (unfactored) lower band.
std::vector<double> multiply(std::vector<double> b, int w, const std::vector<double>& x) {
  const auto n = static_cast<std::int64_t>(x.size());
  std::vector<double> y(x.size(), 0.0);
  for (std::int64_t r = 0; r < n; ++r) {
    for (std::int64_t c = std::max<std::int64_t>(0, r - w); c <= r; ++c) {
      y[r] += at(b, w, r, c) * x[c];
      if (c != r) y[c] += at(b, w, r, c) * x[r];
    }
  }
  return y;
}

std::vector<double> random_vector(std::int64_t n, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> v(static_cast<std::size_t>(n));
  for (double& x : v) x = u(rng);
  return v;
}

TEST(BandLines, TheFactorSolvesTheBandSystem) {
  std::mt19937_64 rng(11);
  for (const int w : {2, 5, 8}) {
    for (const std::int64_t n : {1, 3, 4, 30, 91}) {
      const std::vector<double> a = random_band(n, w, rng);
      std::vector<double> factor = a;
      ASSERT_TRUE(band::cholesky(factor.data(), n, w)) << "n " << n << " w " << w;
      const std::vector<double> b = random_vector(n, rng);
      std::vector<double> x = b;
      band::solve(factor.data(), n, w, x.data());
      const std::vector<double> ax = multiply(a, w, x);
      for (std::int64_t r = 0; r < n; ++r) {
        EXPECT_NEAR(ax[r], b[r], 1e-12) << "n " << n << " w " << w << " row " << r;
      }
    }
  }
}

TEST(BandLines, ANonPositivePivotIsReported) {
  std::mt19937_64 rng(12);
  std::vector<double> a = random_band(20, 5, rng);
  at(a, 5, 13, 13) = -1.0;  // no longer positive definite
  EXPECT_FALSE(band::cholesky(a.data(), 20, 5));
  std::vector<double> nan = random_band(20, 5, rng);
  at(nan, 5, 7, 7) = std::nan("");
  EXPECT_FALSE(band::cholesky(nan.data(), 20, 5));
}

TEST(BandLines, ThePairSolveGivesEachLineTheBitsOfItsOwnSolve) {
  std::mt19937_64 rng(13);
  struct Line {
    std::int64_t n;
    int w;
  };
  // Equal lines, either one longer, either one wider, single-row lines.
  const std::vector<std::pair<Line, Line>> cases = {
      {{30, 5}, {30, 5}}, {{45, 5}, {12, 5}}, {{12, 5}, {45, 5}}, {{27, 8}, {27, 2}},
      {{3, 2}, {60, 8}},  {{1, 5}, {1, 5}},   {{1, 5}, {33, 5}},  {{90, 5}, {1, 2}}};
  for (const auto& [la, lb] : cases) {
    std::vector<double> fa = random_band(la.n, la.w, rng);
    std::vector<double> fb = random_band(lb.n, lb.w, rng);
    ASSERT_TRUE(band::cholesky(fa.data(), la.n, la.w));
    ASSERT_TRUE(band::cholesky(fb.data(), lb.n, lb.w));
    const std::vector<double> ba = random_vector(la.n, rng);
    const std::vector<double> bb = random_vector(lb.n, rng);
    std::vector<double> single_a = ba, single_b = bb, pair_a = ba, pair_b = bb;
    band::solve(fa.data(), la.n, la.w, single_a.data());
    band::solve(fb.data(), lb.n, lb.w, single_b.data());
    band::solve_pair(fa.data(), la.n, la.w, pair_a.data(), fb.data(), lb.n, lb.w, pair_b.data());
    EXPECT_EQ(0, std::memcmp(single_a.data(), pair_a.data(), single_a.size() * sizeof(double)))
        << "line a: n " << la.n << " w " << la.w << " beside n " << lb.n << " w " << lb.w;
    EXPECT_EQ(0, std::memcmp(single_b.data(), pair_b.data(), single_b.size() * sizeof(double)))
        << "line b: n " << lb.n << " w " << lb.w << " beside n " << la.n << " w " << la.w;
  }
}

}  // namespace
}  // namespace clothbench
