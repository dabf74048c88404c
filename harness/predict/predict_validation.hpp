// `clothbench predict --validate SWEEP.json --trace-dir DIR` (issue 17): every measured row of
// a sweep predicted from a 1-thread trace of the same sweep (`sweep --trace DIR` writes
// DIR/<scheduler>-<threads>t.cbtrace), beside its measured time and imbalance.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "harness/predict/bandwidth_model.hpp"
#include "harness/predict/overhead_model.hpp"

namespace clothbench::harness {

/// One sweep row, predicted and measured.
struct ValidationRow {
  std::string scheduler;  ///< canonical spec
  int threads = 1;
  std::string source;  ///< the trace it was predicted from (file name)
  double predicted_time = 0.0;
  double measured_time = 0.0;
  double error_percent = 0.0;  ///< 100 (predicted - measured) / measured
  double predicted_imbalance_percent = 0.0;
  std::optional<double> measured_imbalance_percent;  ///< none when the sweep was not instrumented
  bool disturbed = false;  ///< the sweep labelled the row DISTURBED (other work took the cores)
  /// Busy time of the row's own P-thread trace (every thread's chunks) over that of the same
  /// scheduler's 1-thread trace, when trace_dir holds both: above 1 the loops themselves ran slower
  /// split over P threads (shared caches or core, lines bouncing between threads), which a
  /// replay of 1-thread costs cannot know.
  std::optional<double> work_ratio;
  /// The sweep's core-to-core round trip before and after the row (ns; 0: not measured, e.g.
  /// at 1 thread or in an older sweep): where the host had put the cores (core_round_trip.hpp).
  double round_trip_before_ns = 0.0;
  double round_trip_after_ns = 0.0;
  std::int64_t bandwidth_bound_loops = 0;  ///< loop instances the bandwidth ceiling lengthened
  double bandwidth_added_seconds = 0.0;    ///< what it added to the predicted time
};

/// The whole validation.
struct Validation {
  std::string sweep_file;
  std::string machine_load;  ///< the sweep's load average at its start, as recorded
  std::vector<ValidationRow> rows;
  std::vector<std::string> skipped;  ///< rows that could not be predicted, with the reason
  std::vector<std::string> notes;    ///< e.g. traces whose loop times could not be combined
  OverheadModel overheads;
  BandwidthModel bandwidth;
};

/// Predicts every row of `sweep` (a loaded sweep document) that has a measured time. The
/// source trace of a row: `from` when given, else the 1-thread trace in `trace_dir` with the
/// most chunks over the row's iteration space (the finest per-iteration costs), else one over
/// blocks; without `from`, that trace takes its loop times from the trace of the same space
/// with the fewest chunks (take_loop_times), when that one has fewer. Costs: `overheads` when
/// given, else each source trace's stored ones, else zero (Validation::overheads: those of the
/// first row); the bandwidth ceiling likewise from `bandwidth` or the traces' stored triad. Throws
/// std::invalid_argument when `trace_dir` holds no readable 1-thread trace.
Validation validate_prediction(const nlohmann::json& sweep, const std::string& sweep_file,
                               const std::filesystem::path& trace_dir,
                               const std::optional<std::filesystem::path>& from,
                               const std::optional<OverheadModel>& overheads,
                               const std::optional<BandwidthModel>& bandwidth = std::nullopt);

/// Markdown table of the validation, with the mean and largest |error|.
std::string format_validation_markdown(const Validation& validation);
/// The same as JSON.
nlohmann::json validation_json(const Validation& validation);

}  // namespace clothbench::harness
