// The schedule predictor (harness/predict, issue 17) on synthetic traces with answers worked
// out by hand: uniform work under static, one heavy iteration under static and dynamic:1,
// dispatch costs per chunk, sequential time, the blocks-to-Active-Lists conversion, the
// overheads file of the scheduling-overhead micro-benchmark (what P threads cost beyond 1
// thread, added above 1 thread only, its stored form and the wait policy it was measured
// under), loop times taken from a coarser trace of the same run, and specs it refuses.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "harness/predict/overhead_model.hpp"
#include "harness/predict/predict_validation.hpp"
#include "harness/predict/prediction.hpp"
#include "harness/predict/schedule_simulation.hpp"
#include "harness/predict/trace_workload.hpp"
#include "tests/harness/clothbench_process.hpp"
#include "tests/harness/synthetic_trace.hpp"

namespace clothbench {
namespace {

using clothbench_test::synthetic_trace;
using harness::OmpRuntimeModel;
using harness::OverheadModel;
using harness::ScheduleModel;

constexpr double kMs = 1e-3;

harness::PredictedRow row(const harness::TraceWorkload& w, const std::string& spec, int threads,
                          const OverheadModel& overheads = {}) {
  return harness::predict_row(w, ScheduleModel::parse(spec, OmpRuntimeModel::libgomp), threads,
                              overheads);
}

TEST(Predict, UniformWorkUnderStaticTakesBusyOverP) {
  const std::vector<double> uniform(12, 2.0);  // 12 iterations of 2 ms
  const auto w = harness::build_workload(synthetic_trace({uniform, uniform}, 5.0), "synthetic");
  EXPECT_NEAR(w.busy_seconds, 48 * kMs, 1e-12);
  EXPECT_NEAR(w.sequential_seconds, 5 * kMs, 1e-12);
  for (int p : {1, 2, 3, 4, 6, 12}) {
    const auto r = row(w, "static", p);
    EXPECT_NEAR(r.time, 5 * kMs + 48 * kMs / p, 1e-12) << p << " threads";
    EXPECT_NEAR(r.load_imbalance, 0.0, 1e-12) << p << " threads";
    EXPECT_NEAR(r.parallel_work, 48 * kMs / p, 1e-12) << p << " threads";
  }
  // 5 threads over 12 iterations: shares 3,3,2,2,2 -> the busiest works 6 ms per loop.
  const auto five = row(w, "static", 5);
  EXPECT_NEAR(five.time, 5 * kMs + 2 * 6 * kMs, 1e-12);
  EXPECT_NEAR(five.load_imbalance, 2 * (6 - 24.0 / 5) * kMs, 1e-12);
}

TEST(Predict, OneHeavyIterationGivesTheImbalanceWorkedOutByHand) {
  const auto w = harness::build_workload(synthetic_trace({{7, 1, 1, 1}}, 0.0), "synthetic");
  // static at 2 threads: [0, 2) = 8 ms, [2, 4) = 2 ms; busiest 8, mean 5.
  const auto s = row(w, "static", 2);
  EXPECT_NEAR(s.time, 8 * kMs, 1e-12);
  EXPECT_NEAR(s.load_imbalance, 3 * kMs, 1e-12);
  EXPECT_NEAR(s.imbalance_percent, 60.0, 1e-9);
  // dynamic:1: thread 0 takes the 7 ms iteration, thread 1 the three of 1 ms.
  const auto d = row(w, "dynamic:1", 2);
  EXPECT_NEAR(d.time, 7 * kMs, 1e-12);
  EXPECT_NEAR(d.imbalance_percent, 40.0, 1e-9);
  // guided:1 at 2 threads: chunks of ceil(4/2) = 2, then ceil(2/2) = 1, 1: [0,2) 8 ms on
  // thread 0, [2,3) and [3,4) on thread 1.
  const auto g = harness::simulate_loop(ScheduleModel::parse("guided:1", OmpRuntimeModel::libgomp),
                                        w.loops[0].costs, 2, 0.0, true);
  ASSERT_EQ(g.assignment.size(), 3u);
  EXPECT_EQ(g.assignment[0].end, 2);
  EXPECT_EQ(g.assignment[0].thread, 0);
  EXPECT_EQ(g.assignment[1].thread, 1);
  EXPECT_EQ(g.assignment[2].thread, 1);
  EXPECT_NEAR(g.makespan, 8 * kMs, 1e-12);
}

TEST(Predict, GuidedChunksFollowLibgompsRule) {
  // libgomp: chunk = max(k, ceil(remaining / P)). 5 iterations at 2 threads: 3, 1, 1; at
  // k = 2: 3, 2.
  const auto w =
      harness::build_workload(synthetic_trace({std::vector<double>(5, 1.0)}, 0.0), "synthetic");
  auto sizes = [&](const std::string& spec) {
    std::vector<std::int64_t> out;
    const auto s = harness::simulate_loop(ScheduleModel::parse(spec, OmpRuntimeModel::libgomp),
                                          w.loops[0].costs, 2, 0.0, true);
    for (const auto& c : s.assignment) out.push_back(c.end - c.begin);
    return out;
  };
  EXPECT_EQ(sizes("guided:1"), (std::vector<std::int64_t>{3, 1, 1}));
  EXPECT_EQ(sizes("guided:2"), (std::vector<std::int64_t>{3, 2}));
  EXPECT_EQ(sizes("static:2"), (std::vector<std::int64_t>{2, 2, 1}));
}

TEST(Predict, DispatchCostIsPaidOncePerChunk) {
  const auto w =
      harness::build_workload(synthetic_trace({std::vector<double>(6, 1.0)}, 0.0), "synthetic");
  OverheadModel overheads;
  overheads.measured = true;
  overheads.dispatch_seconds["dynamic:1@blocks"] = 10e-6;
  overheads.loop_seconds = 3e-6;
  // At 1 thread nothing is added: the trace's times already hold the 1-thread costs, and the
  // model's figures are what more threads cost beyond them.
  const auto one = row(w, "dynamic:1", 1, overheads);
  EXPECT_NEAR(one.time, 6 * kMs, 1e-12);
  EXPECT_EQ(one.chunks, 6);
  const auto two = row(w, "dynamic:1", 2, overheads);
  EXPECT_NEAR(two.time, 3 * kMs + 3 * 10e-6 + 3e-6, 1e-12);
  EXPECT_NEAR(two.parallel_overhead, 3 * 10e-6 + 3e-6, 1e-12);
  // dynamic:3 takes its dispatch figure from dynamic:1 (same kind): 1 chunk per thread at 2.
  EXPECT_NEAR(row(w, "dynamic:3", 2, overheads).time, 3 * kMs + 1 * 10e-6 + 3e-6, 1e-12);
}

TEST(Predict, LateThreadsDelayStaticButSelfSchedulingAbsorbsIt) {
  // 8 blocks of 1 ms at 2 threads, the second thread starting 1.5 ms late. static: it ends its
  // 4 ms share at 5.5 ms. dynamic:1: the first thread takes blocks at 0 and 1 ms, then the
  // two alternate (the second at 1.5, 2.5, 3.5 ms, the first at 2, 3, 4 ms): 5 blocks and 3,
  // ending at 5 and 4.5 ms.
  const auto w =
      harness::build_workload(synthetic_trace({std::vector<double>(8, 1.0)}, 0.0), "synthetic");
  const auto s = harness::simulate_loop(ScheduleModel::parse("static", OmpRuntimeModel::libgomp),
                                        w.loops[0].costs, 2, 0.0, false, 1.5 * kMs);
  EXPECT_NEAR(s.makespan, 5.5 * kMs, 1e-12);
  const auto d = harness::simulate_loop(ScheduleModel::parse("dynamic:1", OmpRuntimeModel::libgomp),
                                        w.loops[0].costs, 2, 0.0, true, 1.5 * kMs);
  EXPECT_NEAR(d.thread_work[0], 5 * kMs, 1e-12);
  EXPECT_NEAR(d.thread_work[1], 3 * kMs, 1e-12);
  EXPECT_NEAR(d.makespan, 5 * kMs, 1e-12);
  ASSERT_EQ(d.assignment.size(), 8u);
  EXPECT_EQ(d.assignment[1].thread, 0);  // the second block: the first thread, at 1 ms
  EXPECT_EQ(d.assignment[2].thread, 1);
  // A delay shorter than a block is not absorbed (4 blocks each, ending at 4 and 4.1 ms); the
  // model's loop_seconds is that delay, added only above 1 thread.
  OverheadModel late;
  late.measured = true;
  late.loop_seconds = 0.1 * kMs;
  EXPECT_NEAR(row(w, "dynamic:1", 2, late).time, 4.1 * kMs, 1e-12);
  EXPECT_NEAR(row(w, "static", 2, late).time, 4.1 * kMs, 1e-12);
  EXPECT_NEAR(row(w, "static", 1, late).time, 8 * kMs, 1e-12);  // nothing at 1 thread
}

TEST(Predict, ValidationNamesRowsRunWithTheCoresElsewhere) {
  // Overheads measured with the cores 85 ns apart; one row ran at 90 ns, one at 380 ns.
  harness::Validation v;
  v.overheads.measured = true;
  v.overheads.round_trip_ns = 85.0;
  v.overheads.dispatch_round_trip_ns["static@blocks"] = 85.0;
  v.overheads.dispatch_round_trip_ns["dynamic:1@blocks"] = 400.0;
  harness::ValidationRow near, far;
  near.scheduler = "static@blocks";
  far.scheduler = "dynamic:1@blocks";
  near.threads = far.threads = 2;
  near.measured_time = far.measured_time = 1.0;
  near.round_trip_before_ns = near.round_trip_after_ns = 90.0;
  far.round_trip_before_ns = 370.0;
  far.round_trip_after_ns = 390.0;
  v.rows = {near, far};
  const std::string text = harness::format_validation_markdown(v);
  EXPECT_THAT(text, ::testing::HasSubstr("| 90 / 90 |"));
  EXPECT_THAT(text,
              ::testing::HasSubstr("dynamic:1@blocks x 2 at 380 ns (per-loop cost at 85 ns)."));
  EXPECT_THAT(text, ::testing::HasSubstr("went from 90 to 390 ns within this sweep"));
  v.rows = {near};
  const std::string quiet = harness::format_validation_markdown(v);
  EXPECT_THAT(quiet, ::testing::Not(::testing::HasSubstr("Core placement")));
  // A near row predicted with a per-chunk cost measured far.
  near.scheduler = "dynamic:1@blocks";
  v.rows = {near};
  EXPECT_THAT(harness::format_validation_markdown(v),
              ::testing::HasSubstr("dynamic:1@blocks x 2 at 90 ns (per-chunk cost at 400 ns)."));
  EXPECT_THAT(quiet, ::testing::Not(::testing::HasSubstr("within this sweep")));
}

TEST(Predict, ChunksOverSeveralIterationsSpreadEvenly) {
  harness::IterationCosts costs;
  costs.add(4, 8.0);  // 2 each
  costs.add(0, 5.0);  // ignored
  costs.add(1, 3.0);
  EXPECT_EQ(costs.size(), 5);
  EXPECT_DOUBLE_EQ(costs.range(0, 5), 11.0);
  EXPECT_DOUBLE_EQ(costs.range(1, 3), 4.0);
  EXPECT_DOUBLE_EQ(costs.range(3, 5), 5.0);
  EXPECT_DOUBLE_EQ(costs.total(), 11.0);
}

TEST(Predict, BlocksBecomeListEntriesByTheirElements) {
  // Blocks of 3, 0 and 1 live elements costing 6, 1 and 2 ms: over the lists, 4 entries of
  // 2, 2, 2 and 2 ms; the block without elements is dropped.
  const auto w =
      harness::build_workload(synthetic_trace({{6, 1, 2}}, 0.0, {{3, 0, 1}}), "synthetic");
  ASSERT_EQ(w.loops[0].active.size(), 4);
  EXPECT_NEAR(w.dropped_for_active_seconds, 1 * kMs, 1e-12);
  const auto a = row(w, "active-lists", 2);
  EXPECT_NEAR(a.time, 4 * kMs, 1e-12);
  EXPECT_NEAR(a.load_imbalance, 0.0, 1e-12);
}

TEST(Predict, AmdahlLimitIsOneOverTheSequentialShare) {
  const auto w =
      harness::build_workload(synthetic_trace({std::vector<double>(4, 2.5)}, 10.0), "synthetic");
  const auto p = harness::predict(w, "synthetic", {"static"}, {2, 4}, {});
  ASSERT_TRUE(p.amdahl_limit.has_value());
  EXPECT_NEAR(*p.amdahl_limit, 2.0, 1e-12);  // s = 10 / (10 + 10)
  ASSERT_EQ(p.rows.size(), 2u);
  EXPECT_NEAR(p.rows[0].speedup, 20.0 / 15.0, 1e-12);
  EXPECT_FALSE(p.rows[0].beyond_cores);
  EXPECT_TRUE(p.rows[1].beyond_cores);  // 4 threads on the trace's 2 cores
}

TEST(Predict, RefusesWhatItCannotReplay) {
  EXPECT_THROW(ScheduleModel::parse("runtime", OmpRuntimeModel::libgomp), std::invalid_argument);
  EXPECT_THROW(ScheduleModel::parse("taskloop:2", OmpRuntimeModel::libgomp), std::invalid_argument);
  EXPECT_THROW(ScheduleModel::parse("no-such-scheduler", OmpRuntimeModel::libgomp),
               std::invalid_argument);
  // A chunk that leaves a gap in its loop.
  auto t = synthetic_trace({{1, 1, 1}}, 0.0);
  t.chunks[1].begin = 2;
  EXPECT_THROW(harness::build_workload(t, "gap"), std::invalid_argument);
}

TEST(Predict, OverheadsAreWhatPThreadsCostBeyondOneThread) {
  const auto dir = clothbench_test::fresh_dir("predict_overheads");
  std::filesystem::create_directories(dir);
  const auto file = dir / "overheads.json";
  // static@blocks: 1.5 us per loop at 1 thread, 4 us at 2. dynamic:1: 3.5 us per loop and 1024
  // chunks at 1 thread (dispatch (3.5 - 1.5) us / 1024), 24.48 us per loop and 2048 chunks at 2
  // (dispatch (24.48 - 4) us / 1024): per chunk beyond 1 thread 18.48 us / 1024.
  std::ofstream(file) << R"({"benchmarks": [
    {"name": "scheduling_overhead/static@blocks/threads:1/iterations:30/real_time", "threads": 1,
     "overhead_loop_us_median": 1.5, "chunks_per_loop": 1},
    {"name": "scheduling_overhead/static@blocks/threads:2/iterations:30/real_time", "threads": 2,
     "overhead_loop_us_median": 4.0, "chunks_per_loop": 2},
    {"name": "scheduling_overhead/dynamic:1@blocks/threads:1/iterations:30/real_time",
     "threads": 1, "overhead_loop_us_median": 3.5, "chunks_per_loop": 1024},
    {"name": "scheduling_overhead/dynamic:1@blocks/threads:2/iterations:30/real_time",
     "threads": 2, "overhead_loop_us_median": 24.48, "chunks_per_loop": 2048},
    {"name": "scheduling_overhead/guided:1@blocks/threads:2/iterations:30/real_time",
     "threads": 2, "overhead_loop_us_median": 9.0, "chunks_per_loop": 2048},
    {"name": "scheduling_overhead/fac2:1@blocks/threads:1/iterations:30/real_time", "threads": 1,
     "overhead_loop_us_median": 2.0, "chunks_per_loop": 11},
    {"name": "scheduling_overhead/fac2:1@blocks/threads:2/iterations:30/real_time", "threads": 2,
     "overhead_loop_us_median": 30000.0, "chunks_per_loop": 22, "disturbed": 1}]})";
  const OverheadModel m = harness::read_overhead_model(file);
  EXPECT_EQ(m.measured_threads, 2);
  EXPECT_NEAR(m.loop_seconds, 2.5e-6, 1e-15);
  EXPECT_NEAR(m.loop_seconds_at_one, 1.5e-6, 1e-15);
  EXPECT_NEAR(m.loop_seconds_at_measured, 4e-6, 1e-15);
  EXPECT_NEAR(m.dispatch("dynamic:1@blocks"), 18.48e-6 / 1024, 1e-15);
  EXPECT_NEAR(m.dispatch("dynamic:2@blocks"), 18.48e-6 / 1024, 1e-15);  // same kind
  EXPECT_EQ(m.dispatch("guided:1@blocks"), 0.0);  // measured at 2 threads only: not used
  EXPECT_EQ(m.dispatch("fac2:1@blocks"), 0.0);    // disturbed at 2 threads: not used
  EXPECT_EQ(m.dispatch("tss:1@blocks"), 0.0);     // not measured
  EXPECT_EQ(m.disturbed, std::vector<std::string>{"fac2:1@blocks"});
  EXPECT_THAT(m.source, ::testing::HasSubstr("minus those at 1 thread"));
  EXPECT_THAT(m.source, ::testing::HasSubstr("one team size only, not used: guided:1@blocks"));

  // A 1-thread trace of 8 blocks of 1 ms: at 1 thread exactly its busy time, at 2 threads
  // 4 blocks each plus 4 dispatches and one loop's cost beyond 1 thread.
  const auto w =
      harness::build_workload(synthetic_trace({std::vector<double>(8, 1.0)}, 0.0), "synthetic");
  EXPECT_NEAR(row(w, "dynamic:1", 1, m).time, 8 * kMs, 1e-12);
  EXPECT_NEAR(row(w, "dynamic:1", 2, m).time, 4 * kMs + 4 * 18.48e-6 / 1024 + 2.5e-6, 1e-12);

  // The stored form (a trace header's "overheads") gives the same model back.
  const OverheadModel back =
      harness::overhead_model_from_json(harness::overhead_model_json(m), "T's header");
  EXPECT_EQ(back.measured_threads, 2);
  EXPECT_DOUBLE_EQ(back.loop_seconds, m.loop_seconds);
  EXPECT_EQ(back.dispatch_seconds, m.dispatch_seconds);
  EXPECT_EQ(back.disturbed, m.disturbed);
  EXPECT_THAT(back.source, ::testing::HasSubstr("T's header, copied from " + file.string()));
  EXPECT_THROW(harness::overhead_model_from_json({{"loop_seconds", "x"}}, "T"),
               std::invalid_argument);

  // Only one team size: no difference to take.
  std::ofstream(dir / "two_only.json") << R"({"benchmarks": [
    {"name": "scheduling_overhead/static@blocks/iterations:30/real_time", "threads": 2,
     "overhead_loop_us_median": 4.0, "chunks_per_loop": 2}]})";
  try {
    (void)harness::read_overhead_model(dir / "two_only.json");
    ADD_FAILURE() << "a file with one team size was accepted";
  } catch (const std::invalid_argument& error) {
    EXPECT_THAT(error.what(), ::testing::HasSubstr("at 2 threads only"));
  }
  // The wait policy the micro-benchmark ran under: recorded, kept in the stored form, and a
  // prediction from a trace that ran under the other one says so.
  std::ofstream(dir / "passive.json") << R"({"context": {"omp_wait_policy": "passive"},
    "benchmarks": [
    {"name": "scheduling_overhead/static@blocks/threads:1/iterations:30/real_time", "threads": 1,
     "overhead_loop_us_median": 1.5, "chunks_per_loop": 1},
    {"name": "scheduling_overhead/static@blocks/threads:2/iterations:30/real_time", "threads": 2,
     "overhead_loop_us_median": 31.5, "chunks_per_loop": 2, "core_round_trip_ns_before": 80,
     "core_round_trip_ns_after": 90},
    {"name": "scheduling_overhead/dynamic:1@blocks/threads:2/iterations:30/real_time",
     "threads": 2, "overhead_loop_us_median": 40.0, "chunks_per_loop": 2048,
     "core_round_trip_ns_before": 380, "core_round_trip_ns_after": 85}]})";
  const OverheadModel passive = harness::read_overhead_model(dir / "passive.json");
  EXPECT_EQ(passive.wait_policy, "passive");
  EXPECT_DOUBLE_EQ(passive.round_trip_ns, 85.0);  // static@blocks at 2 threads: (80 + 90) / 2
  EXPECT_THAT(passive.source, ::testing::HasSubstr("with the cores 85 ns apart"));
  EXPECT_EQ(m.round_trip_ns, 0.0);  // not recorded
  EXPECT_EQ(m.wait_policy, "not recorded");
  EXPECT_THAT(passive.source, ::testing::HasSubstr("OMP_WAIT_POLICY passive"));
  const OverheadModel passive_back =
      harness::overhead_model_from_json(harness::overhead_model_json(passive), "T");
  EXPECT_EQ(passive_back.wait_policy, "passive");
  EXPECT_DOUBLE_EQ(passive_back.round_trip_ns, 85.0);
  EXPECT_THAT(harness::wait_policy_mismatch(passive, "active"),
              ::testing::HasSubstr("measured with OMP_WAIT_POLICY passive but the traced run had "
                                   "active"));
  EXPECT_EQ(harness::wait_policy_mismatch(passive, "passive"), "");
  EXPECT_EQ(harness::wait_policy_mismatch(passive, "not recorded"), "");
  EXPECT_EQ(harness::wait_policy_mismatch(m, "active"), "");  // the model's is not recorded
  auto traced_active = w;
  traced_active.wait_policy = "active";
  EXPECT_THAT(harness::choose_overheads(passive, traced_active).source,
              ::testing::HasSubstr("WARNING: the overheads were measured with"));
  EXPECT_THAT(harness::choose_overheads(passive, w).source,
              ::testing::Not(::testing::HasSubstr("WARNING")));

  std::ofstream(dir / "empty.json") << R"({"benchmarks": []})";
  EXPECT_THROW(harness::read_overhead_model(dir / "empty.json"), std::invalid_argument);
  EXPECT_THROW(harness::read_overhead_model(dir / "missing.json"), std::invalid_argument);
}

// The same run traced twice (a fine trace of one chunk per block and a coarse one of one
// chunk per loop): the fine trace keeps its split of each loop and takes the coarse trace's
// loop times and time outside loops.
clothbench::harness::TraceDocument coarse_of(const clothbench::harness::TraceDocument& fine,
                                             const std::vector<double>& loop_ms,
                                             double sequential_ms) {
  clothbench::harness::TraceDocument t = fine;
  t.chunks.clear();
  std::int64_t clock = 0;
  double span_ms = 0.0;
  for (std::size_t i = 0; i < t.loops.size(); ++i) {
    const auto ns = static_cast<std::int64_t>(loop_ms[i] * 1e6);
    t.chunks.push_back({static_cast<std::uint32_t>(i), 0, 0,
                        static_cast<std::int32_t>(t.loops[i].n), 1, 0, clock, clock + ns});
    t.loops[i].entry_ns = clock;
    t.loops[i].exit_ns = clock + ns;
    clock += ns;
    span_ms += loop_ms[i];
  }
  t.header["cost"]["run_seconds"] = (span_ms + sequential_ms) * 1e-3;
  return t;
}

TEST(Predict, LoopTimesFromACoarserTraceOfTheSameRun) {
  // Fine: loop 0 splits 3 : 1 ms, loop 1 three blocks of 2 ms, 4 ms outside loops (tracing
  // cost included). Coarse: the loops took 2 and 3 ms, 1 ms outside them.
  const auto fine_doc = synthetic_trace({{3, 1}, {2, 2, 2}}, 4.0);
  auto w = harness::build_workload(fine_doc, "fine");
  const auto totals = harness::build_workload(coarse_of(fine_doc, {2, 3}, 1.0), "coarse");
  harness::take_loop_times(w, totals, "fine", "coarse");
  EXPECT_EQ(w.loop_times_from, "coarse");
  EXPECT_NEAR(w.loops[0].costs.total(), 2 * kMs, 1e-12);
  EXPECT_NEAR(w.loops[0].costs.range(0, 1), 1.5 * kMs, 1e-12);  // the fine split, 3 : 1
  EXPECT_NEAR(w.loops[1].costs.range(2, 3), 1 * kMs, 1e-12);
  EXPECT_NEAR(w.loops[0].active.total(), 2 * kMs, 1e-12);
  EXPECT_NEAR(w.busy_seconds, 5 * kMs, 1e-12);
  EXPECT_NEAR(w.sequential_seconds, 1 * kMs, 1e-12);
  EXPECT_NEAR(row(w, "static", 1).time, 6 * kMs, 1e-12);
  // dynamic:1 at 2 threads: loop 0 takes its 1.5 ms block, loop 1 two of its 1 ms blocks.
  EXPECT_NEAR(row(w, "dynamic:1", 2).time, 1 * kMs + 1.5 * kMs + 2 * kMs, 1e-12);

  // Not the same run: another loop count, or another loop at the same instance.
  auto other = harness::build_workload(fine_doc, "fine");
  const auto shorter = harness::build_workload(synthetic_trace({{3, 1}}, 4.0), "short");
  try {
    harness::take_loop_times(other, shorter, "fine", "short");
    ADD_FAILURE() << "traces of different runs were combined";
  } catch (const std::invalid_argument& error) {
    EXPECT_THAT(error.what(),
                ::testing::HasSubstr("fine and short are not traces of the same run"));
    EXPECT_THAT(error.what(), ::testing::HasSubstr("2 and 1 loop instances"));
  }
  const auto wider = harness::build_workload(synthetic_trace({{3, 1, 1}, {2, 2, 2}}, 4.0), "wide");
  EXPECT_THROW(harness::take_loop_times(other, wider, "fine", "wide"), std::invalid_argument);
}

}  // namespace
}  // namespace clothbench
