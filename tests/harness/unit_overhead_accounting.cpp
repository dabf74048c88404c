// Known answers for the overhead columns of a sweep (MODEL.md section 7, the paper's Table 2):
// loops whose work is made up by the test run through the kernel's loop runner and the
// sweep's accounting, and the figures must come out as the test built them - the chunk count
// of dynamic:k is ceil(n/k), a deliberately skewed loop shows the load imbalance it was given,
// and a delay inserted after the scheduler's barrier lands in the parallel overhead.
// Timings are compared with what the same test measured inside its loop bodies (never with
// absolute numbers), with generous margins, and a timing test passes when one of a few
// attempts agrees: a loaded machine can preempt a thread inside any single attempt.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "harness/sweep/measured_run.hpp"
#include "kernels/loop_runner.hpp"
#include "kernels/simulation.hpp"
#include "schedulers/registry.hpp"

namespace clothbench {
namespace {

using kernels::Instrumentation;
using kernels::monotonic_seconds;

/// Spins until `seconds` have passed on the monotonic clock (a preempted spin still ends on
/// time, unless it is preempted at its end); returns the time it took.
double spin(double seconds) {
  const double start = monotonic_seconds();
  double now = start;
  while (now < start + seconds) now = monotonic_seconds();
  return now - start;
}

/// Any mesh: the loops below run over indices (for_index), not over elements, and declare no
/// bytes (LoopBytes {}: nothing here reads the trace).
const kernels::ClothMesh& some_mesh() {
  static const kernels::Simulation simulation{[] {
    kernels::SimulationConfig c;
    c.cloth.particles_i = 9;
    c.cloth.particles_j = 7;
    c.cloth.block_size = 4;
    return c;
  }()};
  return simulation.mesh();
}

/// Runs `loops(runner)` on `threads` threads through `driver` with `level`; returns the
/// accounting of the loop times (wall and step clocks set to the loops' wall time).
harness::OverheadAccounting account_loops(schedulers::LoopDriver& driver, int threads,
                                          Instrumentation level,
                                          const std::function<void(kernels::LoopRunner&)>& loops) {
  const kernels::ClothMesh& mesh = some_mesh();
  kernels::LoopTimes times;
  times.resize(threads);
  int team = 0;
#pragma omp parallel num_threads(threads)
  {
    kernels::LoopRunner runner(driver, mesh, nullptr, level, &times);
    loops(runner);
#pragma omp single
    team = omp_get_num_threads();
  }
  EXPECT_EQ(team, threads) << "the runtime gave fewer threads than asked";
  return harness::account(times, times.loop_wall, times.loop_wall);
}

/// Up to `attempts` tries of `attempt`, which returns "" when its figures agree and a
/// description otherwise; passes on the first agreement.
void expect_within_attempts(int attempts, const std::function<std::string()>& attempt) {
  std::string log;
  for (int k = 0; k < attempts; ++k) {
    const std::string problem = attempt();
    if (problem.empty()) return;
    log += "attempt " + std::to_string(k + 1) + ": " + problem + "\n";
  }
  ADD_FAILURE() << "no attempt agreed:\n" << log;
}

/// True when `value` is within `fraction` of `expected` (relative).
bool near(double value, double expected, double fraction) {
  return std::abs(value - expected) <= fraction * std::abs(expected);
}

TEST(OverheadKnownAnswer, DynamicKRunsCeilNOverKChunks) {
  for (const Instrumentation level : {Instrumentation::loops, Instrumentation::chunks}) {
    for (const int k : {1, 2, 3, 7}) {
      const auto driver = schedulers::make_driver("dynamic:" + std::to_string(k));
      for (const std::int64_t n : {1, 10, 17, 100}) {
        const harness::OverheadAccounting a =
            account_loops(*driver, 2, level, [&](kernels::LoopRunner& run) {
              run.for_index(n, {}, [](std::int64_t) {});
              run.for_index(n, {}, [](std::int64_t) {});
              run.for_index(n, {}, [](std::int64_t) {});
            });
        EXPECT_EQ(a.loops, 3);
        EXPECT_EQ(a.chunks, 3 * ((n + k - 1) / k)) << "dynamic:" << k << ", n = " << n;
      }
    }
  }
  // static without a chunk: one contiguous share per thread.
  const auto fixed = schedulers::make_driver("static");
  EXPECT_EQ(
      account_loops(*fixed, 2, Instrumentation::chunks,
                    [](kernels::LoopRunner& run) { run.for_index(100, {}, [](std::int64_t) {}); })
          .chunks,
      2);
}

TEST(OverheadKnownAnswer, TaskloopCountsEachChunkOnTheThreadThatRanIt) {
  // Under taskloop one thread creates the tasks and every thread of the team runs them: a
  // chunk's work and count belong to the thread that ran it (they went to the creating
  // thread's locals before, written from two threads at once, so each loop's work showed on
  // its creator). A thread may run the next loop's first tasks before it reaches that loop,
  // so nothing it counted may be reset at a loop's entry (tried: a third of the chunks went
  // missing). Each thread's recorded work is compared with what the bodies it ran measured
  // themselves, so a loaded machine (a spin preempted runs long) changes both alike.
  // taskloop:1 makes tasks of one or two iterations.
  const auto driver = schedulers::make_driver("taskloop:1");
  const std::int64_t n = 24;
  const double unit = 0.0005;
  expect_within_attempts(3, [&]() -> std::string {
    std::vector<double> measured(2, 0.0);  // entry t written only by thread t
    const harness::OverheadAccounting a =
        account_loops(*driver, 2, Instrumentation::chunks, [&](kernels::LoopRunner& run) {
          for (int loop = 0; loop < 3; ++loop) {
            run.for_index(n, {}, [&](std::int64_t) {
              measured[static_cast<std::size_t>(omp_get_thread_num())] += spin(unit);
            });
          }
        });
    if (a.loops != 3 || a.chunks < 3 * n / 2 || a.chunks > 3 * n) {
      return "loops " + std::to_string(a.loops) + ", chunks " + std::to_string(a.chunks) +
             " (want 3 loops and " + std::to_string(3 * n / 2) + ".." + std::to_string(3 * n) +
             " chunks)";
    }
    const double total = measured[0] + measured[1];
    for (std::size_t t = 0; t < 2; ++t) {
      if (!(std::abs(a.thread_work[t] - measured[t]) <= 0.1 * total)) {
        return "thread " + std::to_string(t) + " recorded " + std::to_string(a.thread_work[t]) +
               " s of work, its bodies measured " + std::to_string(measured[t]) + " s (of " +
               std::to_string(total) + " s)";
      }
    }
    if (!(measured[0] > 0.0 && measured[1] > 0.0)) {
      return "one thread ran no task: the attribution was not tested";
    }
    return "";
  });
}

TEST(OverheadKnownAnswer, InstrumentOffRecordsNothing) {
  const auto driver = schedulers::make_driver("dynamic:2");
  std::int64_t visited = 0;
  const harness::OverheadAccounting a =
      account_loops(*driver, 2, Instrumentation::off, [&](kernels::LoopRunner& run) {
        run.for_index(50, {}, [&](std::int64_t) {
#pragma omp atomic
          ++visited;
        });
      });
  EXPECT_EQ(visited, 50) << "the loop itself runs";
  EXPECT_EQ(a.loops, 0);
  EXPECT_EQ(a.chunks, 0);
  EXPECT_EQ(a.parallel_overhead, 0.0);
  EXPECT_EQ(a.load_imbalance, 0.0);
  EXPECT_EQ(a.parallel_work, 0.0);
}

/// Work (seconds) of iteration `k` of the skewed loop: iteration 1 does three times the work
/// of iteration 0.
double skewed_work(std::int64_t k, double unit) { return k == 0 ? unit : 3.0 * unit; }

TEST(OverheadKnownAnswer, ASkewedLoopShowsTheImbalanceItWasGiven) {
  // static over 2 iterations on 2 threads: thread 0 gets iteration 0 (1 unit), thread 1
  // iteration 1 (3 units). Per loop the busiest thread works 3 units, the mean is 2: the
  // imbalance is 1 unit (50 %), the parallel work 2 units.
  const auto driver = schedulers::make_driver("static");
  const double unit = 0.01;
  const int loops = 4;
  for (const Instrumentation level : {Instrumentation::loops, Instrumentation::chunks}) {
    expect_within_attempts(5, [&]() -> std::string {
      std::vector<double> took(2 * loops, 0.0);  // what each body measured, per loop
      const harness::OverheadAccounting a =
          account_loops(*driver, 2, level, [&](kernels::LoopRunner& run) {
            for (int l = 0; l < loops; ++l) {
              run.for_index(2, {}, [&](std::int64_t k) {
                took[static_cast<std::size_t>(2 * l + k)] = spin(skewed_work(k, unit));
              });
            }
          });
      // The known answer from what the bodies measured: sum over loops of max - mean.
      double imbalance = 0.0, work = 0.0, busiest = 0.0;
      for (int l = 0; l < loops; ++l) {
        const double t0 = took[static_cast<std::size_t>(2 * l)], t1 = took[static_cast<std::size_t>(2 * l + 1)];
        imbalance += std::max(t0, t1) - 0.5 * (t0 + t1);
        work += 0.5 * (t0 + t1);
        busiest += std::max(t0, t1);
      }
      const double percent = 100.0 * (busiest / work - 1.0);
      if (near(a.load_imbalance, imbalance, 0.25) && near(a.parallel_work, work, 0.25) &&
          near(a.imbalance_percent, percent, 0.25) && a.loops == loops && a.chunks == 2 * loops) {
        return "";
      }
      return "imbalance " + std::to_string(a.load_imbalance) + " s vs " + std::to_string(imbalance) +
             " s, work " + std::to_string(a.parallel_work) + " s vs " + std::to_string(work) +
             " s, " + std::to_string(a.imbalance_percent) + " % vs " + std::to_string(percent) +
             " %, loops " + std::to_string(a.loops) + ", chunks " + std::to_string(a.chunks);
    });
  }
}

/// Runs another driver's loops, then holds every thread `delay` seconds after its closing
/// barrier: a barrier that is `delay` slower. Records the delays thread 0 spent.
class SlowBarrierDriver final : public schedulers::LoopDriver {
 public:
  SlowBarrierDriver(std::unique_ptr<schedulers::LoopDriver> inner, double delay)
      : inner_(std::move(inner)), delay_(delay) {}
  void for_range(std::int64_t n, schedulers::RangeBody body) override {
    inner_->for_range(n, body);
    const double took = spin(delay_);
    if (omp_get_thread_num() == 0) delays += took;
  }
  [[nodiscard]] schedulers::IterationSpace space() const override { return inner_->space(); }
  [[nodiscard]] std::string name() const override { return inner_->name() + "+slow-barrier"; }
  double delays = 0.0;

 private:
  std::unique_ptr<schedulers::LoopDriver> inner_;
  double delay_;
};

TEST(OverheadKnownAnswer, ASlowerBarrierShowsAsParallelOverhead) {
  // The same balanced loops with and without a delay after the barrier: the parallel overhead
  // grows by the delay, the work and the imbalance do not.
  const double unit = 0.002, delay = 0.01;
  const int loops = 5;
  auto balanced = [&](kernels::LoopRunner& run) {
    for (int l = 0; l < loops; ++l) run.for_index(2, {}, [&](std::int64_t) { spin(unit); });
  };
  for (const Instrumentation level : {Instrumentation::loops, Instrumentation::chunks}) {
    expect_within_attempts(5, [&]() -> std::string {
      const auto plain = schedulers::make_driver("static");
      SlowBarrierDriver slow(schedulers::make_driver("static"), delay);
      const harness::OverheadAccounting before = account_loops(*plain, 2, level, balanced);
      const harness::OverheadAccounting after = account_loops(slow, 2, level, balanced);
      const double grown = after.parallel_overhead - before.parallel_overhead;
      const double inserted = slow.delays;  // thread 0's share; every thread waited as long
      if (near(grown, inserted, 0.25) &&
          std::abs(after.load_imbalance - before.load_imbalance) <= 0.25 * inserted &&
          std::abs(after.parallel_work - before.parallel_work) <= 0.25 * inserted) {
        return "";
      }
      return "parallel overhead grew by " + std::to_string(grown) + " s for " +
             std::to_string(inserted) + " s inserted; imbalance " +
             std::to_string(before.load_imbalance) + " -> " + std::to_string(after.load_imbalance) +
             " s, work " + std::to_string(before.parallel_work) + " -> " +
             std::to_string(after.parallel_work) + " s";
    });
  }
}

}  // namespace
}  // namespace clothbench
