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
//    file with exit code 2; `--validate` predicts the rows of a sweep from its traces.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
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
      " --trace-dir " + clothbench_test::quote((dir / "traces").string()));
  ASSERT_EQ(out.exit_code, 0) << out.output;
  EXPECT_THAT(out.output, HasSubstr("| static@blocks | 2 | dynamic_1_blocks-1t.cbtrace |"));
  EXPECT_THAT(out.output,
              HasSubstr("| active-lists@active | 2 | active-lists_active-1t.cbtrace |"));
  EXPECT_THAT(out.output, HasSubstr("6 rows: mean |error|"));
}

}  // namespace
}  // namespace clothbench
