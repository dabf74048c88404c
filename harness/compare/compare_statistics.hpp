// Statistics of `clothbench compare`: the median of a sample, a percentile-bootstrap 95 %
// interval of the ratio of two medians, the two-sided Mann-Whitney U test (as Google
// Benchmark's tools/gbench/report.py uses it, there through scipy.stats.mannwhitneyu) and
// LB4OMP's percent imbalance of per-thread work times.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

namespace clothbench::harness {

/// Median of `values` (mean of the two middle values for an even count; this is not the
/// sweep table's lower-middle median). Requires a non-empty sample.
double median(std::vector<double> values);

/// An interval [low, high].
struct Interval {
  double low = 0.0;
  double high = 0.0;
};

/// Percentile-bootstrap interval of median(b) / median(a): `resamples` times, each sample is
/// resampled with replacement independently (its own size), the ratio of the resampled
/// medians is taken, and the interval is the (1-level)/2 and (1+level)/2 quantiles of those
/// ratios (linear interpolation between order statistics). The generator is std::mt19937_64
/// seeded with `seed`, indices drawn by rejection (no std::uniform_int_distribution, whose
/// output differs between standard libraries), so the interval is the same on every build.
/// Requires non-empty samples with a positive median of `a` in every resample (times > 0).
Interval bootstrap_ratio_of_medians(const std::vector<double>& a, const std::vector<double>& b,
                                    int resamples = 10000, std::uint64_t seed = 20240617,
                                    double level = 0.95);

/// How a Mann-Whitney p-value was obtained.
enum class MannWhitneyMethod { exact, normal };

/// The two-sided Mann-Whitney U test of samples x and y.
struct MannWhitneyResult {
  double u_x = 0.0;  ///< U of x: pairs (x_i, y_j) with x_i > y_j, plus half the ties
  double u_y = 0.0;  ///< U of y = n_x n_y - u_x
  double p_value = 1.0;
  MannWhitneyMethod method = MannWhitneyMethod::exact;
};

/// Largest n_x + n_y for which the exact distribution is used (when there are no ties).
inline constexpr std::size_t kMannWhitneyExactLimit = 40;

/// Two-sided Mann-Whitney U test. Exact (the null distribution of U enumerated by the usual
/// recurrence; p = min(1, 2 P(U >= max(u_x, u_y)))) when no value occurs twice in the pooled
/// sample and n_x + n_y <= kMannWhitneyExactLimit; otherwise the normal approximation with
/// the tie correction of the variance and a continuity correction of 0.5, as
/// scipy.stats.mannwhitneyu(method="asymptotic", use_continuity=True). p = 1 when every value
/// is tied. Requires non-empty samples.
MannWhitneyResult mann_whitney_u(const std::vector<double>& x, const std::vector<double>& y);

/// LB4OMP's percent imbalance of per-thread work times w (P = w.size() threads):
/// (max - mean) / max x P / (P - 1) x 100; 0 when every thread worked the same, 100 when one
/// thread did all the work. nullopt when P < 2 (undefined) or max <= 0.
std::optional<double> lb4omp_percent_imbalance(const std::vector<double>& thread_work);

}  // namespace clothbench::harness
