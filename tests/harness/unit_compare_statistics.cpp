// The statistics of `clothbench compare` (harness/compare/compare_statistics.hpp) against
// hand-computed values, enumerated exact distributions and scipy.stats.mannwhitneyu results
// (scipy 1.10.1, Debian's python3-scipy; the values are quoted, scipy is not needed to test).
#include "harness/compare/compare_statistics.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

namespace {

using clothbench::harness::bootstrap_ratio_of_medians;
using clothbench::harness::lb4omp_percent_imbalance;
using clothbench::harness::mann_whitney_u;
using clothbench::harness::MannWhitneyMethod;
using clothbench::harness::median;

TEST(CompareMedian, OddAndEvenCounts) {
  EXPECT_DOUBLE_EQ(median({3.0, 1.0, 2.0}), 2.0);
  EXPECT_DOUBLE_EQ(median({4.0, 1.0, 3.0, 2.0}), 2.5);  // mean of the middle two
  EXPECT_DOUBLE_EQ(median({7.0}), 7.0);
  EXPECT_THROW(median({}), std::invalid_argument);
}

// scipy.stats.mannwhitneyu([1, 2, 3], [4, 5, 6]) -> U = 0, p = 0.1 (exact: 2 / C(6, 3)).
TEST(CompareMannWhitney, SeparatedSmallSamplesExact) {
  const auto r = mann_whitney_u({1, 2, 3}, {4, 5, 6});
  EXPECT_EQ(r.method, MannWhitneyMethod::exact);
  EXPECT_DOUBLE_EQ(r.u_x, 0.0);
  EXPECT_DOUBLE_EQ(r.u_y, 9.0);
  EXPECT_NEAR(r.p_value, 0.1, 1e-12);
}

// mannwhitneyu([1, 3, 5], [2, 4, 6]) -> U = 3, p = 0.7: of the 20 orderings of three x and
// three y, U = 6, 7, 8, 9 happen 3, 2, 1, 1 times, so P(U >= 6) = 7/20.
TEST(CompareMannWhitney, InterleavedSmallSamplesExact) {
  const auto r = mann_whitney_u({1, 3, 5}, {2, 4, 6});
  EXPECT_DOUBLE_EQ(r.u_x, 3.0);
  EXPECT_NEAR(r.p_value, 0.7, 1e-12);
}

// Ten against ten with every B above every A (the integration test's 1.5x slow-down):
// p = 2 / C(20, 10) = 2 / 184756.
TEST(CompareMannWhitney, TenAgainstTenSeparated) {
  std::vector<double> a(10), b(10);
  std::iota(a.begin(), a.end(), 1.0);
  std::iota(b.begin(), b.end(), 11.0);
  const auto r = mann_whitney_u(a, b);
  EXPECT_EQ(r.method, MannWhitneyMethod::exact);
  EXPECT_NEAR(r.p_value, 2.0 / 184756.0, 1e-15);
  EXPECT_NEAR(mann_whitney_u(b, a).p_value, r.p_value, 1e-15);  // two-sided: symmetric
}

// Every split of {1..7} into 4 x and 3 y: the p-value equals the enumerated two-sided tail
// min(1, 2 #{splits with U' >= max(U_x, U_y)} / 35).
TEST(CompareMannWhitney, ExactPValuesMatchEnumeration) {
  const int m = 4, n = 3;
  std::vector<double> us;  // U_x of every split
  std::vector<std::vector<double>> xs, ys;
  for (int mask = 0; mask < (1 << (m + n)); ++mask) {
    if (__builtin_popcount(static_cast<unsigned>(mask)) != m) continue;
    std::vector<double> x, y;
    for (int v = 0; v < m + n; ++v) ((mask >> v) & 1 ? x : y).push_back(v + 1.0);
    double u = 0.0;
    for (double xi : x)
      u += static_cast<double>(
          std::count_if(y.begin(), y.end(), [&](double yj) { return xi > yj; }));
    us.push_back(u);
    xs.push_back(x);
    ys.push_back(y);
  }
  ASSERT_EQ(us.size(), 35u);
  for (std::size_t k = 0; k < us.size(); ++k) {
    const double big = std::max(us[k], m * n - us[k]);
    const double tail = static_cast<double>(
        std::count_if(us.begin(), us.end(), [&](double u) { return u >= big; }));
    const auto r = mann_whitney_u(xs[k], ys[k]);
    ASSERT_EQ(r.method, MannWhitneyMethod::exact);
    EXPECT_DOUBLE_EQ(r.u_x, us[k]);
    EXPECT_NEAR(r.p_value, std::min(1.0, 2.0 * tail / 35.0), 1e-12) << "split " << k;
  }
}

// Ties: normal approximation with tie and continuity corrections. By hand: U_x = 2.5,
// U = 13.5, tie groups 2 (x3) and 3 (x2) give sum(t^3 - t) = 30, variance 16/12 (9 - 30/56)
// = 11.285714, z = (13.5 - 8 - 0.5) / 3.359422 = 1.488351, p = erfc(z / sqrt 2) = 0.1366582;
// scipy 1.10 stats.mannwhitneyu([1, 2, 2, 3], [2, 3, 4, 5]) gives 0.1366582477 (asymptotic).
TEST(CompareMannWhitney, TiesUseNormalApproximation) {
  const auto r = mann_whitney_u({1, 2, 2, 3}, {2, 3, 4, 5});
  EXPECT_EQ(r.method, MannWhitneyMethod::normal);
  EXPECT_DOUBLE_EQ(r.u_x, 2.5);
  EXPECT_NEAR(r.p_value, 0.1366582477, 1e-9);
}

TEST(CompareMannWhitney, IdenticalSamplesGivePOne) {
  const std::vector<double> a = {1.0, 1.1, 1.2, 1.3};
  EXPECT_DOUBLE_EQ(mann_whitney_u(a, a).p_value, 1.0);
  EXPECT_DOUBLE_EQ(mann_whitney_u({2.0, 2.0}, {2.0, 2.0, 2.0}).p_value, 1.0);  // all tied
}

// Above the exact limit without ties: normal approximation of 21 against 21 separated values,
// U = 441, mean 220.5, variance 21 * 21 * 43 / 12 = 1580.25, z = 220 / 39.752358 = 5.534263,
// p = erfc(z / sqrt 2); scipy 1.10 mannwhitneyu(..., method="asymptotic") gives 3.1253999984e-8.
TEST(CompareMannWhitney, LargeSamplesUseNormalApproximation) {
  std::vector<double> a(21), b(21);
  std::iota(a.begin(), a.end(), 1.0);
  std::iota(b.begin(), b.end(), 100.0);
  const auto r = mann_whitney_u(a, b);
  EXPECT_EQ(r.method, MannWhitneyMethod::normal);
  EXPECT_NEAR(r.p_value, 3.1253999984e-8, 1e-17);
}

TEST(CompareBootstrap, ConstantSamplesGiveThePointRatio) {
  const auto i = bootstrap_ratio_of_medians({2.0, 2.0, 2.0}, {3.0, 3.0, 3.0}, 1000);
  EXPECT_DOUBLE_EQ(i.low, 1.5);
  EXPECT_DOUBLE_EQ(i.high, 1.5);
}

// B = 1.5 A exactly: every resample's ratio lies between min(B)/max(A) and max(B)/min(A),
// the interval contains 1.5, is reproducible for a seed, and changes with the seed.
TEST(CompareBootstrap, IntervalContainsTheRatioAndIsReproducible) {
  const std::vector<double> a = {1.00, 1.02, 0.98, 1.05, 0.97, 1.01, 1.03, 0.99, 1.04, 0.96};
  std::vector<double> b;
  for (double v : a) b.push_back(1.5 * v);
  const auto i = bootstrap_ratio_of_medians(a, b, 10000, 7);
  EXPECT_LT(i.low, i.high);
  EXPECT_LE(i.low, 1.5);
  EXPECT_GE(i.high, 1.5);
  EXPECT_GE(i.low, 1.5 * 0.96 / 1.05);
  EXPECT_LE(i.high, 1.5 * 1.05 / 0.96);
  const auto again = bootstrap_ratio_of_medians(a, b, 10000, 7);
  EXPECT_EQ(i.low, again.low);
  EXPECT_EQ(i.high, again.high);
  const auto other = bootstrap_ratio_of_medians(a, b, 10000, 8);
  EXPECT_TRUE(other.low != i.low || other.high != i.high);
}

// Two values each: a resample's median is one of 1, 1.5, 2 (A) or 2, 3, 4 (B) with
// probabilities 1/4, 1/2, 1/4, so the ratio's 2.5 % quantile is 2 / 2 = 1 and its 97.5 %
// quantile 4 / 1 = 4 (each has probability 1/16 > 2.5 %).
TEST(CompareBootstrap, QuantilesOfATinyDiscreteDistribution) {
  const auto i = bootstrap_ratio_of_medians({1.0, 2.0}, {2.0, 4.0}, 20000, 1);
  EXPECT_DOUBLE_EQ(i.low, 1.0);
  EXPECT_DOUBLE_EQ(i.high, 4.0);
}

// LB4OMP: (max - mean) / max x P / (P - 1) x 100.
TEST(CompareImbalance, Lb4ompPercentImbalance) {
  EXPECT_FALSE(lb4omp_percent_imbalance({5.0}).has_value());  // P = 1: undefined
  EXPECT_FALSE(lb4omp_percent_imbalance({}).has_value());
  EXPECT_DOUBLE_EQ(*lb4omp_percent_imbalance({2.0, 2.0, 2.0}), 0.0);
  EXPECT_DOUBLE_EQ(*lb4omp_percent_imbalance({4.0, 0.0, 0.0, 0.0}), 100.0);  // one did all
  // (4 - 3) / 4 x 2 / 1 x 100 = 50
  EXPECT_DOUBLE_EQ(*lb4omp_percent_imbalance({4.0, 2.0}), 50.0);
}

}  // namespace
