// Median, bootstrap interval, Mann-Whitney U and LB4OMP imbalance (compare_statistics.hpp).
#include "harness/compare/compare_statistics.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <random>
#include <stdexcept>

namespace clothbench::harness {

double median(std::vector<double> values) {
  if (values.empty()) throw std::invalid_argument("median of an empty sample");
  const std::size_t n = values.size();
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(n / 2);
  std::nth_element(values.begin(), middle, values.end());
  if (n % 2 == 1) return *middle;
  const double upper = *middle;
  const double lower = *std::max_element(values.begin(), middle);
  return 0.5 * (lower + upper);
}

namespace {

/// A uniform index in [0, n) from `generator`, by rejection (the same on every library).
std::size_t uniform_index(std::mt19937_64& generator, std::size_t n) {
  const std::uint64_t bound = n;
  const std::uint64_t threshold = (0 - bound) % bound;  // 2^64 mod bound
  std::uint64_t r = 0;
  do {
    r = generator();
  } while (r < threshold);
  return static_cast<std::size_t>(r % bound);
}

/// The q-quantile of sorted values, interpolating linearly between order statistics.
double quantile(const std::vector<double>& sorted, double q) {
  const double h = q * static_cast<double>(sorted.size() - 1);
  const auto low = static_cast<std::size_t>(std::floor(h));
  const std::size_t high = std::min(low + 1, sorted.size() - 1);
  return sorted[low] + (h - static_cast<double>(low)) * (sorted[high] - sorted[low]);
}

}  // namespace

Interval bootstrap_ratio_of_medians(const std::vector<double>& a, const std::vector<double>& b,
                                    int resamples, std::uint64_t seed, double level) {
  if (a.empty() || b.empty() || resamples < 1) {
    throw std::invalid_argument("bootstrap: empty sample or no resamples");
  }
  std::mt19937_64 generator(seed);
  std::vector<double> ratios;
  ratios.reserve(static_cast<std::size_t>(resamples));
  std::vector<double> resample_a(a.size()), resample_b(b.size());
  for (int r = 0; r < resamples; ++r) {
    for (double& v : resample_a) v = a[uniform_index(generator, a.size())];
    for (double& v : resample_b) v = b[uniform_index(generator, b.size())];
    const double denominator = median(resample_a);
    if (!(denominator > 0.0)) throw std::invalid_argument("bootstrap: a median of A is not > 0");
    ratios.push_back(median(resample_b) / denominator);
  }
  std::sort(ratios.begin(), ratios.end());
  return {quantile(ratios, (1.0 - level) / 2.0), quantile(ratios, (1.0 + level) / 2.0)};
}

namespace {

/// P(U >= k) under the null for sample sizes m and n without ties: counts[i][j][u] of the
/// orderings of i x's and j y's with U = u, by the recurrence on the largest element (an x
/// above all j y's adds j, a y adds nothing), over C(m + n, m).
double exact_upper_tail(std::size_t m, std::size_t n, double k) {
  const std::size_t top = m * n;
  // counts for the current i (rows j = 0..n), built from those of i - 1.
  std::vector<std::vector<double>> previous(n + 1, std::vector<double>(top + 1, 0.0));
  for (auto& row : previous) row[0] = 1.0;  // i = 0: one ordering, U = 0
  for (std::size_t i = 1; i <= m; ++i) {
    std::vector<std::vector<double>> current(n + 1, std::vector<double>(top + 1, 0.0));
    current[0][0] = 1.0;
    for (std::size_t j = 1; j <= n; ++j) {
      for (std::size_t u = 0; u <= top; ++u) {
        current[j][u] = current[j - 1][u] + (u >= j ? previous[j][u - j] : 0.0);
      }
    }
    previous = std::move(current);
  }
  const std::vector<double>& counts = previous[n];
  const double total = std::accumulate(counts.begin(), counts.end(), 0.0);
  double tail = 0.0;
  for (std::size_t u = 0; u <= top; ++u) {
    if (static_cast<double>(u) >= k) tail += counts[u];
  }
  return tail / total;
}

}  // namespace

MannWhitneyResult mann_whitney_u(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.empty() || y.empty()) throw std::invalid_argument("Mann-Whitney U of an empty sample");
  MannWhitneyResult result;
  for (double xi : x) {
    for (double yj : y) result.u_x += xi > yj ? 1.0 : (xi == yj ? 0.5 : 0.0);
  }
  const double nx = static_cast<double>(x.size()), ny = static_cast<double>(y.size());
  result.u_y = nx * ny - result.u_x;
  const double u = std::max(result.u_x, result.u_y);

  std::map<double, int> multiplicity;  // tie groups of the pooled sample
  for (double v : x) ++multiplicity[v];
  for (double v : y) ++multiplicity[v];
  double tie_sum = 0.0;  // sum of t^3 - t over tie groups
  for (const auto& [value, t] : multiplicity) tie_sum += std::pow(t, 3) - t;

  if (tie_sum == 0.0 && x.size() + y.size() <= kMannWhitneyExactLimit) {
    result.method = MannWhitneyMethod::exact;
    result.p_value = std::min(1.0, 2.0 * exact_upper_tail(x.size(), y.size(), u));
    return result;
  }
  result.method = MannWhitneyMethod::normal;
  const double n = nx + ny;
  const double variance = nx * ny / 12.0 * ((n + 1.0) - tie_sum / (n * (n - 1.0)));
  if (!(variance > 0.0)) {
    result.p_value = 1.0;  // every value tied: no evidence either way
    return result;
  }
  const double z = (u - nx * ny / 2.0 - 0.5) / std::sqrt(variance);
  result.p_value = std::min(1.0, std::erfc(z / std::sqrt(2.0)));  // 2 x the normal upper tail
  return result;
}

std::optional<double> lb4omp_percent_imbalance(const std::vector<double>& thread_work) {
  if (thread_work.size() < 2) return std::nullopt;
  const double p = static_cast<double>(thread_work.size());
  const double max = *std::max_element(thread_work.begin(), thread_work.end());
  if (!(max > 0.0)) return std::nullopt;
  const double mean = std::accumulate(thread_work.begin(), thread_work.end(), 0.0) / p;
  return (max - mean) / max * p / (p - 1.0) * 100.0;
}

}  // namespace clothbench::harness
