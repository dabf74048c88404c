// The predictor's memory-bandwidth ceiling (harness/predict/bandwidth_model.hpp, issue 17) on
// synthetic traces with answers worked out by hand: a loop instance takes at least its bytes
// / B(P), which binds at high P and not at 1 thread; a bound loop is stretched as a whole (its
// imbalance share unchanged); B(P) between and beyond the measured thread counts; loops of a
// format-1 trace (no bytes recorded) get no ceiling and the prediction says so; the triad file
// of clothbench-micro and its stored form, and the bad input they refuse.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "harness/predict/bandwidth_model.hpp"
#include "harness/predict/prediction.hpp"
#include "harness/predict/trace_workload.hpp"
#include "tests/harness/clothbench_process.hpp"
#include "tests/harness/synthetic_trace.hpp"

namespace clothbench {
namespace {

namespace fs = std::filesystem;
using clothbench_test::synthetic_trace;
using harness::BandwidthModel;
using harness::OmpRuntimeModel;
using harness::ScheduleModel;
using ::testing::HasSubstr;

constexpr double kMs = 1e-3;

harness::PredictedRow row(const harness::TraceWorkload& w, const std::string& spec, int threads,
                          const BandwidthModel& bandwidth) {
  return harness::predict_row(w, ScheduleModel::parse(spec, OmpRuntimeModel::libgomp), threads, {},
                              bandwidth);
}

BandwidthModel triad(std::map<int, double> rates) {
  BandwidthModel b;
  b.triad = std::move(rates);
  b.source = "test";
  return b;
}

TEST(PredictBandwidth, CeilingBindsAtHighThreadsAndNotAtOne) {
  // Two loops of 16 iterations of 1 ms and 1000 elements each, 1000 B per element: 16 MB a
  // loop instance; 5 ms outside the loops. Triad 4 GB/s at 1 thread, 6 GB/s at 2 (flat above).
  const std::vector<double> uniform(16, 1.0);
  const std::vector<int> thousand(16, 1000);
  const auto w = harness::build_workload(
      synthetic_trace({uniform, uniform}, 5.0, {thousand, thousand}, 1000.0), "synthetic");
  ASSERT_NEAR(w.loops[0].bytes, 16e6, 1e-6);
  const BandwidthModel b = triad({{1, 4e9}, {2, 6e9}});
  // P = 1: 16 ms of work against 16 MB / 4 GB/s = 4 ms: not bound.
  const auto one = row(w, "static", 1, b);
  EXPECT_EQ(one.bandwidth_bound_loops, 0);
  EXPECT_NEAR(one.time, 37 * kMs, 1e-12);
  // P = 2 and 4: 8 and 4 ms against 16 MB / 6 GB/s = 2.667 ms: not bound.
  EXPECT_EQ(row(w, "static", 2, b).bandwidth_bound_loops, 0);
  EXPECT_NEAR(row(w, "static", 4, b).time, 13 * kMs, 1e-12);
  // P = 8: 2 ms < 2.667 ms: each loop takes 8/3 ms, 2/3 ms more; balanced, so the stretched
  // work is all parallel work.
  const auto eight = row(w, "static", 8, b);
  EXPECT_EQ(eight.bandwidth_bound_loops, 2);
  EXPECT_NEAR(eight.bandwidth_added_seconds, 4.0 / 3.0 * kMs, 1e-12);
  EXPECT_NEAR(eight.time, 5 * kMs + 16.0 / 3.0 * kMs, 1e-12);
  EXPECT_NEAR(eight.parallel_work, 16.0 / 3.0 * kMs, 1e-12);
  EXPECT_NEAR(eight.parallel_overhead, 0.0, 1e-12);
  EXPECT_NEAR(eight.bandwidth, 6e9, 1e-3);
  // P = 16: 1 ms per loop without the ceiling; the same 8/3 ms with it.
  const auto sixteen = row(w, "static", 16, b);
  EXPECT_NEAR(sixteen.time, eight.time, 1e-12);
  EXPECT_NEAR(sixteen.bandwidth_added_seconds, 10.0 / 3.0 * kMs, 1e-12);
  // Without a bandwidth model nothing changes.
  const auto free = row(w, "static", 16, {});
  EXPECT_EQ(free.bandwidth_bound_loops, 0);
  EXPECT_NEAR(free.time, 7 * kMs, 1e-12);
}

TEST(PredictBandwidth, ABoundLoopIsStretchedAsAWhole) {
  // 7, 1, 1, 1 ms, one element each, 3.2 MB per element: 12.8 MB. dynamic:1 at 2 threads
  // replays to 7 ms (thread 0: 7, thread 1: 3); at 1.6 GB/s the loop takes 8 ms: stretched by
  // 8/7, busiest 8 ms, mean 5 x 8/7 ms, so the imbalance stays 40 %. At 1 thread 10 ms of work
  // against 8 ms: not bound.
  const auto w =
      harness::build_workload(synthetic_trace({{7, 1, 1, 1}}, 0.0, {}, 3.2e6), "synthetic");
  const BandwidthModel b = triad({{1, 1.6e9}});
  EXPECT_EQ(row(w, "dynamic:1", 1, b).bandwidth_bound_loops, 0);
  const auto two = row(w, "dynamic:1", 2, b);
  EXPECT_EQ(two.bandwidth_bound_loops, 1);
  EXPECT_NEAR(two.time, 8 * kMs, 1e-12);
  EXPECT_NEAR(two.bandwidth_added_seconds, 1 * kMs, 1e-12);
  EXPECT_NEAR(two.load_imbalance, 8 * kMs - 5.0 * 8.0 / 7.0 * kMs, 1e-12);
  EXPECT_NEAR(two.imbalance_percent, 40.0, 1e-9);
  EXPECT_EQ(b.basis(2), "flat beyond 1 core: the 1-core triad");
}

TEST(PredictBandwidth, BandwidthBetweenAndBeyondTheMeasuredThreads) {
  const BandwidthModel b = triad({{1, 4e9}, {4, 10e9}});
  EXPECT_DOUBLE_EQ(b.at(1), 4e9);
  EXPECT_DOUBLE_EQ(b.at(2), 6e9);
  EXPECT_DOUBLE_EQ(b.at(3), 8e9);
  EXPECT_DOUBLE_EQ(b.at(4), 10e9);
  EXPECT_DOUBLE_EQ(b.at(80), 10e9);
  EXPECT_EQ(b.basis(1), "measured");
  EXPECT_EQ(b.basis(3), "interpolated between 1 and 4 threads");
  EXPECT_EQ(b.basis(80), "flat beyond 4 cores: the 4-core triad");
  EXPECT_EQ(BandwidthModel{}.at(2), 0.0);
  EXPECT_FALSE(BandwidthModel{}.measured());

  // The prediction says where it assumed the bandwidth flat.
  const auto w = harness::build_workload(
      synthetic_trace({std::vector<double>(4, 1.0)}, 0.0, {}, 8.0), "synthetic");
  const auto p = harness::predict(w, "synthetic", {"static"}, {1, 8}, {}, b);
  EXPECT_THAT(p.notes, ::testing::Contains(
                           HasSubstr("bandwidth beyond 4 cores assumed flat at the 4-core triad")));
}

TEST(PredictBandwidth, LoopsWithoutBytesGetNoCeilingAndThePredictionSaysSo) {
  // A format-1 trace records no bytes: even a tiny bandwidth bounds nothing.
  const auto w = harness::build_workload(synthetic_trace({{1, 1}, {2, 2}}, 0.0), "synthetic");
  EXPECT_EQ(w.loops_without_bytes, 2);
  EXPECT_LT(w.loops[0].bytes, 0.0);
  const BandwidthModel slow = triad({{1, 1.0}});
  EXPECT_EQ(row(w, "static", 2, slow).bandwidth_bound_loops, 0);
  const auto p = harness::predict(w, "synthetic", {"static"}, {1, 2}, {}, slow);
  EXPECT_THAT(p.notes, ::testing::Contains(HasSubstr("2 of 2 loop instances carry no bytes")));
  EXPECT_THAT(harness::format_prediction_markdown(p), HasSubstr("Bandwidth ceiling: test"));

  // With bytes the loop beat that triad in the trace itself (2 ms of work for 100 bytes at
  // 1 B/s): its ceiling is its own 1-thread rate scaled as the triad scales, so the 1-thread
  // row keeps the trace's time, and with a flat triad 2 threads cannot beat it either (2 ms
  // instead of 1 ms), and the prediction says so.
  const auto with_bytes =
      harness::build_workload(synthetic_trace({{1, 1}}, 0.0, {}, 100.0), "synthetic");
  const auto bound = harness::predict(with_bytes, "synthetic", {"static"}, {1, 2}, {}, slow);
  EXPECT_EQ(bound.rows[0].bandwidth_bound_loops, 0);
  EXPECT_DOUBLE_EQ(bound.rows[0].time, 0.002);
  EXPECT_EQ(bound.rows[1].bandwidth_bound_loops, 1);
  EXPECT_DOUBLE_EQ(bound.rows[1].time, 0.002);
  EXPECT_DOUBLE_EQ(bound.rows[1].bandwidth_added_seconds, 0.001);
  EXPECT_THAT(bound.notes, ::testing::Contains(HasSubstr(
                               "1 of 1 loop instances moved their bytes faster than the 1-thread "
                               "triad")));
}

/// Writes `text` to dir/name and returns the path.
fs::path write(const fs::path& dir, const std::string& name, const std::string& text) {
  std::ofstream(dir / name) << text;
  return dir / name;
}

TEST(PredictBandwidth, ReadsTheTriadOfClothbenchMicro) {
  const fs::path dir = clothbench_test::fresh_dir("predict_bandwidth_file");
  fs::create_directories(dir);
  // Three repetitions at 1 thread (median 5 GB/s), their aggregate (ignored), 2 threads, and
  // a benchmark that is not the triad.
  const fs::path file = write(dir, "triad.json", R"({"context": {"date": "today"}, "benchmarks": [
    {"name": "triad/16777216/1/real_time", "threads": 1, "bytes_per_second": 6e9},
    {"name": "triad/16777216/1/real_time", "threads": 1, "bytes_per_second": 4e9},
    {"name": "triad/16777216/1/real_time", "threads": 1, "bytes_per_second": 5e9},
    {"name": "triad/16777216/1/real_time_median", "run_type": "aggregate", "threads": 1,
     "bytes_per_second": 1},
    {"name": "triad/16777216/2/real_time", "threads": 2, "bytes_per_second": 7e9},
    {"name": "gradient/potential/101/1/real_time", "threads": 1, "bytes_per_second": -1}]})");
  const BandwidthModel b = harness::read_bandwidth_model(file);
  EXPECT_EQ(b.triad, (std::map<int, double>{{1, 5e9}, {2, 7e9}}));
  EXPECT_THAT(b.source, HasSubstr(file.string() + ": STREAM triad of clothbench-micro, today"));
  EXPECT_THAT(b.source, HasSubstr("2 threads 7.00 GB/s"));

  // The stored form (a trace header's "bandwidth") gives the same model back.
  const BandwidthModel back =
      harness::bandwidth_model_from_json(harness::bandwidth_model_json(b), "T's header");
  EXPECT_EQ(back.triad, b.triad);
  EXPECT_THAT(back.source, HasSubstr("T's header, copied from " + file.string()));
}

TEST(PredictBandwidth, RefusesABadTriadNamingTheFile) {
  const fs::path dir = clothbench_test::fresh_dir("predict_bandwidth_bad");
  fs::create_directories(dir);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {R"({"benchmarks": [{"name": "triad/8/1/real_time", "threads": 1,
           "bytes_per_second": -5}]})",
       "bytes_per_second -5 is not a positive number"},
      {R"({"benchmarks": [{"name": "triad/8/1/real_time", "threads": 1}]})",
       "triad/8/1/real_time: no bytes_per_second"},
      {R"({"benchmarks": [{"name": "other/8", "threads": 1, "bytes_per_second": 1}]})",
       "holds no triad result"},
      {R"({"benchmarks": [{"name": "triad/8/2/real_time", "threads": 2,
           "bytes_per_second": 5e9}]})",
       "holds no triad at 1 thread"},
      {R"({"no": "benchmarks"})", "not Google Benchmark JSON"},
  };
  int k = 0;
  for (const auto& [text, expected] : cases) {
    const fs::path file = write(dir, "bad" + std::to_string(k++) + ".json", text);
    try {
      (void)harness::read_bandwidth_model(file);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const std::invalid_argument& error) {
      EXPECT_THAT(error.what(), HasSubstr(file.string())) << text;
      EXPECT_THAT(error.what(), HasSubstr(expected)) << text;
    }
  }
  EXPECT_THROW((void)harness::read_bandwidth_model(dir / "missing.json"), std::invalid_argument);
  // A stored triad that is negative or missing is refused naming where it was stored.
  for (const nlohmann::json& stored :
       {nlohmann::json{{"source", "f"}, {"triad", {{{"threads", 1}, {"bytes_per_second", -1.0}}}}},
        nlohmann::json{{"source", "f"}, {"triad", {{{"threads", 1}}}}},
        nlohmann::json{{"source", "f"}}}) {
    try {
      (void)harness::bandwidth_model_from_json(stored, "T's header");
      ADD_FAILURE() << "accepted: " << stored.dump();
    } catch (const std::invalid_argument& error) {
      EXPECT_THAT(error.what(), HasSubstr("T's header: bandwidth")) << stored.dump();
    }
  }
}

}  // namespace
}  // namespace clothbench
