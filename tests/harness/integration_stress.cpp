// The real `clothbench stress` binary on two small cells of the quick matrix: exit code, the
// per-cell and overall PASSED lines, stress.json (schema, fields, no NaN), stress.md (the
// table and the result line) and stress.csv; --only that matches nothing and a bad --size are
// bad input (exit 2); Ctrl-C stops the matrix after the step in progress and keeps the
// finished cells.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "harness/stress/stress_report.hpp"
#include "tests/harness/clothbench_process.hpp"

namespace {

namespace fs = std::filesystem;
using clothbench_test::fresh_dir;
using clothbench_test::Outcome;
using clothbench_test::quote;
using clothbench_test::read_json;
using clothbench_test::read_text;
using clothbench_test::run;
using nlohmann::json;
using testing::HasSubstr;

// Two cells of a few CG iterations per step each: seconds even in sanitizer builds.
constexpr const char* kCells = "dt-1e-4,fabric-soft-x10";

class StressBinary : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(clothbench_test::binary()))
        << "clothbench binary not built: " << clothbench_test::binary();
  }
};

TEST_F(StressBinary, TwoQuickCellsPassAndEveryOutputHasItsStructure) {
  const fs::path out = fresh_dir("stress");
  const Outcome o = run("stress --size quick --only " + quote(kCells) + " --threads 1 --out " +
                        quote(out.string()));
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_THAT(o.output, HasSubstr("clothbench stress: quick size, 2 of "));
  EXPECT_THAT(o.output, testing::ContainsRegex("\n  dt-1e-4 +30/30 steps .* PASSED\n"));
  EXPECT_THAT(o.output, testing::ContainsRegex("\n  fabric-soft-x10 +30/30 steps .* PASSED\n"));
  EXPECT_THAT(o.output, HasSubstr("\nVerification: PASSED (2 of 2 cells passed)\n"));

  const json d = read_json(out / "stress.json");
  const auto problems = clothbench::harness::validate_stress_document(d);
  EXPECT_TRUE(problems.empty()) << problems.front();
  EXPECT_TRUE(d["complete"].get<bool>());
  EXPECT_TRUE(d["passed"].get<bool>());
  EXPECT_EQ(d["settings"]["size"], "quick");
  EXPECT_EQ(d["settings"]["threads"], 1);
  EXPECT_EQ(d["settings"]["only"], kCells);
  EXPECT_EQ(d["summary"]["finished"], 2);
  EXPECT_EQ(d["summary"]["passed"], 2);
  ASSERT_EQ(d["cells"].size(), 2u);
  EXPECT_EQ(d["cells"][0]["name"], "fabric-soft-x10") << "cells run in the matrix's order";
  const json& small_step = d["cells"][1];
  EXPECT_EQ(small_step["name"], "dt-1e-4");
  EXPECT_EQ(small_step["axis"], "time step");
  EXPECT_DOUBLE_EQ(small_step["time_step_s"].get<double>(), 1e-4);
  EXPECT_EQ(small_step["steps"]["completed"], small_step["steps"]["planned"]);
  EXPECT_TRUE(small_step["non_finite"].is_null());
  EXPECT_EQ(small_step["mass_drift"].get<double>(), 0.0);
  EXPECT_LT(small_step["max_penetration_m"]["particles"].get<double>(),
            small_step["contact_distance_m"].get<double>());
  EXPECT_GT(small_step["cg"]["iterations"].get<int>(), 0);
  // The base scene's automatic solver is Newton: its iterations are named so, with the inner
  // PCG iterations beside them (at least one a Newton iteration).
  EXPECT_EQ(small_step["cg"]["method"], "newton");
  EXPECT_GE(small_step["cg"]["linear_iterations"].get<std::int64_t>(),
            small_step["cg"]["iterations"].get<std::int64_t>());
  EXPECT_TRUE(small_step["cost_trend"]["quarter_means"].is_array());
  EXPECT_FALSE(small_step["cost_trend"]["grows_without_bound"].get<bool>());
  EXPECT_TRUE(small_step["failures"].empty());
  // Each cell's peak resident memory is its own (the high-water mark reset before its set-up).
  for (const json& cell : d["cells"]) {
    EXPECT_EQ(cell["memory"]["scope"], "run") << cell["name"];
    EXPECT_GE(cell["memory"]["peak_resident_bytes"].get<std::uint64_t>(),
              cell["memory"]["start_resident_bytes"].get<std::uint64_t>())
        << cell["name"];
    EXPECT_GT(cell["memory"]["start_resident_bytes"].get<std::uint64_t>(), 0u) << cell["name"];
  }
  EXPECT_THAT(o.output, testing::ContainsRegex(
                            "\n  dt-1e-4 +30/30 steps  strain -?0\\.[0-9]{4}\\.\\.0\\.[0-9]{4}  "
                            "penetration .* s  peak [0-9.]+ MiB  PASSED\n"));
  EXPECT_GT(d["cells"][0]["max_strain"].get<double>(), small_step["max_strain"].get<double>())
      << "a 10x softer cloth stretches more";
  EXPECT_THAT(read_text(out / "stress.json"), testing::Not(HasSubstr("NaN")));

  const std::string md = read_text(out / "stress.md");
  EXPECT_THAT(md, HasSubstr("# Stress matrix (quick)"));
  EXPECT_THAT(
      md, HasSubstr("| cell | change | particles | steps | first non-finite | strain min / max |"));
  EXPECT_THAT(
      md, testing::ContainsRegex("\n\\| dt-1e-4 \\| dt = 0.0001 s \\| 17 x 17 \\| 30 / 30 "
                                 "\\| - \\| -?0\\.[0-9]{4} / 0\\.[0-9]{4} \\|.*\\| PASSED \\|\n"));
  EXPECT_THAT(md, testing::ContainsRegex("\n\\| fabric-soft-x10 \\|.*\\| PASSED \\|\n"));
  EXPECT_THAT(md, testing::ContainsRegex("\\| Newton [0-9]+ / [0-9]+ \\(PCG [0-9]+ a step\\) \\|"));
  EXPECT_THAT(md, HasSubstr("\nResult: PASSED (2 of 2 cells passed)\n"));

  const std::string csv = read_text(out / "stress.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 3);
  EXPECT_EQ(csv.rfind("cell,axis,change,particles_i,particles_j,time_step_s,", 0), 0u);
  EXPECT_THAT(csv, HasSubstr("\ndt-1e-4,time step,dt = 0.0001 s,17,17,"));
  EXPECT_THAT(csv, HasSubstr(",solver_method,cg_iterations,"));
  EXPECT_THAT(csv, HasSubstr(",newton,"));
  fs::remove_all(out);
}

TEST_F(StressBinary, BadSelectionAndSizeAreBadInput) {
  const fs::path out = fresh_dir("stress-bad");
  const Outcome none = run("stress --only 'no-such-*' --out " + quote(out.string()));
  EXPECT_EQ(none.exit_code, 2) << none.output;
  EXPECT_THAT(none.output, HasSubstr("clothbench stress: --only: 'no-such-*' matches no cell of "
                                     "the quick matrix (base, fabric-wool-suiting,"));
  const Outcome empty_item = run("stress --only 'base,,dt-*' --out " + quote(out.string()));
  EXPECT_EQ(empty_item.exit_code, 2) << empty_item.output;
  EXPECT_THAT(empty_item.output, HasSubstr("--only: empty item in list 'base,,dt-*'"));
  const Outcome size = run("stress --size medium --out " + quote(out.string()));
  EXPECT_EQ(size.exit_code, 2) << size.output;
  EXPECT_THAT(size.output, HasSubstr("--size"));
  EXPECT_FALSE(fs::exists(out)) << "nothing is written for bad input";
}

TEST_F(StressBinary, CtrlCKeepsTheFinishedCells) {
  const fs::path out = fresh_dir("stress-ctrl-c");
  const fs::path log = out.string() + ".log";
  // The first cell takes a moment, the second (300 steps) far longer than the signal needs.
  const pid_t child = clothbench_test::spawn(
      {"stress", "--only", "dt-1e-4,long", "--threads", "1", "--out", out.string()}, log);
  ASSERT_NE(child, 0);
  std::size_t cells = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(600);
  while (cells < 1 && std::chrono::steady_clock::now() < deadline) {
    try {
      if (fs::exists(out / "stress.json")) cells = read_json(out / "stress.json")["cells"].size();
    } catch (const json::exception&) {
      ADD_FAILURE() << "stress.json was torn: writes must be atomic";
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  kill(child, SIGINT);
  int status = 0;
  waitpid(child, &status, 0);
  const std::string output = read_text(log);
  ASSERT_EQ(cells, 1u) << output;
  ASSERT_TRUE(WIFEXITED(status)) << "Ctrl-C must not kill the matrix: " << output;
  EXPECT_EQ(WEXITSTATUS(status), 130) << output;
  EXPECT_THAT(output, HasSubstr("clothbench stress: stopping after the current step"));
  EXPECT_THAT(output, HasSubstr("clothbench stress: stopped by SIGINT: 1 of 2 cells are finished "
                                "and kept in " +
                                (out / "stress.json").string()));
  const json d = read_json(out / "stress.json");
  EXPECT_FALSE(d["complete"].get<bool>());
  ASSERT_EQ(d["cells"].size(), 1u) << "the interrupted cell is dropped";
  EXPECT_EQ(d["cells"][0]["name"], "dt-1e-4");
  EXPECT_TRUE(clothbench::harness::validate_stress_document(d).empty());
  EXPECT_THAT(read_text(out / "stress.md"), HasSubstr("1 of 2 cells finished"));
  fs::remove_all(out);
  fs::remove(log);
}

}  // namespace
