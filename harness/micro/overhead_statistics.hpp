// Statistics of the scheduling-overhead micro-benchmark (scheduling_overhead.cpp), after the
// method of EPCC schedbench: one overhead sample per outer repetition, summarised by the mean
// with a 95% interval (mean +- 1.96 sample standard deviations), the median, and a count of
// outliers (samples further than 3 standard deviations from the mean). Header-only, so the
// benchmark and the unit tests (tests/harness/unit_overhead_statistics.cpp) share one copy.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace clothbench::micro {

/// Summary of the overhead samples of one benchmark (the unit of the samples, e.g. us).
struct OverheadSummary {
  int samples = 0;       ///< number of samples (outer repetitions)
  double mean = 0.0;     ///< arithmetic mean
  double sigma = 0.0;    ///< sample standard deviation (divisor n - 1; 0 for one sample)
  double low95 = 0.0;    ///< mean - 1.96 sigma
  double high95 = 0.0;   ///< mean + 1.96 sigma
  double median = 0.0;   ///< middle sample; mean of the two middle ones for an even count
  double minimum = 0.0;  ///< smallest sample
  double maximum = 0.0;  ///< largest sample
  int outliers = 0;      ///< samples with |sample - mean| > 3 sigma
};

/// Width of the 95% interval in standard deviations (normal distribution).
inline constexpr double kInterval95Sigmas = 1.96;
/// A sample further than this many standard deviations from the mean is an outlier.
inline constexpr double kOutlierSigmas = 3.0;

/// Summarises `samples` (at least one; throws std::invalid_argument when empty).
inline OverheadSummary summarize_overheads(std::vector<double> samples) {
  if (samples.empty()) throw std::invalid_argument("summarize_overheads: no samples");
  OverheadSummary s;
  s.samples = static_cast<int>(samples.size());
  double sum = 0.0;
  for (double x : samples) sum += x;
  s.mean = sum / static_cast<double>(samples.size());
  double squares = 0.0;
  for (double x : samples) squares += (x - s.mean) * (x - s.mean);
  s.sigma = samples.size() > 1 ? std::sqrt(squares / static_cast<double>(samples.size() - 1)) : 0.0;
  s.low95 = s.mean - kInterval95Sigmas * s.sigma;
  s.high95 = s.mean + kInterval95Sigmas * s.sigma;
  for (double x : samples) {
    if (std::abs(x - s.mean) > kOutlierSigmas * s.sigma) ++s.outliers;
  }
  std::sort(samples.begin(), samples.end());
  const std::size_t middle = samples.size() / 2;
  s.median =
      samples.size() % 2 == 1 ? samples[middle] : 0.5 * (samples[middle - 1] + samples[middle]);
  s.minimum = samples.front();
  s.maximum = samples.back();
  return s;
}

/// Overhead of one dispatch: the per-loop overhead divided by the dispatches on one thread's
/// path, i.e. the loop's `chunks` (counted over all threads) shared among `threads`. With
/// fewer chunks than threads, every chunk-holding thread dispatched once: the divisor is 1.
/// Throws std::invalid_argument unless chunks >= 1 and threads >= 1.
inline double per_chunk_overhead(double per_loop, std::int64_t chunks, int threads) {
  if (chunks < 1 || threads < 1) {
    throw std::invalid_argument("per_chunk_overhead: needs chunks >= 1 and threads >= 1");
  }
  const double per_thread = static_cast<double>(chunks) / static_cast<double>(threads);
  return per_loop / std::max(1.0, per_thread);
}

}  // namespace clothbench::micro
