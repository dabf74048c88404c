// Conformance of every scheduling backend (Taskflow test_partitioners.cpp model): each
// index of [0, n) is visited exactly once, over awkward n x chunk x thread-count grids;
// body ranges are non-empty and in bounds; many consecutive calls in one parallel region
// (changing n, including 0) neither lose nor repeat work (the counter-reset protocol),
// and no thread leaves a call while its ranges still run (the closing barrier); calls
// outside any parallel region work.
//
// CLOTHBENCH_CONFORMANCE_QUICK=1 shrinks the grids (used by scripts/tsan-check).
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "schedulers/active_lists_partitioner.hpp"
#include "schedulers/omp_schedule_partitioner.hpp"
#include "schedulers/partitioner.hpp"
#include "schedulers/registry.hpp"
#include "schedulers/self_scheduling_partitioners.hpp"
#include "schedulers/taskloop_partitioner.hpp"

namespace clothbench::schedulers {
namespace {

bool quick_mode() {
  const char* value = std::getenv("CLOTHBENCH_CONFORMANCE_QUICK");
  return value != nullptr && std::string(value) == "1";
}

std::vector<int> thread_counts() {
  if (quick_mode()) return {1, 2, 4};
  return {1, 2, 3, 4, 5, 6, 7, 8};
}

std::vector<std::int64_t> loop_sizes() {
  if (quick_mode()) return {0, 1, 7, 99, 1000};
  return {0, 1, 7, 99, 1000, 100003};
}

// One run-sched-var value for the `runtime` backends (as omp_set_schedule takes it).
struct RuntimeSchedule {
  omp_sched_t kind;
  int chunk;
  const char* label;
};

// One conformance case: a spec, and for runtime specs the run-sched-var to use.
struct ConformanceCase {
  std::string spec;
  std::optional<RuntimeSchedule> runtime;
};

// Readable test parameters in failure messages.
void PrintTo(const ConformanceCase& test_case, std::ostream* stream) {
  *stream << test_case.spec;
  if (test_case.runtime) *stream << " with run-sched-var " << test_case.runtime->label;
}

std::vector<ConformanceCase> conformance_cases() {
  std::vector<std::string> specs = available_schedulers();
  for (const auto& [preset, canonical] : scheduler_presets()) specs.push_back(preset);
  for (const char* kind : {"static", "dynamic", "guided", "taskloop", "fac2", "tss", "gss"}) {
    for (int chunk : {1, 3, 64, 200000})
      specs.push_back(std::string(kind) + ":" + std::to_string(chunk));
  }
  for (const char* modifier : {"monotonic:", "nonmonotonic:"}) {
    for (const char* clause : {"static:1", "static:7", "dynamic:1", "dynamic:7", "guided:3"}) {
      specs.push_back(std::string(modifier) + clause);
    }
  }
  for (const char* spec :
       {"fac2:4@active", "tss:2@active", "gss:8@active", "active-lists@blocks"}) {
    specs.emplace_back(spec);
  }
  const auto monotonic = [](omp_sched_t kind) {
    return static_cast<omp_sched_t>(static_cast<unsigned>(kind) |
                                    static_cast<unsigned>(omp_sched_monotonic));
  };
  const std::vector<RuntimeSchedule> runtime_schedules{
      {omp_sched_static, 0, "static"},
      {omp_sched_static, 3, "static_3"},
      {omp_sched_dynamic, 1, "dynamic_1"},
      {omp_sched_dynamic, 7, "dynamic_7"},
      {omp_sched_guided, 2, "guided_2"},
      {omp_sched_auto, 0, "auto"},
      {monotonic(omp_sched_dynamic), 2, "monotonic_dynamic_2"},
      {monotonic(omp_sched_static), 0, "monotonic_static"}};
  std::vector<ConformanceCase> cases;
  for (const std::string& spec : specs) {
    if (parse_scheduler_spec(spec).kind != "runtime") {
      cases.push_back({spec, std::nullopt});
      continue;
    }
    for (const RuntimeSchedule& schedule : runtime_schedules) cases.push_back({spec, schedule});
  }
  return cases;
}

std::string case_name(const testing::TestParamInfo<ConformanceCase>& info) {
  std::string name = info.param.spec;
  if (info.param.runtime) name += std::string("_with_") + info.param.runtime->label;
  for (char& c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  }
  return name + "_" + std::to_string(info.index);
}

// Visit counters of one loop plus the bounds check of every range.
class VisitRecord {
 public:
  explicit VisitRecord(std::int64_t n) : n_(n), visits_(static_cast<std::size_t>(n)) {}
  void visit(std::int64_t begin, std::int64_t end) {
    if (begin < 0 || end > n_ || begin >= end) {
      bad_range_.store(true, std::memory_order_relaxed);
      return;
    }
    for (std::int64_t i = begin; i < end; ++i)
      visits_[static_cast<std::size_t>(i)].fetch_add(1, std::memory_order_relaxed);
  }
  // Empty when every index was visited once and every range was valid.
  [[nodiscard]] std::string problems() const {
    if (bad_range_.load()) return "a range was empty or outside [0, " + std::to_string(n_) + ")";
    for (std::size_t i = 0; i < visits_.size(); ++i) {
      if (const int count = visits_[i].load(); count != 1) {
        return "index " + std::to_string(i) + " of " + std::to_string(n_) + " visited " +
               std::to_string(count) + " times";
      }
    }
    return {};
  }

 private:
  std::int64_t n_;
  std::vector<std::atomic<int>> visits_;
  std::atomic<bool> bad_range_{false};
};

class SchedulerConformance : public testing::TestWithParam<ConformanceCase> {
 protected:
  void SetUp() override {
    omp_get_schedule(&saved_kind_, &saved_chunk_);
    if (GetParam().runtime) omp_set_schedule(GetParam().runtime->kind, GetParam().runtime->chunk);
    driver_ = make_driver(GetParam().spec);
  }
  void TearDown() override { omp_set_schedule(saved_kind_, saved_chunk_); }

  std::unique_ptr<LoopDriver> driver_;

 private:
  omp_sched_t saved_kind_{};
  int saved_chunk_ = 0;
};

TEST_P(SchedulerConformance, NameIsCanonicalAndRoundTrips) {
  EXPECT_EQ(driver_->name(), parse_scheduler_spec(GetParam().spec).canonical());
  EXPECT_EQ(make_driver(driver_->name())->name(), driver_->name());
}

TEST_P(SchedulerConformance, EveryIndexExactlyOnceOverThreadAndSizeGrid) {
  for (const int threads : thread_counts()) {
    for (const std::int64_t n : loop_sizes()) {
      VisitRecord record(n);
      auto body = [&record](std::int64_t begin, std::int64_t end) { record.visit(begin, end); };
#pragma omp parallel num_threads(threads)
      driver_->for_range(n, body);
      EXPECT_EQ(record.problems(), "") << "threads=" << threads << " n=" << n;
    }
  }
}

TEST_P(SchedulerConformance, ConsecutiveCallsInOneRegionResetSafely) {
  // Sizes change from call to call, with empty loops and loops smaller than the team.
  std::vector<std::int64_t> sizes;
  const int calls = quick_mode() ? 24 : 96;
  for (int call = 0; call < calls; ++call) {
    const std::int64_t pattern[] = {0, 1000, 3, 0, 0, 257, 1, 99, 8, 0, 4096, 17};
    sizes.push_back(pattern[call % 12] + (call / 12));
  }
  for (const int threads : thread_counts()) {
    std::vector<std::unique_ptr<VisitRecord>> records;
    for (const std::int64_t n : sizes) records.push_back(std::make_unique<VisitRecord>(n));
    // returned[c] counts threads that have left call c; a body of call c running after
    // that means the call did not end with a barrier.
    std::vector<std::atomic<int>> returned(sizes.size());
    std::atomic<int> late_bodies{0};
#pragma omp parallel num_threads(threads)
    for (std::size_t call = 0; call < sizes.size(); ++call) {
      auto body = [&, call](std::int64_t begin, std::int64_t end) {
        if (returned[call].load(std::memory_order_acquire) != 0) late_bodies.fetch_add(1);
        records[call]->visit(begin, end);
      };
      driver_->for_range(sizes[call], body);
      returned[call].fetch_add(1, std::memory_order_release);
    }
    EXPECT_EQ(late_bodies.load(), 0) << "threads=" << threads;
    for (std::size_t call = 0; call < sizes.size(); ++call) {
      EXPECT_EQ(records[call]->problems(), "")
          << "threads=" << threads << " call=" << call << " n=" << sizes[call];
    }
  }
}

TEST_P(SchedulerConformance, WorksOutsideAnyParallelRegion) {
  for (const std::int64_t n : loop_sizes()) {
    for (int repeat = 0; repeat < 3; ++repeat) {
      VisitRecord record(n);
      auto body = [&record](std::int64_t begin, std::int64_t end) { record.visit(begin, end); };
      driver_->for_range(n, body);
      EXPECT_EQ(record.problems(), "") << "n=" << n << " repeat=" << repeat;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(EveryBackend, SchedulerConformance, testing::ValuesIn(conformance_cases()),
                         case_name);

// Chunked static and dynamic clauses call the body once per chunk, [c k, (c + 1) k),
// as soon as the chunk is handed out: never merged with the next chunk, never deferred.
TEST(OmpScheduleChunks, BodyRunsOncePerWholeChunk) {
  for (const char* spec : {"dynamic:1", "dynamic:3", "static:4", "nonmonotonic:dynamic:5",
                           "monotonic:dynamic:2", "monotonic:static:3"}) {
    const std::unique_ptr<LoopDriver> driver = make_driver(spec);
    const std::int64_t chunk = parse_scheduler_spec(spec).chunk;
    for (const int threads : thread_counts()) {
      constexpr std::int64_t n = 1001;
      std::atomic<int> wrong_ranges{0};
      auto body = [&](std::int64_t begin, std::int64_t end) {
        if (begin % chunk != 0 || end != std::min(n, begin + chunk)) wrong_ranges.fetch_add(1);
      };
#pragma omp parallel num_threads(threads)
      for (int repeat = 0; repeat < 3; ++repeat) driver->for_range(n, body);
      EXPECT_EQ(wrong_ranges.load(), 0) << spec << " threads=" << threads;
    }
  }
}

// The hot loops used directly (no type erasure), with an rvalue lambda body.
template <class P>
std::unique_ptr<P> make_partitioner();
template <>
std::unique_ptr<OmpSchedulePartitioner> make_partitioner() {
  return std::make_unique<OmpSchedulePartitioner>(OmpScheduleKind::dynamic_schedule,
                                                  OmpScheduleModifier::none, 5);
}
template <>
std::unique_ptr<TaskloopPartitioner> make_partitioner() {
  return std::make_unique<TaskloopPartitioner>(3);
}
template <>
std::unique_ptr<Factoring2Partitioner> make_partitioner() {
  return std::make_unique<Factoring2Partitioner>(1);
}
template <>
std::unique_ptr<TrapezoidPartitioner> make_partitioner() {
  return std::make_unique<TrapezoidPartitioner>(1);
}
template <>
std::unique_ptr<GuidedSelfSchedulingPartitioner> make_partitioner() {
  return std::make_unique<GuidedSelfSchedulingPartitioner>(2);
}
template <>
std::unique_ptr<ActiveListsPartitioner> make_partitioner() {
  return std::make_unique<ActiveListsPartitioner>();
}

template <class P>
class PartitionerHotLoop : public testing::Test {};
using PartitionerTypes =
    testing::Types<OmpSchedulePartitioner, TaskloopPartitioner, Factoring2Partitioner,
                   TrapezoidPartitioner, GuidedSelfSchedulingPartitioner, ActiveListsPartitioner>;
TYPED_TEST_SUITE(PartitionerHotLoop, PartitionerTypes);

TYPED_TEST(PartitionerHotLoop, SatisfiesConceptAndVisitsEachIndexOnce) {
  static_assert(Partitioner<TypeParam>);
  const std::unique_ptr<TypeParam> partitioner = make_partitioner<TypeParam>();
  for (const int threads : thread_counts()) {
    VisitRecord first(1000);
    VisitRecord second(31);
#pragma omp parallel num_threads(threads)
    {
      partitioner->loop(
          1000, [&first](std::int64_t begin, std::int64_t end) { first.visit(begin, end); });
      partitioner->loop(
          31, [&second](std::int64_t begin, std::int64_t end) { second.visit(begin, end); });
    }
    EXPECT_EQ(first.problems(), "") << "threads=" << threads;
    EXPECT_EQ(second.problems(), "") << "threads=" << threads;
  }
}

// The self-scheduling chunk sequences follow their definitions (one thread, so chunks
// arrive in grab order).
std::vector<std::int64_t> chunk_sizes_single_thread(auto& partitioner, std::int64_t n) {
  std::vector<std::int64_t> sizes;
  partitioner.loop(
      n, [&sizes](std::int64_t begin, std::int64_t end) { sizes.push_back(end - begin); });
  return sizes;
}

TEST(SelfSchedulingChunks, FollowTheirDefinitions) {
  Factoring2Partitioner factoring(1);
  // P = 1: batches of one chunk of ceil(R / 2).
  EXPECT_EQ(chunk_sizes_single_thread(factoring, 20), (std::vector<std::int64_t>{10, 5, 3, 1, 1}));
  TrapezoidPartitioner trapezoid(1);
  // f = 50, l = 1, N = ceil(200 / 51) = 4, d = floor(49 / 3) = 16: 50, 34, then 18 clipped to 16.
  EXPECT_EQ(chunk_sizes_single_thread(trapezoid, 100), (std::vector<std::int64_t>{50, 34, 16}));
  GuidedSelfSchedulingPartitioner guided(2);
  EXPECT_EQ(chunk_sizes_single_thread(guided, 7), (std::vector<std::int64_t>{7}));
}

}  // namespace
}  // namespace clothbench::schedulers
