// Known answers for the overhead columns of a sweep (MODEL.md section 7, the paper's Table 2):
// loops whose work is made up by the test run through the kernel's loop runner and the
// sweep's accounting, and the figures must come out as the test built them - the chunk count
// of dynamic:k is ceil(n/k), a deliberately skewed loop shows the load imbalance it was given,
// and a delay inserted after the scheduler's barrier lands in the parallel overhead.
// The loops are timed by a clock the test moves itself (`LoopTimes::clock`): a body advances
// its thread's time by the work the test gives it, and the threads leave a loop at the latest
// of their times, as from a barrier. So the answers are exact and no assertion depends on how
// fast or how loaded the machine is; timings themselves belong to the benchmarks.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <atomic>
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

/// The team every test here runs.
constexpr int kTeam = 2;

/// Each thread's time on the test's clock (seconds). Whole numbers of seconds throughout, so
/// every sum the accounting forms is exact.
std::array<std::atomic<double>, kTeam> virtual_time;

double virtual_clock() {
  return virtual_time[static_cast<std::size_t>(omp_get_thread_num())].load(
      std::memory_order_relaxed);
}

/// The calling thread works `seconds` on the test's clock.
void work(double seconds) {
  std::atomic<double>& t = virtual_time[static_cast<std::size_t>(omp_get_thread_num())];
  t.store(t.load(std::memory_order_relaxed) + seconds, std::memory_order_relaxed);
}

/// Runs another driver's loops, then holds every thread `delay` seconds (a barrier that
/// much slower; 0 for a plain one) and lets the team leave at the latest of their times, as
/// threads leave a barrier.
class VirtualBarrierDriver final : public schedulers::LoopDriver {
 public:
  VirtualBarrierDriver(std::unique_ptr<schedulers::LoopDriver> inner, double delay)
      : inner_(std::move(inner)), delay_(delay) {}
  void for_range(std::int64_t n, schedulers::RangeBody body) override {
    inner_->for_range(n, body);
    work(delay_);
#pragma omp barrier
    double latest = 0.0;
    for (int t = 0; t < omp_get_num_threads(); ++t) {
      latest = std::max(latest,
                        virtual_time[static_cast<std::size_t>(t)].load(std::memory_order_relaxed));
    }
#pragma omp barrier
    virtual_time[static_cast<std::size_t>(omp_get_thread_num())].store(latest,
                                                                       std::memory_order_relaxed);
  }
  [[nodiscard]] schedulers::IterationSpace space() const override { return inner_->space(); }
  [[nodiscard]] std::string name() const override { return inner_->name() + "+virtual-barrier"; }

 private:
  std::unique_ptr<schedulers::LoopDriver> inner_;
  double delay_;
};

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

/// Runs `loops(runner)` on the team through `driver` with `level`, timed by the test's clock
/// from 0; returns the accounting of the loop times (wall and step clocks set to the loops'
/// wall time).
harness::OverheadAccounting account_loops(schedulers::LoopDriver& driver, Instrumentation level,
                                          const std::function<void(kernels::LoopRunner&)>& loops) {
  const kernels::ClothMesh& mesh = some_mesh();
  kernels::LoopTimes times;
  times.resize(kTeam);
  times.clock = virtual_clock;
  for (std::atomic<double>& t : virtual_time) t.store(0.0);
  int team = 0;
#pragma omp parallel num_threads(kTeam)
  {
    kernels::LoopRunner runner(driver, mesh, nullptr, level, &times);
    loops(runner);
#pragma omp single
    team = omp_get_num_threads();
  }
  EXPECT_EQ(team, kTeam) << "the runtime gave fewer threads than asked";
  return harness::account(times, times.loop_wall, times.loop_wall);
}

TEST(OverheadKnownAnswer, DynamicKRunsCeilNOverKChunks) {
  for (const Instrumentation level : {Instrumentation::loops, Instrumentation::chunks}) {
    for (const int k : {1, 2, 3, 7}) {
      const auto driver = schedulers::make_driver("dynamic:" + std::to_string(k));
      for (const std::int64_t n : {1, 10, 17, 100}) {
        const harness::OverheadAccounting a =
            account_loops(*driver, level, [&](kernels::LoopRunner& run) {
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
      account_loops(*fixed, Instrumentation::chunks,
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
  // missing). Each thread's recorded work must be the work of the bodies it ran. taskloop:1
  // makes tasks of one or two iterations; which thread runs which task is the runtime's
  // choice, so each body also holds its thread a moment of real time (not measured), long
  // enough for the other thread to take tasks, and the test is repeated until both did.
  VirtualBarrierDriver team_driver(schedulers::make_driver("taskloop:1"), 0.0);
  const std::int64_t n = 24;
  bool both_ran = false;
  for (int attempt = 0; attempt < 10 && !both_ran; ++attempt) {
    std::array<std::atomic<int>, kTeam> bodies{};  // bodies run by each thread
    const harness::OverheadAccounting a =
        account_loops(team_driver, Instrumentation::chunks, [&](kernels::LoopRunner& run) {
          for (int loop = 0; loop < 3; ++loop) {
            run.for_index(n, {}, [&](std::int64_t) {
              const double until = kernels::monotonic_seconds() + 0.0005;
              while (kernels::monotonic_seconds() < until) {
              }
              work(1.0);
              ++bodies[static_cast<std::size_t>(omp_get_thread_num())];
            });
          }
        });
    EXPECT_EQ(a.loops, 3);
    EXPECT_GE(a.chunks, 3 * n / 2);
    EXPECT_LE(a.chunks, 3 * n);
    EXPECT_EQ(bodies[0] + bodies[1], 3 * n);
    for (std::size_t t = 0; t < kTeam; ++t) {
      EXPECT_EQ(a.thread_work[t], static_cast<double>(bodies[t])) << "thread " << t;
    }
    both_ran = bodies[0] > 0 && bodies[1] > 0;
  }
  EXPECT_TRUE(both_ran)
      << "one thread ran every task in 10 attempts: the attribution was not tested";
}

TEST(OverheadKnownAnswer, InstrumentOffRecordsNothing) {
  const auto driver = schedulers::make_driver("dynamic:2");
  std::int64_t visited = 0;
  const harness::OverheadAccounting a =
      account_loops(*driver, Instrumentation::off, [&](kernels::LoopRunner& run) {
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

TEST(OverheadKnownAnswer, ASkewedLoopShowsTheImbalanceItWasGiven) {
  // static over 2 iterations on 2 threads: thread 0 gets iteration 0 (1 s of work), thread 1
  // iteration 1 (3 s). Per loop the busiest thread works 3 s, the mean is 2 s: the imbalance
  // is 1 s (50 %), the parallel work 2 s, and the team leaves when the busiest is done, so
  // there is no parallel overhead.
  VirtualBarrierDriver driver(schedulers::make_driver("static"), 0.0);
  const int loops = 4;
  for (const Instrumentation level : {Instrumentation::loops, Instrumentation::chunks}) {
    const harness::OverheadAccounting a =
        account_loops(driver, level, [&](kernels::LoopRunner& run) {
          for (int l = 0; l < loops; ++l) {
            run.for_index(2, {}, [&](std::int64_t k) { work(k == 0 ? 1.0 : 3.0); });
          }
        });
    EXPECT_EQ(a.load_imbalance, 1.0 * loops);
    EXPECT_EQ(a.parallel_work, 2.0 * loops);
    EXPECT_EQ(a.imbalance_percent, 50.0);
    EXPECT_EQ(a.parallel_overhead, 0.0);
    EXPECT_EQ(a.thread_work, (std::vector<double>{1.0 * loops, 3.0 * loops}));
    EXPECT_EQ(a.loops, loops);
    EXPECT_EQ(a.chunks, 2 * loops);
  }
}

TEST(OverheadKnownAnswer, ASlowerBarrierShowsAsParallelOverhead) {
  // The same balanced loops (1 s on each thread) with a plain barrier and with one 4 s slower:
  // the parallel overhead grows by the delay of every loop, the work and the imbalance do not.
  const int loops = 5;
  const double delay = 4.0;
  auto balanced = [&](kernels::LoopRunner& run) {
    for (int l = 0; l < loops; ++l) run.for_index(2, {}, [](std::int64_t) { work(1.0); });
  };
  for (const Instrumentation level : {Instrumentation::loops, Instrumentation::chunks}) {
    VirtualBarrierDriver plain(schedulers::make_driver("static"), 0.0);
    VirtualBarrierDriver slow(schedulers::make_driver("static"), delay);
    const harness::OverheadAccounting before = account_loops(plain, level, balanced);
    const harness::OverheadAccounting after = account_loops(slow, level, balanced);
    EXPECT_EQ(before.parallel_overhead, 0.0);
    EXPECT_EQ(after.parallel_overhead, delay * loops);
    EXPECT_EQ(after.load_imbalance, before.load_imbalance);
    EXPECT_EQ(before.load_imbalance, 0.0);
    EXPECT_EQ(after.parallel_work, before.parallel_work);
    EXPECT_EQ(before.parallel_work, 1.0 * loops);
  }
}

}  // namespace
}  // namespace clothbench
