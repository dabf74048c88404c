// The disturbance criteria (harness/run/disturbance.hpp) on counters made up for the purpose:
// each criterion marks a run on its own, the thresholds scale with the threads (1 to 128
// alike), an oversubscribed run's own preemptions are not held against it, and a row with a
// disturbed run is DISTURBED in the table and gets no speed-up.
// The core-to-core round trip (harness/run/core_round_trip.hpp): measured, and what counts as
// a change of the cores' placement.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <cmath>

#include "harness/machine/machine_context.hpp"
#include "harness/report/sweep_table.hpp"
#include "harness/run/core_round_trip.hpp"
#include "harness/run/disturbance.hpp"

namespace clothbench {
namespace {

using harness::assess_disturbance;
using harness::ResourceSample;
using ::testing::HasSubstr;

/// Counters of a run of `wall` seconds that used `cpu` CPU seconds and was preempted
/// `switches` times, with the load average `load` before and after.
std::pair<ResourceSample, ResourceSample> run_of(double wall, double cpu, long switches,
                                                 double load = 0.1) {
  ResourceSample before{100.0, 5.0, 1000, load};
  ResourceSample after{100.0 + wall, 5.0 + cpu, 1000 + switches, load};
  return {before, after};
}

TEST(Disturbance, AQuietRunIsNotDisturbedAtAnyThreadCount) {
  for (int threads : {1, 2, 8, 32, 128}) {
    // 30 preemptions per second per core and every core busy: what a quiet machine shows.
    const auto [b, a] = run_of(2.0, 2.0 * threads, 60L * threads);
    const harness::Disturbance d = assess_disturbance(b, a, threads, 128, "active");
    EXPECT_FALSE(d.disturbed) << threads << ::testing::PrintToString(d.reasons);
    EXPECT_NEAR(d.cpu_share, 1.0, 1e-12);
    EXPECT_NEAR(d.switch_rate, 30.0, 1e-9);
  }
}

TEST(Disturbance, PreemptionsByAnotherProcessMarkTheRunAtAnyThreadCount) {
  for (int threads : {1, 2, 8, 32, 128}) {
    const auto [b, a] = run_of(2.0, 2.0 * threads, 260L * threads);  // 130 per core-second
    const harness::Disturbance d = assess_disturbance(b, a, threads, 128, "passive");
    EXPECT_TRUE(d.disturbed) << threads;
    ASSERT_EQ(d.reasons.size(), 1u);
    EXPECT_THAT(d.reasons[0], HasSubstr("involuntary context switches (130 per second per core"));
  }
  // A short run's handful of switches is no evidence.
  const auto [b, a] = run_of(0.01, 0.01, 5);
  EXPECT_FALSE(assess_disturbance(b, a, 1, 2, "passive").disturbed);
}

TEST(Disturbance, LostCpuTimeMarksTheRunOnlyWithSpinningWaits) {
  const auto [b, a] = run_of(2.0, 2.4, 10);  // 2 threads, 60 % of 2 cores
  const harness::Disturbance active = assess_disturbance(b, a, 2, 2, "active");
  EXPECT_TRUE(active.disturbed);
  ASSERT_EQ(active.reasons.size(), 1u);
  EXPECT_THAT(active.reasons[0], HasSubstr("is 60 % of wall x 2 cores"));
  // Waiting threads sleep under passive and default waits: a load imbalance looks the same.
  EXPECT_FALSE(assess_disturbance(b, a, 2, 2, "passive").disturbed);
  EXPECT_FALSE(assess_disturbance(b, a, 2, 2, "unset").disturbed);
}

TEST(Disturbance, ALoadAboveTheHardwareBeforeAndAfterMarksTheRun) {
  const auto [b, a] = run_of(1.0, 1.0, 0, 3.0);
  const harness::Disturbance d = assess_disturbance(b, a, 1, 2, "unset");
  EXPECT_TRUE(d.disturbed);
  ASSERT_EQ(d.reasons.size(), 1u);
  EXPECT_THAT(d.reasons[0], HasSubstr("load average 3.00 before and 3.00 after"));
  // Below hardware + 0.5 it is this run's own threads and those of a quiet machine.
  const auto [b2, a2] = run_of(1.0, 1.0, 0, 2.4);
  EXPECT_FALSE(assess_disturbance(b2, a2, 2, 2, "unset").disturbed);
}

TEST(Disturbance, AnOversubscribedRunsOwnPreemptionsAreNotHeldAgainstIt) {
  // 4 threads on 2 hardware threads preempt each other: recorded, not judged.
  const auto [b, a] = run_of(1.0, 2.0, 400);
  const harness::Disturbance d = assess_disturbance(b, a, 4, 2, "passive");
  EXPECT_TRUE(d.oversubscribed);
  EXPECT_EQ(d.usable_cores, 2);
  EXPECT_FALSE(d.disturbed) << ::testing::PrintToString(d.reasons);
  EXPECT_EQ(d.involuntary_switches, 400);
}

TEST(Disturbance, ADisturbedRowGetsNoSpeedupAndIsLabelled) {
  using nlohmann::json;
  auto row = [](int threads, double time, bool disturbed) {
    return json{{"scheduler", "static"}, {"scheduler_canonical", "static@blocks"},
                {"note", ""}, {"threads", threads}, {"oversubscribed", false},
                {"time_seconds", {{"median", time}, {"min", time}, {"max", time},
                                  {"samples", {time}}}},
                {"instrumented", {{"level", "off"}, {"time_seconds", nullptr},
                                  {"cost_seconds", nullptr}, {"cost_percent", nullptr}}},
                {"accounting", nullptr},
                {"verification", {{"passed", true}, {"failures", json::array()}}},
                {"disturbance", {{"disturbed", disturbed}, {"disturbed_runs", disturbed ? 1 : 0},
                                 {"runs", 1}, {"reruns", 2}, {"records", json::array()}}},
                {"derived", json::object()}};
  };
  json document = {{"scene", {{"name", "s"}, {"file", "s.toml"}, {"hash", "0"}}},
                   {"settings", {{"schedulers", {"static"}}, {"steps", 1}, {"repeat", 1},
                                 {"instrument", "off"}, {"retries", 2},
                                 {"omp_wait_policy", "passive"}}},
                   {"machine", json::object()},
                   {"rows", {row(1, 2.0, false), row(2, 1.0, true), row(4, 0.6, false)}}};
  harness::add_derived(document);
  EXPECT_DOUBLE_EQ(document["rows"][0]["derived"]["speedup"].get<double>(), 1.0);
  EXPECT_TRUE(document["rows"][1]["derived"]["speedup"].is_null());
  EXPECT_NEAR(document["rows"][2]["derived"]["speedup"].get<double>(), 2.0 / 0.6, 1e-12);
  const std::string md = harness::format_markdown(document);
  EXPECT_THAT(md, HasSubstr("| - | - | - | PASSED | DISTURBED (1 of 1 runs) |"));
  EXPECT_THAT(md, HasSubstr("| PASSED | clean |"));
  EXPECT_THAT(md, HasSubstr("OMP_WAIT_POLICY `passive`"));
  EXPECT_THAT(harness::format_csv(document), HasSubstr(",,,,PASSED,DISTURBED (1 of 1 runs)\n"));

  // A disturbed 1-thread row is no baseline: no row of its scheduler gets a speed-up.
  document["rows"][0]["disturbance"]["disturbed"] = true;
  harness::add_derived(document);
  EXPECT_TRUE(document["rows"][2]["derived"]["speedup"].is_null());
}

TEST(CoreRoundTrip, MeasuredOnTwoHardwareThreadsAndAChangeIsMoreThanTwofold) {
  const double ns = harness::core_round_trip_ns(50, 3);
  if (harness::hardware_threads() >= 2) {
    EXPECT_GT(ns, 0.0);  // measured (its size is the machine's, not the test's business)
    EXPECT_TRUE(std::isfinite(ns));
  } else {
    EXPECT_EQ(ns, 0.0);
  }
  EXPECT_TRUE(harness::round_trip_changed(80.0, 380.0));
  EXPECT_TRUE(harness::round_trip_changed(380.0, 80.0));
  EXPECT_FALSE(harness::round_trip_changed(80.0, 150.0));
  EXPECT_FALSE(harness::round_trip_changed(0.0, 380.0));  // one not measured
}

}  // namespace
}  // namespace clothbench
