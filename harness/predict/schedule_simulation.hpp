// How a scheduler hands the iterations of one loop to P threads, replayed on a virtual clock
// (issue 17, "The predictor"). Our own partitioners (fac2, tss, gss, active-lists) use the
// chunk rules of schedulers/ themselves; the OpenMP clauses follow the runtime's documented
// algorithm: static = contiguous shares, the first n % P threads one more (libgomp; libomp
// 14 splits the same way), static,k = chunk j to thread j % P, dynamic,k = the next free
// thread takes the next k, guided,k = max(k, ceil(R / P)) (libgomp's gomp_iter_guided_next;
// libomp's guided is modelled the same way and says so).
// A thread that takes a chunk first pays the dispatch cost, then the chunk's work; a free
// thread is the one whose clock is earliest (ties: the lowest thread number).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "harness/predict/trace_workload.hpp"
#include "schedulers/registry.hpp"

namespace clothbench::harness {

/// The OpenMP runtime whose clause algorithms are modelled.
enum class OmpRuntimeModel { libgomp, libomp };

/// A scheduler spec the predictor can replay; throws std::invalid_argument naming the spec
/// for one it cannot (runtime, taskloop: their assignment is not ours to know).
struct ScheduleModel {
  schedulers::SchedulerSpec spec;
  OmpRuntimeModel runtime = OmpRuntimeModel::libgomp;

  static ScheduleModel parse(const std::string& text, OmpRuntimeModel runtime);
  [[nodiscard]] std::string name() const { return spec.canonical(); }
  /// True when chunk j goes to a thread fixed in advance (static, static,k, active-lists).
  [[nodiscard]] bool fixed_assignment() const;
};

/// One chunk of a simulated loop.
struct SimulatedChunk {
  int thread = 0;
  std::int64_t begin = 0;
  std::int64_t end = 0;
};

/// A simulated loop: each thread's work (chunk costs only), its finish time (dispatch costs
/// and work from the loop's start), and, when asked for, the chunks in grab order.
struct LoopSimulation {
  std::vector<double> thread_work;
  double makespan = 0.0;  ///< the last thread's finish
  std::int64_t chunks = 0;
  std::vector<SimulatedChunk> assignment;
};

/// Simulates `model` over the iterations of `costs` with `threads` threads and
/// `dispatch_seconds` per chunk; every thread but the first starts the loop `start_delay`
/// seconds after it (the fork's wake-up: under a self-scheduled clause the first thread takes
/// chunks meanwhile, under a fixed assignment the late threads' shares end later);
/// `keep_assignment` fills LoopSimulation::assignment.
LoopSimulation simulate_loop(const ScheduleModel& model, const IterationCosts& costs, int threads,
                             double dispatch_seconds, bool keep_assignment = false,
                             double start_delay = 0.0);

}  // namespace clothbench::harness
