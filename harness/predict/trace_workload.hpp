// The work a traced run did, as the schedule predictor replays it (issue 17, "The
// predictor"): for every parallel loop instance the cost of each iteration of its iteration
// space, rebuilt from the recorded chunks, and the sequential time between the loops.
//
// A chunk's duration is spread evenly over the iterations it covered (the trace holds no
// finer timing), so a trace with one iteration per chunk (dynamic:1, guided:1 over blocks)
// gives each block its own cost, while a 1-thread static trace gives every block of a loop
// the same. The element counts carry a trace over blocks to the Active-Lists' space: the
// entries of a block's live elements follow each other in list order (kernels/loop_runner.hpp),
// so a chunk of E live elements and duration D becomes E entries of D / E each.
// A loop instance's bytes are its recorded bytes per element (kernels/loop_bytes.hpp) times the
// elements its chunks visited: the same in either space.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "harness/predict/bandwidth_model.hpp"
#include "harness/predict/overhead_model.hpp"
#include "harness/trace/trace_file.hpp"
#include "schedulers/loop_driver.hpp"

namespace clothbench::harness {

/// The per-iteration cost of one loop instance as a step function: segment s covers
/// iterations [start[s], start[s+1]) at cost[s] / (start[s+1] - start[s]) seconds each.
class IterationCosts {
 public:
  /// Appends a segment of `iterations` iterations costing `seconds` in total (zero-length
  /// segments are ignored).
  void add(std::int64_t iterations, double seconds);
  /// Iterations covered.
  [[nodiscard]] std::int64_t size() const { return start_.empty() ? 0 : start_.back(); }
  /// Seconds of iterations [begin, end) (0 <= begin <= end <= size()).
  [[nodiscard]] double range(std::int64_t begin, std::int64_t end) const;
  /// Seconds of all iterations: the segments' sum, in the order they were added.
  [[nodiscard]] double total() const { return cumulative_.empty() ? 0.0 : cumulative_.back(); }
  /// Multiplies every segment's cost by `factor` (>= 0).
  void scale(double factor);

 private:
  [[nodiscard]] double prefix(std::int64_t i) const;
  std::vector<std::int64_t> start_;  // segment starts, then the end (size segments + 1)
  std::vector<double> cumulative_;   // seconds before each segment start (size segments + 1)
};

/// One parallel loop instance of the trace.
struct TracedLoop {
  std::int32_t site = 0;  ///< index into the header's sites
  int kind = -1;          ///< element kind (0-3), -1 for index loops
  std::int32_t step = 0;
  IterationCosts costs;       ///< over the trace's own iteration space
  IterationCosts active;      ///< over the Active-Lists' space (from a trace over blocks)
  double span_seconds = 0.0;  ///< the traced run's loop span (entry to exit over all threads)
  double dropped_for_active_seconds = 0.0;  ///< busy seconds of chunks without a live element
  /// Unavoidable bytes the instance moves (bytes per element x elements); negative when the
  /// trace does not record them (format 1).
  double bytes = -1.0;
};

/// A trace prepared for replay.
struct TraceWorkload {
  std::string scheduler;  ///< the traced run's scheduler (canonical spec)
  int threads = 1;        ///< the traced run's team size
  std::string scene;
  std::string openmp_runtime;  ///< "libgomp", "libomp", ... ("unknown" when not recorded)
  int machine_cores = 0;       ///< cores of the traced machine (0: not recorded)
  std::string wait_policy = "not recorded";  ///< the traced run's OMP_WAIT_POLICY
  schedulers::IterationSpace space = schedulers::IterationSpace::blocks;
  std::vector<TracedLoop> loops;
  double busy_seconds = 0.0;        ///< sum of all chunk durations
  double run_seconds = 0.0;         ///< the traced steps' time (header cost.run_seconds)
  double loop_span_seconds = 0.0;   ///< sum of the loop spans
  double sequential_seconds = 0.0;  ///< run_seconds - loop_span_seconds (outside the loops)
  /// Busy seconds of chunks over blocks without a live element: dropped in the Active-Lists'
  /// space, which never visits those blocks.
  double dropped_for_active_seconds = 0.0;
  /// The scheduling costs the trace's header stores (`run|sweep --trace-overheads`), if any.
  std::optional<OverheadModel> stored_overheads;
  /// The triad the trace's header stores (`run|sweep --trace-bandwidth`), if any.
  std::optional<BandwidthModel> stored_bandwidth;
  std::int64_t loops_without_bytes = 0;  ///< loop instances whose bytes are not recorded
  /// When take_loop_times replaced the loops' times: the trace they came from, else empty.
  std::string loop_times_from;
};

/// Takes every loop instance's time, the loop spans and the time outside loops from `totals`,
/// a trace of the same run with fewer chunks, and keeps only how `fine` split each loop's time
/// over its iterations (each instance's costs scaled to `totals`'s busy time of the instance).
/// Recording a chunk costs time inside and between chunks (clock reads, the record, its cache
/// lines: ~50-130 ns a chunk on the 2-core VM), which a trace of one chunk per block (dynamic:1
/// or guided:1 at 1 thread, the finest split) adds hundreds of thousands of times; a static
/// trace (one chunk per thread and loop) adds it once per loop. Throws std::invalid_argument
/// naming both files when they are not traces of the same run (loop instances, steps, sites or
/// iteration counts differ) or not over the same iteration space.
void take_loop_times(TraceWorkload& fine, const TraceWorkload& totals, const std::string& fine_name,
                     const std::string& totals_name);

/// The costs a prediction from `workload` uses: `given` (--overheads) when set, else the
/// trace's stored ones, else zero (each model's source text says which).
OverheadModel choose_overheads(const std::optional<OverheadModel>& given,
                               const TraceWorkload& workload);
/// Likewise the bandwidth: `given` (--bandwidth), else the trace's stored triad, else none.
BandwidthModel choose_bandwidth(const std::optional<BandwidthModel>& given,
                                const TraceWorkload& workload);

/// Builds the workload of `trace`; throws std::invalid_argument naming `name` (the file) when
/// the trace is inconsistent (a chunk outside its loop, ranges that do not tile a loop).
TraceWorkload build_workload(const TraceDocument& trace, const std::string& name);

}  // namespace clothbench::harness
