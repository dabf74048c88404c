// The schedule predictor (issue 17) against real traces of a 17 x 17 sheet with AMRC on a
// box, 3 steps, recorded here with the real schedulers:
//  - at 1 thread with zero overheads, the prediction's loop work is the trace's busy time and
//    its time the busy time plus the time outside loops (within rounding);
//  - at 2, 3 and 4 threads (3 and 4 oversubscribe a 2-core machine: only assignments are
//    compared, never times), replaying a traced run through its own scheduler hands out the
//    chunks the run handed out: the same thread per chunk where the assignment is fixed
//    (static, active-lists), the same chunk ranges where threads race for them (fac2, tss,
//    gss, dynamic:2);
//  - `clothbench predict` prints a labelled Table 2 and refuses bad input naming the flag or
//    file with exit code 2; `--validate` predicts the rows of a sweep from its traces;
//  - `sweep --trace DIR --trace-overheads FILE --trace-bandwidth FILE` stores the scheduling
//    costs and the triad in each trace's header, which read back to the same models, and
//    `predict` uses them (and says so) when no --overheads / --bandwidth is given; bad
//    --trace-overheads / --trace-bandwidth input is refused naming the flag, exit 2;
//  - `predict --bandwidth FILE`: the ceiling lengthens every loop of a real trace under a
//    tiny bandwidth and none under a huge one; a trace of format 1 (no bytes per loop) still
//    loads and gets no ceiling, saying so; a bad triad file is refused naming the flag and
//    the file, exit 2.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "harness/machine/machine_context.hpp"
#include "harness/predict/prediction.hpp"
#include "harness/predict/schedule_simulation.hpp"
#include "harness/predict/trace_workload.hpp"
#include "harness/trace/trace_file.hpp"
#include "kernels/simulation.hpp"
#include "schedulers/registry.hpp"
#include "tests/harness/adaptive_sheet_scene.hpp"
#include "tests/harness/clothbench_process.hpp"

namespace clothbench {
namespace {

namespace fs = std::filesystem;
using clothbench_test::adaptive_sheet_on_box;
using ::testing::HasSubstr;

/// A traced run of 3 steps, its header holding the machine context (the OpenMP runtime).
harness::TraceDocument traced_run(const std::string& scheduler, int threads) {
  omp_set_num_threads(threads);
  kernels::Simulation simulation(adaptive_sheet_on_box());
  const auto driver = schedulers::make_driver(scheduler);
  kernels::ChunkTrace trace;
  trace.start(threads, 1024);
  double seconds = 0.0;
  for (int k = 0; k < 3; ++k) {
    seconds += simulation.step(*driver, kernels::Instrumentation::off, nullptr, &trace).seconds;
  }
  return harness::collect_trace(trace,
                                {{"scheduler", driver->name()},
                                 {"threads", threads},
                                 {"machine", harness::machine_context()}},
                                0.0, seconds);
}

TEST(PredictReplay, OneThreadReproducesTheBusyTime) {
  for (const std::string scheduler : {"static", "dynamic:1", "active-lists"}) {
    const harness::TraceDocument trace = traced_run(scheduler, 1);
    const harness::TraceWorkload w = harness::build_workload(trace, scheduler);
    std::int64_t busy_ns = 0;
    for (const auto& c : trace.chunks) busy_ns += c.end_ns - c.start_ns;
    ASSERT_GT(busy_ns, 0);
    const double busy = 1e-9 * static_cast<double>(busy_ns);
    const auto model = harness::ScheduleModel::parse(scheduler, harness::OmpRuntimeModel::libgomp);
    const harness::PredictedRow row = harness::predict_row(w, model, 1, {});
    EXPECT_NEAR(row.parallel_work, busy, 1e-12 * busy) << scheduler;
    EXPECT_NEAR(row.load_imbalance, 0.0, 1e-12 * busy) << scheduler;
    EXPECT_NEAR(row.time, w.sequential_seconds + busy, 1e-12 * busy) << scheduler;
    EXPECT_GT(w.sequential_seconds, 0.0) << scheduler;
  }
}

using Chunk = std::tuple<std::uint32_t, int, std::int64_t, std::int64_t>;  // loop, thread, range

struct Case {
  std::string scheduler;
  int threads;
};
void PrintTo(const Case& c, std::ostream* os) { *os << c.scheduler << " x " << c.threads; }

class PredictAssignment : public ::testing::TestWithParam<Case> {};

TEST_P(PredictAssignment, ReplayHandsOutTheRecordedChunks) {
  const Case& param = GetParam();
  const harness::TraceDocument trace = traced_run(param.scheduler, param.threads);
  const harness::TraceWorkload w = harness::build_workload(trace, param.scheduler);
  const auto model =
      harness::ScheduleModel::parse(param.scheduler, harness::runtime_model(w.openmp_runtime));
  const bool fixed = model.fixed_assignment();
  std::vector<Chunk> recorded, predicted;
  for (const auto& c : trace.chunks) {
    recorded.emplace_back(c.instance, fixed ? c.thread : -1, c.begin, c.end);
  }
  for (std::size_t i = 0; i < w.loops.size(); ++i) {
    const harness::LoopSimulation s =
        harness::simulate_loop(model, w.loops[i].costs, param.threads, 0.0, true);
    for (const auto& c : s.assignment) {
      predicted.emplace_back(static_cast<std::uint32_t>(i), fixed ? c.thread : -1, c.begin, c.end);
    }
  }
  std::sort(recorded.begin(), recorded.end());
  std::sort(predicted.begin(), predicted.end());
  ASSERT_EQ(predicted.size(), recorded.size());
  for (std::size_t k = 0; k < recorded.size(); ++k) {
    ASSERT_EQ(predicted[k], recorded[k])
        << "chunk " << k << ": loop " << std::get<0>(recorded[k]) << " thread "
        << std::get<1>(recorded[k]) << " [" << std::get<2>(recorded[k]) << ", "
        << std::get<3>(recorded[k]) << ")";
  }
}

std::vector<Case> assignment_cases() {
  std::vector<Case> cases;
  for (const char* s : {"static", "active-lists", "fac2", "tss:2", "gss", "dynamic:2"}) {
    for (int p : {2, 3, 4}) cases.push_back({s, p});
  }
  return cases;
}

INSTANTIATE_TEST_SUITE_P(Schedulers, PredictAssignment, ::testing::ValuesIn(assignment_cases()),
                         [](const auto& info) {
                           std::string name =
                               info.param.scheduler + "_" + std::to_string(info.param.threads);
                           for (char& ch : name) {
                             if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           }
                           return name;
                         });

/// A 1-thread dynamic:1 trace written to a file, for the command-line tests.
const fs::path& recorded_trace() {
  static const fs::path file = [] {
    const fs::path dir = clothbench_test::fresh_dir("predict_cli");
    harness::write_trace(dir / "d1.cbtrace", traced_run("dynamic:1", 1));
    return dir / "d1.cbtrace";
  }();
  return file;
}

TEST(PredictCommand, PrintsTable2AndLabelsRowsBeyondTheCores) {
  const fs::path json = recorded_trace().parent_path() / "prediction.json";
  const auto out = clothbench_test::run(
      "predict " + clothbench_test::quote(recorded_trace().string()) +
      " --threads 1,2,1024 --schedulers static,dynamic:1,fac2:2,active-lists --json " +
      clothbench_test::quote(json.string()));
  ASSERT_EQ(out.exit_code, 0) << out.output;
  EXPECT_THAT(out.output, HasSubstr("## static@blocks"));
  EXPECT_THAT(out.output, HasSubstr("## active-lists@active"));
  EXPECT_THAT(out.output, HasSubstr("| 1024 | predicted (beyond the traced machine's cores) |"));
  EXPECT_THAT(out.output, HasSubstr("overheads assumed zero"));
  EXPECT_THAT(out.output, HasSubstr("Amdahl limit"));
  std::ifstream in(json);
  const auto document = nlohmann::json::parse(in);
  EXPECT_EQ(document["rows"].size(), 12u);
  EXPECT_EQ(document["rows"][0]["threads"], 1);
  EXPECT_DOUBLE_EQ(document["rows"][0]["speedup"].get<double>(), 1.0);
}

TEST(PredictCommand, BadInputNamesTheFlagOrFileWithExitCode2) {
  const std::string trace = clothbench_test::quote(recorded_trace().string());
  const fs::path dir = recorded_trace().parent_path();
  std::ofstream(dir / "garbled.cbtrace")
      << "clothbench-trace 1\n{\"loop_count\": 5, \"chunk_count\": 1}\n";
  std::ofstream(dir / "text.cbtrace") << "hello\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"predict " + clothbench_test::quote((dir / "missing.cbtrace").string()), "missing.cbtrace"},
      {"predict " + clothbench_test::quote((dir / "garbled.cbtrace").string()), "garbled.cbtrace"},
      {"predict " + clothbench_test::quote((dir / "text.cbtrace").string()),
       "not a clothbench trace"},
      {"predict " + trace + " --threads 0", "--threads"},
      {"predict " + trace + " --threads 1,a", "--threads"},
      {"predict " + trace + " --schedulers static,no-such", "--schedulers"},
      {"predict " + trace + " --schedulers runtime", "--schedulers"},
      {"predict", "TRACE"},
      {"predict --validate " + clothbench_test::quote((dir / "missing.json").string()) +
           " --trace-dir " + clothbench_test::quote(dir.string()),
       "--validate"},
      {"predict " + trace + " --overheads " + clothbench_test::quote((dir / "none.json").string()),
       "--overheads"},
  };
  for (const auto& [arguments, expected] : cases) {
    const auto out = clothbench_test::run(arguments);
    EXPECT_EQ(out.exit_code, 2) << arguments << "\n" << out.output;
    EXPECT_THAT(out.output, HasSubstr(expected)) << arguments;
    EXPECT_THAT(out.output, HasSubstr("clothbench predict")) << arguments;
  }
}

TEST(PredictCommand, ValidatesASweepFromItsTraces) {
  const fs::path dir = clothbench_test::fresh_dir("predict_validate");
  const auto sweep = clothbench_test::run(
      "sweep " +
      clothbench_test::quote(std::string(CLOTHBENCH_SOURCE_DIR) +
                             "/tests/data/scenes/sweep-tiny.toml") +
      " --schedulers static,dynamic:1,active-lists --threads 1,2 --repeat 1 --retries 0 --steps 2 "
      "--no-plots --quiet --out " +
      clothbench_test::quote((dir / "out").string()) + " --trace " +
      clothbench_test::quote((dir / "traces").string()));
  ASSERT_EQ(sweep.exit_code, 0) << sweep.output;
  const auto out = clothbench_test::run(
      "predict --validate " + clothbench_test::quote((dir / "out" / "sweep.json").string()) +
      " --trace-dir " + clothbench_test::quote((dir / "traces").string()) + " --json " +
      clothbench_test::quote((dir / "validation.json").string()));
  ASSERT_EQ(out.exit_code, 0) << out.output;
  // Each 2-thread row's own trace gives the work it did against the 1-thread trace's.
  EXPECT_THAT(out.output, HasSubstr("| Work at P / 1 thread |"));
  const auto validation = clothbench_test::read_json(dir / "validation.json");
  ASSERT_EQ(validation["rows"].size(), 6u);
  for (const auto& r : validation["rows"]) {
    if (r["threads"] == 1) {
      EXPECT_TRUE(r["work_ratio"].is_null()) << r.dump();
    } else {
      ASSERT_TRUE(r["work_ratio"].is_number()) << r.dump();
      EXPECT_GT(r["work_ratio"].get<double>(), 0.0) << r.dump();
    }
  }
  // The finest trace over blocks (one chunk per block) takes its loop times from the static
  // one (one chunk per loop), which recording slowed less.
  EXPECT_THAT(out.output, HasSubstr("| static@blocks | 2 | dynamic_1_blocks-1t.cbtrace (loop "
                                    "times: static_blocks-1t.cbtrace) |"));
  EXPECT_THAT(out.output,
              HasSubstr("| active-lists@active | 2 | active-lists_active-1t.cbtrace |"));
  EXPECT_THAT(out.output, HasSubstr("6 rows: mean |error|"));

  // The same by hand: `predict TRACE --loop-times COARSER`, and a trace of another iteration
  // space refused by name.
  const std::string fine =
      clothbench_test::quote((dir / "traces" / "dynamic_1_blocks-1t.cbtrace").string());
  const auto by_hand = clothbench_test::run(
      "predict " + fine + " --threads 1,2 --schedulers static --loop-times " +
      clothbench_test::quote((dir / "traces" / "static_blocks-1t.cbtrace").string()));
  ASSERT_EQ(by_hand.exit_code, 0) << by_hand.output;
  EXPECT_THAT(by_hand.output, HasSubstr("Loop times, loop spans and time outside loops from"));
  const auto refused = clothbench_test::run(
      "predict " + fine + " --loop-times " +
      clothbench_test::quote((dir / "traces" / "active-lists_active-1t.cbtrace").string()));
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_THAT(refused.output, HasSubstr("--loop-times"));
  EXPECT_THAT(refused.output, HasSubstr("one is over blocks, the other over the Active-Lists"));
}

/// A triad JSON as clothbench-micro writes it, at 1 and 2 threads, with `rate` bytes per second
/// at both.
fs::path synthetic_triad(const fs::path& dir, const std::string& name, const std::string& rate) {
  fs::create_directories(dir);
  const fs::path file = dir / name;
  std::ofstream(file) << R"({"benchmarks": [
    {"name": "triad/16777216/1/real_time", "threads": 1, "bytes_per_second": )"
                      << rate << R"(},
    {"name": "triad/16777216/2/real_time", "threads": 2, "bytes_per_second": )"
                      << rate << "}]}";
  return file;
}

/// A scheduling_overhead JSON as clothbench-micro writes it, with figures chosen here:
/// static@blocks 1 us per loop at 1 thread and 5 us at 2 (4 us beyond 1 thread).
fs::path synthetic_overheads(const fs::path& dir) {
  fs::create_directories(dir);
  const fs::path file = dir / "overheads.json";
  std::ofstream(file) << R"({"benchmarks": [
    {"name": "scheduling_overhead/static@blocks/threads:1/iterations:30/real_time", "threads": 1,
     "overhead_loop_us_median": 1.0, "chunks_per_loop": 1},
    {"name": "scheduling_overhead/static@blocks/threads:2/iterations:30/real_time", "threads": 2,
     "overhead_loop_us_median": 5.0, "chunks_per_loop": 2}]})";
  return file;
}

TEST(PredictCommand, UsesTheOverheadsAndTriadStoredInTheTraceHeader) {
  const fs::path dir = clothbench_test::fresh_dir("predict_stored_overheads");
  const fs::path overheads = synthetic_overheads(dir);
  const fs::path triad = synthetic_triad(dir, "triad.json", "5e9");
  const auto sweep = clothbench_test::run(
      "sweep " +
      clothbench_test::quote(std::string(CLOTHBENCH_SOURCE_DIR) +
                             "/tests/data/scenes/sweep-tiny.toml") +
      " --schedulers static --threads 1 --repeat 1 --retries 0 --steps 2 --no-plots --quiet "
      "--out " +
      clothbench_test::quote((dir / "out").string()) + " --trace " +
      clothbench_test::quote((dir / "traces").string()) + " --trace-overheads " +
      clothbench_test::quote(overheads.string()) + " --trace-bandwidth " +
      clothbench_test::quote(triad.string()));
  ASSERT_EQ(sweep.exit_code, 0) << sweep.output;
  const fs::path trace = dir / "traces" / "static_blocks-1t.cbtrace";
  // The header holds the model as read from the file, and reads back to the same figures.
  const harness::TraceDocument document = harness::read_trace(trace);
  ASSERT_TRUE(document.header.contains("overheads")) << document.header.dump();
  EXPECT_NEAR(document.header["overheads"]["loop_seconds"].get<double>(), 4e-6, 1e-15);
  EXPECT_EQ(document.header["overheads"]["measured_threads"], 2);
  const harness::TraceWorkload w = harness::build_workload(document, trace.string());
  ASSERT_TRUE(w.stored_overheads.has_value());
  EXPECT_NEAR(w.stored_overheads->loop_seconds, 4e-6, 1e-15);
  ASSERT_TRUE(w.stored_bandwidth.has_value()) << document.header.dump();
  EXPECT_EQ(w.stored_bandwidth->triad, (std::map<int, double>{{1, 5e9}, {2, 5e9}}));
  EXPECT_EQ(w.loops_without_bytes, 0);

  // predict without --overheads takes them from the header and says so; the 2-thread time is
  // the prediction with the header's model, in which the second thread starts each loop 4 us
  // late: longer than the zero-overhead prediction, by at most 4 us per loop instance.
  const fs::path with = dir / "stored.json";
  const auto out = clothbench_test::run("predict " + clothbench_test::quote(trace.string()) +
                                        " --threads 2 --schedulers static --json " +
                                        clothbench_test::quote(with.string()));
  ASSERT_EQ(out.exit_code, 0) << out.output;
  EXPECT_THAT(out.output,
              HasSubstr("static_blocks-1t.cbtrace's header, copied from " + overheads.string()));
  EXPECT_THAT(out.output, HasSubstr("Bandwidth ceiling: " + trace.string() +
                                    "'s header, copied from " + triad.string()));
  const harness::OverheadModel zero;
  const harness::Prediction p =
      harness::predict(w, trace.string(), {"static"}, {2}, zero, *w.stored_bandwidth);
  const auto stored = clothbench_test::read_json(with);
  const harness::Prediction with_header = harness::predict(
      w, trace.string(), {"static"}, {2}, *w.stored_overheads, *w.stored_bandwidth);
  const double time = stored["rows"][0]["time_seconds"].get<double>();
  EXPECT_NEAR(time, with_header.rows[0].time, 1e-12);
  EXPECT_GT(time, p.rows[0].time);
  EXPECT_LE(time, p.rows[0].time + 4e-6 * static_cast<double>(w.loops.size()) + 1e-12);
  // --overheads wins over the header.
  const auto given = clothbench_test::run("predict " + clothbench_test::quote(trace.string()) +
                                          " --threads 2 --schedulers static --overheads " +
                                          clothbench_test::quote(overheads.string()));
  ASSERT_EQ(given.exit_code, 0) << given.output;
  EXPECT_THAT(given.output, HasSubstr("Overheads: " + overheads.string() + ": "));

  // Bad input: a missing file, one without the 1-thread figures or with a negative triad, and
  // either flag without --trace, name the flag (and the file); exit 2.
  std::ofstream(dir / "two_only.json") << R"({"benchmarks": [
    {"name": "scheduling_overhead/static@blocks/iterations:30/real_time", "threads": 2,
     "overhead_loop_us_median": 5.0, "chunks_per_loop": 2}]})";
  const fs::path negative = synthetic_triad(dir, "negative.json", "-5");
  const std::string scene = clothbench_test::quote(std::string(CLOTHBENCH_SOURCE_DIR) +
                                                   "/tests/data/scenes/sweep-tiny.toml");
  const std::string run = "run " + scene + " --no-vtk --quiet --steps 1 --out " +
                          clothbench_test::quote((dir / "runs").string());
  const std::string traced =
      run + " --trace " + clothbench_test::quote((dir / "r.cbtrace").string());
  const std::string sweep_untraced = "sweep " + scene +
                                     " --threads 1 --schedulers static --quiet --no-plots --out " +
                                     clothbench_test::quote((dir / "s").string());
  auto flag_file = [](const std::string& command, const std::string& flag, const fs::path& file) {
    return command + " " + flag + " " + clothbench_test::quote(file.string());
  };
  struct BadCase {
    std::string arguments, flag, expected;
  };
  const std::vector<BadCase> cases = {
      {flag_file(traced, "--trace-overheads", dir / "none.json"), "--trace-overheads", "none.json"},
      {flag_file(traced, "--trace-overheads", dir / "two_only.json"), "--trace-overheads",
       "at 2 threads only"},
      {flag_file(run, "--trace-overheads", overheads), "--trace-overheads", "needs --trace"},
      {flag_file(sweep_untraced, "--trace-overheads", overheads), "--trace-overheads",
       "needs --trace"},
      {flag_file(traced, "--trace-bandwidth", negative), "--trace-bandwidth",
       "negative.json: triad/16777216/1/real_time: bytes_per_second -5"},
      {flag_file(run, "--trace-bandwidth", triad), "--trace-bandwidth", "needs --trace"},
      {flag_file(sweep_untraced, "--trace-bandwidth", triad), "--trace-bandwidth", "needs --trace"},
  };
  for (const BadCase& c : cases) {
    const auto bad = clothbench_test::run(c.arguments);
    EXPECT_EQ(bad.exit_code, 2) << c.arguments << "\n" << bad.output;
    EXPECT_THAT(bad.output, HasSubstr(c.flag)) << c.arguments;
    EXPECT_THAT(bad.output, HasSubstr(c.expected)) << c.arguments;
  }
  EXPECT_FALSE(fs::exists(dir / "r.cbtrace")) << "no trace is written from bad input";
}

/// `from` rewritten as a trace of format 1: its first line, and loop records without their
/// last 8 bytes (bytes_per_element).
void write_format1(const fs::path& from, const fs::path& to) {
  std::ifstream in(from, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t first = bytes.find('\n'), second = bytes.find('\n', first + 1);
  const auto loops = nlohmann::json::parse(bytes.substr(first + 1, second - first - 1))
                         .at("loop_count")
                         .get<std::size_t>();
  std::string out = "clothbench-trace 1" + bytes.substr(first, second + 1 - first);
  for (std::size_t i = 0; i < loops; ++i) {
    out += bytes.substr(second + 1 + i * sizeof(kernels::LoopRecord), 40);
  }
  out += bytes.substr(second + 1 + loops * sizeof(kernels::LoopRecord));
  std::ofstream(to, std::ios::binary) << out;
}

TEST(PredictCommand, BandwidthCeilingFromATriadFile) {
  const std::string trace = clothbench_test::quote(recorded_trace().string());
  const fs::path dir = clothbench_test::fresh_dir("predict_bandwidth");
  const fs::path slow = synthetic_triad(dir, "slow.json", "1e3");
  const fs::path fast = synthetic_triad(dir, "fast.json", "1e18");
  auto predict = [&](const std::string& file, const fs::path& triad, const fs::path& json) {
    return clothbench_test::run("predict " + file + " --threads 1,2,64 --schedulers static " +
                                "--bandwidth " + clothbench_test::quote(triad.string()) +
                                " --json " + clothbench_test::quote(json.string()));
  };
  // 1 kB/s, flat: every loop instance that moves a byte beat it in the trace, so each is held
  // to its own 1-thread time at every thread count: nothing is bound at 1 thread, and no row
  // is faster than the 1-thread row.
  const auto bound = predict(trace, slow, dir / "slow-out.json");
  ASSERT_EQ(bound.exit_code, 0) << bound.output;
  EXPECT_THAT(bound.output, HasSubstr("Bandwidth ceiling: " + slow.string() + ": STREAM triad"));
  EXPECT_THAT(bound.output, HasSubstr("bandwidth beyond 2 cores assumed flat"));
  EXPECT_THAT(bound.output, HasSubstr("moved their bytes faster than the 1-thread triad"));
  const auto slow_rows = clothbench_test::read_json(dir / "slow-out.json")["rows"];
  const harness::TraceWorkload w =
      harness::build_workload(harness::read_trace(recorded_trace()), "d1.cbtrace");
  const std::size_t loops = w.loops.size();
  const auto moving = std::count_if(w.loops.begin(), w.loops.end(),
                                    [](const harness::TracedLoop& l) { return l.bytes > 0.0; });
  EXPECT_GT(moving, 0);
  EXPECT_EQ(slow_rows[0]["bandwidth_bound_loops"].get<std::int64_t>(), 0);
  for (std::size_t k = 1; k < slow_rows.size(); ++k) {
    const auto& r = slow_rows[k];
    EXPECT_GT(r["bandwidth_bound_loops"].get<std::int64_t>(), 0) << r.dump();
    EXPECT_LE(r["bandwidth_bound_loops"].get<std::int64_t>(), moving) << r.dump();
    EXPECT_GT(r["bandwidth_added_seconds"].get<double>(), 0.0) << r.dump();
    EXPECT_GE(r["time_seconds"].get<double>(),
              slow_rows[0]["time_seconds"].get<double>() * (1.0 - 1e-12))
        << r.dump();
  }
  EXPECT_EQ(slow_rows[2]["bandwidth_basis"], "flat beyond 2 cores: the 2-core triad");
  // 1 EB/s: nothing is bound.
  const auto free = predict(trace, fast, dir / "fast-out.json");
  ASSERT_EQ(free.exit_code, 0) << free.output;
  // The document is kept in a local: a range-for over a member of a temporary reads freed
  // memory (the temporary dies before the loop runs).
  const auto fast_rows = clothbench_test::read_json(dir / "fast-out.json")["rows"];
  for (const auto& r : fast_rows) {
    EXPECT_EQ(r["bandwidth_bound_loops"], 0) << r.dump();
  }

  // A trace of format 1 loads; its loops carry no bytes, so nothing is bound, and it says so.
  write_format1(recorded_trace(), dir / "old.cbtrace");
  const auto old =
      predict(clothbench_test::quote((dir / "old.cbtrace").string()), slow, dir / "old-out.json");
  ASSERT_EQ(old.exit_code, 0) << old.output;
  EXPECT_THAT(old.output, HasSubstr(std::to_string(loops) + " of " + std::to_string(loops) +
                                    " loop instances carry no bytes per element"));
  const auto old_json = clothbench_test::read_json(dir / "old-out.json");
  EXPECT_EQ(old_json["trace"]["loop_instances_without_bytes"], loops);
  for (const auto& r : old_json["rows"]) EXPECT_EQ(r["bandwidth_bound_loops"], 0) << r.dump();

  // Bad triad files are refused naming the flag and the file; exit 2.
  std::ofstream(dir / "no-rate.json")
      << R"({"benchmarks": [{"name": "triad/8/1/real_time", "threads": 1}]})";
  const std::vector<std::pair<fs::path, std::string>> cases = {
      {synthetic_triad(dir, "negative.json", "-5"), "bytes_per_second -5"},
      {dir / "no-rate.json", "no bytes_per_second"},
      {dir / "none.json", "cannot open the bandwidth file"},
  };
  for (const auto& [file, expected] : cases) {
    const auto bad = clothbench_test::run("predict " + trace + " --bandwidth " +
                                          clothbench_test::quote(file.string()));
    EXPECT_EQ(bad.exit_code, 2) << file << "\n" << bad.output;
    EXPECT_THAT(bad.output, HasSubstr("clothbench predict: --bandwidth: " + file.string()));
    EXPECT_THAT(bad.output, HasSubstr(expected)) << file;
  }
}

}  // namespace
}  // namespace clothbench
