// Run-time identity of the OpenMP library, and the detection of schedule-clause defects
// by the registry's self-test probe. Skip-free: on a runtime without the defect the test
// asserts that the probe passes.
#include <omp.h>

#include <memory>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "schedulers/openmp_runtime.hpp"
#include "schedulers/registry.hpp"
#include "schedulers/self_test.hpp"

namespace clothbench::schedulers {
namespace {

using testing::HasSubstr;

// Clang 14 emits `schedule(monotonic:static)` and `schedule(nonmonotonic:static)` as a
// static schedule type with a modifier bit that libomp 14's __kmpc_for_static_init does
// not strip: every thread then runs the whole loop.
bool expect_static_modifier_defect() {
#if defined(__clang__) && __clang_major__ <= 14
  return openmp_runtime_info().library == "libomp (LLVM)";
#else
  return false;
#endif
}

TEST(OpenmpRuntime, IdentifiesTheLoadedLibrary) {
  const RuntimeInfo info = openmp_runtime_info();
  EXPECT_EQ(info.openmp_macro, _OPENMP);
  EXPECT_FALSE(info.openmp_version.empty());
#if defined(__clang__)
  EXPECT_EQ(info.library, "libomp (LLVM)");
  EXPECT_THAT(info.library_path, HasSubstr("libomp"));
#else
  EXPECT_EQ(info.library, "libgomp (GNU)");
  EXPECT_THAT(info.library_path, HasSubstr("libgomp"));
#endif
  EXPECT_GE(info.max_threads, 1);
  EXPECT_GE(info.num_procs, 1);
  EXPECT_GE(info.thread_limit, 1);
}

TEST(OpenmpRuntime, ReportsTheEffectiveScheduleWithTheMonotonicFlag) {
  omp_sched_t saved_kind{};
  int saved_chunk = 0;
  omp_get_schedule(&saved_kind, &saved_chunk);
  omp_set_schedule(static_cast<omp_sched_t>(omp_sched_dynamic | omp_sched_monotonic), 2);
  EXPECT_EQ(openmp_runtime_info().schedule, "monotonic:dynamic,2");
  omp_set_schedule(omp_sched_guided, 7);
  EXPECT_EQ(openmp_runtime_info().schedule, "guided,7");
  omp_set_schedule(saved_kind, saved_chunk);
}

TEST(OpenmpRuntime, ScheduleAndVersionText) {
  EXPECT_EQ(schedule_text(omp_sched_static, 0), "static");
  EXPECT_EQ(schedule_text(omp_sched_static, 4), "static,4");
  EXPECT_EQ(schedule_text(omp_sched_auto, 3), "auto");
  EXPECT_EQ(schedule_text(static_cast<omp_sched_t>(omp_sched_guided | omp_sched_monotonic), 1),
            "monotonic:guided,1");
  EXPECT_EQ(openmp_version_text(201511), "4.5");
  EXPECT_EQ(openmp_version_text(201811), "5.0");
  EXPECT_EQ(openmp_version_text(123), "123");
}

TEST(OpenmpRuntimeDefects, ProbeDetectsStaticWithModifierExactlyWhereBroken) {
  const bool defect = expect_static_modifier_defect();
  for (const char* spec : {"monotonic:static", "monotonic:static:3", "nonmonotonic:static"}) {
    const std::unique_ptr<LoopDriver> literal = make_driver_without_self_test(spec);
    const ProbeReport report = probe_exactly_once(*literal, 4);
    EXPECT_EQ(report.exactly_once, !defect) << spec << ": " << report.describe();
    if (defect) {
      // Every thread of the team ran the loop: index 0 visited once per thread.
      EXPECT_EQ(report.first_wrong_index, 0) << spec;
      EXPECT_EQ(report.first_wrong_visits, report.threads) << spec;
    }
  }
  EXPECT_EQ(openmp_runtime_info().defects.size(), defect ? 4U : 0U);
}

TEST(OpenmpRuntimeDefects, RegistryWorksAroundTheDefectAndSaysSo) {
  const bool defect = expect_static_modifier_defect();
  for (const char* spec : {"monotonic:static", "nonmonotonic:static:5"}) {
    const std::unique_ptr<LoopDriver> driver = make_driver(spec);
    EXPECT_TRUE(probe_exactly_once(*driver, 4).exactly_once) << spec;
    EXPECT_EQ(driver->name(), parse_scheduler_spec(spec).canonical());
    if (defect) {
      EXPECT_THAT(driver->note(), HasSubstr("runtime defect"));
      EXPECT_THAT(driver->note(), HasSubstr("which OpenMP defines as monotonic"));
    } else {
      EXPECT_EQ(driver->note(), "");
    }
  }
  EXPECT_EQ(make_driver("dynamic:2")->note(), "");
}

TEST(OpenmpRuntimeDefects, ProbeCatchesADriverThatRepeatsWork) {
  // A deliberately broken driver: every thread runs the whole loop.
  class EveryThreadRunsAll final : public LoopDriver {
   public:
    void for_range(std::int64_t n, RangeBody body) override {
      if (n > 0) body(0, n);
#pragma omp barrier
    }
    [[nodiscard]] IterationSpace space() const override { return IterationSpace::blocks; }
    [[nodiscard]] std::string name() const override { return "broken"; }
  } broken;
  const ProbeReport report = probe_exactly_once(broken, 3);
  EXPECT_FALSE(report.exactly_once);
  EXPECT_EQ(report.describe(),
            "index 0 of 1000 visited 3 times with 3 threads (1003 indices wrong)");
}

}  // namespace
}  // namespace clothbench::schedulers
