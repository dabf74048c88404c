// Comparing two sweep documents row by row (`clothbench compare A.json B.json`): rows are
// matched by (scheduler_canonical, threads); for each matched row the ratio of medians B/A of
// the timed repetitions with a bootstrap 95 % interval, a two-sided Mann-Whitney U p-value,
// a verdict, and both documents' imbalance figures. Output as a Markdown table or JSON
// (`clothbench.compare`, schema_version 1).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "harness/compare/compare_statistics.hpp"

namespace clothbench::harness {

/// Settings of a comparison.
struct CompareOptions {
  double alpha = 0.05;      ///< significance level of the Mann-Whitney test, in (0, 1)
  double threshold = 0.05;  ///< relative slow-down that counts as a regression, >= 0
  int resamples = 10000;    ///< bootstrap resamples
  std::uint64_t seed = 20240617;
};

/// Repetitions below which a row is flagged: Google Benchmark's compare.py calls 9 the
/// optimal count for its U test; with fewer, a real difference is often not significant.
inline constexpr std::size_t kRecommendedRepetitions = 9;

/// What the comparison concludes about one row.
enum class CompareVerdict {
  slower,         ///< significant (p < alpha) and B's times tend to be larger
  faster,         ///< significant and B's times tend to be smaller
  no_difference,  ///< not significant at alpha
  failed,         ///< the row failed verification in A or B: not compared
  disturbed,      ///< the row was DISTURBED in A or B: figures shown, not judged
  only_in_a,      ///< unmatched: the row is only in A
  only_in_b,      ///< unmatched: the row is only in B
};

/// The verdict's label in tables and JSON: "slower", "faster", "same", "FAILED",
/// "DISTURBED", "only in A", "only in B".
std::string to_string(CompareVerdict verdict);

/// One row of the comparison. Figures that do not apply are nullopt.
struct RowComparison {
  std::string scheduler;  ///< scheduler_canonical
  int threads = 0;
  std::size_t repetitions_a = 0, repetitions_b = 0;
  std::optional<double> median_a, median_b;  ///< seconds (mean of middle two when even)
  std::optional<double> ratio;               ///< median_b / median_a
  std::optional<Interval> interval;          ///< bootstrap 95 % interval of the ratio
  std::optional<MannWhitneyResult> test;
  CompareVerdict verdict = CompareVerdict::no_difference;
  bool regression = false;       ///< slower with ratio > 1 + threshold: fails the exit code
  bool few_repetitions = false;  ///< fewer than kRecommendedRepetitions in A or B
  /// clothbench's imbalance (100 (busiest / mean - 1), accounting.imbalance_percent) and
  /// LB4OMP's percent imbalance of accounting.thread_work_seconds, in A and B.
  std::optional<double> imbalance_a, imbalance_b, lb4omp_a, lb4omp_b;
  std::vector<std::string> notes;  ///< why a row is skipped or flagged
};

/// The whole comparison.
struct Comparison {
  std::string file_a, file_b;
  std::string about_a, about_b;  ///< scene, steps, created, build revision
  CompareOptions options;
  std::vector<RowComparison> rows;    ///< A's row order, then the rows only in B
  std::vector<std::string> warnings;  ///< documents of different scenes or step counts
  [[nodiscard]] int regressions() const;
};

/// Compares two validated sweep documents (load_sweep_document). Rows are matched by
/// (scheduler_canonical, threads).
Comparison compare_sweeps(const nlohmann::json& a, const nlohmann::json& b,
                          const std::string& file_a, const std::string& file_b,
                          const CompareOptions& options);

/// The comparison as Markdown: a heading, the method, one table line per row, a summary.
std::string format_comparison_markdown(const Comparison& comparison);

/// The comparison as a `clothbench.compare` JSON document.
nlohmann::json comparison_json(const Comparison& comparison);

}  // namespace clothbench::harness
