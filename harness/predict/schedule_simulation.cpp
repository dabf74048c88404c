// Replaying one loop's schedule on a virtual clock (see schedule_simulation.hpp).
#include "harness/predict/schedule_simulation.hpp"

#include <algorithm>
#include <functional>
#include <queue>
#include <stdexcept>
#include <utility>

#include "schedulers/active_lists_partitioner.hpp"
#include "schedulers/self_scheduling_partitioners.hpp"

namespace clothbench::harness {

namespace {

/// Threads by clock, earliest first, ties to the lowest thread number.
class ThreadClocks {
 public:
  explicit ThreadClocks(const std::vector<double>& start) {
    for (std::size_t t = 0; t < start.size(); ++t) queue_.emplace(start[t], static_cast<int>(t));
  }
  /// The next free thread and its clock (removed until put back).
  std::pair<double, int> take() {
    const auto next = queue_.top();
    queue_.pop();
    return next;
  }
  void put(double clock, int thread) { queue_.emplace(clock, thread); }

 private:
  std::priority_queue<std::pair<double, int>, std::vector<std::pair<double, int>>, std::greater<>>
      queue_;
};

}  // namespace

ScheduleModel ScheduleModel::parse(const std::string& text, OmpRuntimeModel runtime) {
  ScheduleModel model;
  model.spec = schedulers::parse_scheduler_spec(text);
  model.runtime = runtime;
  const std::string& k = model.spec.kind;
  if (k != "static" && k != "dynamic" && k != "guided" && k != "fac2" && k != "tss" && k != "gss" &&
      k != "active-lists") {
    throw std::invalid_argument(
        text +
        ": the predictor replays static, static:k, dynamic:k, guided:k, fac2:k, tss:k, "
        "gss:k and active-lists (not runtime or taskloop)");
  }
  return model;
}

bool ScheduleModel::fixed_assignment() const {
  return spec.kind == "static" || spec.kind == "active-lists";
}

LoopSimulation simulate_loop(const ScheduleModel& model, const IterationCosts& costs, int threads,
                             double dispatch_seconds, bool keep_assignment, double start_delay) {
  LoopSimulation out;
  out.thread_work.assign(static_cast<std::size_t>(threads), 0.0);
  std::vector<double> finish(static_cast<std::size_t>(threads), start_delay);
  finish[0] = 0.0;
  const std::int64_t n = costs.size();
  auto run = [&](int thread, std::int64_t begin, std::int64_t end) {
    const double work = costs.range(begin, end);
    const auto t = static_cast<std::size_t>(thread);
    out.thread_work[t] += work;
    finish[t] += dispatch_seconds + work;
    ++out.chunks;
    if (keep_assignment) out.assignment.push_back({thread, begin, end});
    return finish[t];
  };
  const std::string& kind = model.spec.kind;
  const std::int64_t k = std::max<std::int64_t>(model.spec.chunk, 1);

  if ((kind == "static" && model.spec.chunk == 0) || kind == "active-lists") {
    // One contiguous share per thread, decided up front: the first n % P threads get one
    // iteration more (libgomp's static, and libomp 14's, as the recorded traces show).
    for (int t = 0; t < threads; ++t) {
      const auto share = schedulers::contiguous_share(n, t, threads);
      if (share.end > share.begin) run(t, share.begin, share.end);
    }
  } else if (kind == "static") {
    for (std::int64_t j = 0; j * k < n; ++j) {
      run(static_cast<int>(j % threads), j * k, std::min(n, (j + 1) * k));
    }
  } else {
    // Self-scheduled: chunks in grab order, each to the earliest free thread.
    ThreadClocks clocks(finish);
    const schedulers::TrapezoidChunks trapezoid(n, threads, k);
    std::int64_t next = 0;  // first iteration not handed out (dynamic, guided, gss)
    for (std::int64_t j = 0;; ++j) {
      std::int64_t begin = next, end = next;
      if (kind == "fac2") {
        if (!schedulers::factoring2_chunk(j, n, threads, k, begin, end)) break;
      } else if (kind == "tss") {
        if (!trapezoid.bounds(j, n, begin, end)) break;
      } else {
        if (next >= n) break;
        std::int64_t size = k;  // dynamic
        if (kind == "gss") size = schedulers::guided_self_scheduling_size(n - next, threads, k);
        if (kind == "guided") size = std::max(k, (n - next + threads - 1) / threads);
        end = std::min(n, next + size);
        next = end;
      }
      const auto [clock, thread] = clocks.take();
      (void)clock;
      clocks.put(run(thread, begin, end), thread);
    }
  }
  out.makespan = *std::max_element(finish.begin(), finish.end());
  return out;
}

}  // namespace clothbench::harness
