// The real `clothbench` binary run as a child process on a tiny scene: the sweep document's
// schema, the table command, the accounting identity on real runs, resume after the process
// is killed mid-sweep, and the CLI's bad-input errors (exit code 2, clear messages).
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "harness/sweep/sweep_document.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const fs::path kScene = fs::path(CLOTHBENCH_SOURCE_DIR) / "tests/data/scenes/sweep-tiny.toml";

/// The clothbench binary of this build (tests/CMakeLists.txt defines its path), or
/// $CLOTHBENCH_BINARY when set.
fs::path binary() {
  if (const char* b = std::getenv("CLOTHBENCH_BINARY"); b != nullptr && *b != '\0') return b;
  return CLOTHBENCH_BINARY;
}

struct Outcome {
  int exit_code = -1;
  std::string output;  ///< stdout and stderr
};

std::string quote(const std::string& s) { return "'" + s + "'"; }

/// Runs clothbench with `arguments` (already shell-quoted where needed).
Outcome run(const std::string& arguments) {
  // A hung child (a kernel deadlock) fails the test instead of blocking it.
  const std::string command =
      "timeout -s KILL 300 " + quote(binary().string()) + " " + arguments + " 2>&1";
  Outcome outcome;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return outcome;
  char buffer[4096];
  while (std::fgets(buffer, sizeof buffer, pipe) != nullptr) outcome.output += buffer;
  const int status = pclose(pipe);
  outcome.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return outcome;
}

json read_json(const fs::path& file) {
  std::ifstream in(file);
  return json::parse(in);
}

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("clothbench-test-" + name + "-" +
                                                    std::to_string(getpid()));
  fs::remove_all(dir);
  return dir;
}

class SweepBinary : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(binary())) << "clothbench binary not built: " << binary();
  }
};

TEST_F(SweepBinary, DocumentSchemaTableAndAccountingIdentity) {
  const fs::path out = fresh_dir("schema");
  const Outcome o = run("sweep " + quote(kScene.string()) +
                        " --schedulers static,dynamic:1,guided:1,active-lists --threads 1,2 "
                        "--repeat 2 --no-plots --quiet --out " + quote(out.string()));
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const json d = read_json(out / "sweep.json");
  const auto problems = clothbench::harness::validate_sweep_document(d);
  EXPECT_TRUE(problems.empty()) << problems.front();
  EXPECT_TRUE(d["complete"].get<bool>());
  EXPECT_EQ(d["rows"].size(), 8u);
  EXPECT_TRUE(std::regex_match(d["created_utc"].get<std::string>(),
                               std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ)")));
  EXPECT_TRUE(std::regex_match(d["scene"]["hash"].get<std::string>(), std::regex("[0-9a-f]{16}")));
  EXPECT_TRUE(d["openmp_environment"].contains("OMP_NUM_THREADS"));
  EXPECT_TRUE(d["machine"].contains("cpu"));

  for (const json& row : d["rows"]) {
    const std::string where = row["scheduler_canonical"].get<std::string>() + " x " +
                              std::to_string(row["threads"].get<int>());
    EXPECT_TRUE(row["verification"]["passed"].get<bool>()) << where;
    EXPECT_TRUE(row["verification"]["bit_identical"].get<bool>()) << where;
    EXPECT_EQ(row["verification"]["state_digest"], d["reference"]["state_digest"]) << where;
    EXPECT_EQ(row["binding"]["threads"].size(), row["threads"].get<std::size_t>()) << where;
    // Accounting identity: the four components add up to the steps' time (an identity of the
    // recorded clocks, to rounding), and the steps' time plus what lies outside the steps is
    // the wall time. No speed is asserted.
    const json& a = row["accounting"];
    ASSERT_TRUE(a.is_object()) << where;
    const double wall = a["wall_seconds"];
    const double step = a["step_seconds"];
    const double parts = a["sequential_overhead_seconds"].get<double>() +
                         a["parallel_overhead_seconds"].get<double>() +
                         a["load_imbalance_seconds"].get<double>() +
                         a["parallel_work_seconds"].get<double>();
    EXPECT_NEAR(parts, step, 1e-12 + 1e-12 * wall) << where;
    EXPECT_NEAR(step + a["unaccounted_seconds"].get<double>(), wall, 1e-12 + 1e-12 * wall) << where;
    EXPECT_GE(a["unaccounted_seconds"].get<double>(), 0.0) << where;
    const double tolerance = 0.02 * wall + 50e-6 * row["steps"].get<double>();
    // Every component is a time: non-negative up to the same tolerance.
    for (const char* k : {"sequential_overhead_seconds", "parallel_overhead_seconds",
                          "load_imbalance_seconds", "parallel_work_seconds"}) {
      EXPECT_GE(a[k].get<double>(), -tolerance) << where << " " << k;
    }
    // Mean thread work computed per loop equals the per-thread totals' mean.
    double total = 0.0;
    for (const json& w : a["thread_work_seconds"]) total += w.get<double>();
    EXPECT_NEAR(total / row["threads"].get<double>(), a["parallel_work_seconds"].get<double>(),
                1e-9 + 1e-9 * wall)
        << where;
    if (row["threads"] == 1) {
      EXPECT_DOUBLE_EQ(row["derived"]["speedup"].get<double>(), 1.0) << where;
      EXPECT_NEAR(a["load_imbalance_seconds"].get<double>(), 0.0, 1e-12) << where;
    }
  }

  const Outcome md = run("table " + quote((out / "sweep.json").string()));
  ASSERT_EQ(md.exit_code, 0) << md.output;
  EXPECT_TRUE(std::regex_search(
      md.output, std::regex(R"(\n\| 2 \| [-0-9.e]+ \| [-0-9.e]+ \| [-0-9.e]+ \| [-0-9.]+ \| [0-9.e-]+ \| )"
                            R"([0-9.e-]+-[0-9.e-]+ \| \d+\.\d\d \| \d+\.\d\d \| \d+\.\d\d \| PASSED \|\n)")))
      << md.output;
  for (const char* heading : {"## static@blocks", "## dynamic:1@blocks", "## guided:1@blocks",
                              "## active-lists@active"}) {
    EXPECT_NE(md.output.find(heading), std::string::npos) << heading;
  }
  const Outcome csv = run("table --format csv " + quote((out / "sweep.json").string()));
  ASSERT_EQ(csv.exit_code, 0) << csv.output;
  EXPECT_EQ(std::count(csv.output.begin(), csv.output.end(), '\n'), 9);
  fs::remove_all(out);
}

/// (scheduler, threads, digest, passed) of every row, the part of a row that must not
/// depend on whether the sweep was interrupted.
std::set<std::tuple<std::string, int, std::string, bool>> row_keys(const json& d) {
  std::set<std::tuple<std::string, int, std::string, bool>> keys;
  for (const json& r : d["rows"]) {
    keys.emplace(r["scheduler_canonical"], r["threads"], r["verification"]["state_digest"],
                 r["verification"]["passed"]);
  }
  return keys;
}

TEST_F(SweepBinary, ResumeAfterKillMatchesUninterruptedSweep) {
  const fs::path killed = fresh_dir("killed"), whole = fresh_dir("whole");
  const std::vector<std::string> grid = {"--schedulers", "static,dynamic:2,guided:1,active-lists",
                                         "--threads", "1,2", "--repeat", "12",
                                         "--no-plots", "--quiet", "--out"};
  std::vector<std::string> args = {binary().string(), "sweep", kScene.string()};
  args.insert(args.end(), grid.begin(), grid.end());
  args.push_back(killed.string());
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t child = 0;
  ASSERT_EQ(posix_spawn(&child, argv[0], nullptr, nullptr, argv.data(), environ), 0);

  // Kill it once two rows are on disk (and well before the last of the 8).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  std::size_t rows_before_kill = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    try {
      if (fs::exists(killed / "sweep.json")) rows_before_kill = read_json(killed / "sweep.json")["rows"].size();
    } catch (const json::exception&) {
      ADD_FAILURE() << "sweep.json was torn: writes must be atomic";
    }
    if (rows_before_kill >= 2) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the sweep finished before it could be killed";
  const json partial = read_json(killed / "sweep.json");
  EXPECT_FALSE(partial["complete"].get<bool>());
  EXPECT_GE(partial["rows"].size(), 2u);
  EXPECT_LT(partial["rows"].size(), 8u);
  const auto kept = row_keys(partial);

  std::string grid_text;
  for (const auto& g : grid) grid_text += quote(g) + " ";
  const Outcome resumed = run("sweep " + quote(kScene.string()) + " " + grid_text +
                              quote(killed.string()) + " --resume");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  const json after = read_json(killed / "sweep.json");
  EXPECT_TRUE(after["complete"].get<bool>());
  EXPECT_EQ(after["rows"].size(), 8u);
  for (std::size_t i = 0; i < partial["rows"].size(); ++i) {  // finished rows are kept as they were
    EXPECT_EQ(after["rows"][i]["time_seconds"], partial["rows"][i]["time_seconds"]);
  }
  const auto all = row_keys(after);
  for (const auto& k : kept) EXPECT_TRUE(all.count(k));

  const Outcome uninterrupted =
      run("sweep " + quote(kScene.string()) + " " + grid_text + quote(whole.string()));
  ASSERT_EQ(uninterrupted.exit_code, 0) << uninterrupted.output;
  EXPECT_EQ(row_keys(read_json(whole / "sweep.json")), all);

  // Resume refuses a result made with other settings.
  const Outcome mismatch = run("sweep " + quote(kScene.string()) + " --steps 3 --quiet --no-plots "
                               "--resume --out " + quote(killed.string()));
  EXPECT_EQ(mismatch.exit_code, 2) << mismatch.output;
  EXPECT_NE(mismatch.output.find("--resume"), std::string::npos) << mismatch.output;
  fs::remove_all(killed);
  fs::remove_all(whole);
}

TEST_F(SweepBinary, BadInputExitsWithCodeTwoAndSaysWhy) {
  const std::string out = " --quiet --no-plots --out " + quote(fresh_dir("bad").string());
  const Outcome unknown =
      run("sweep " + quote(kScene.string()) + " --schedulers static,dynamc:2" + out);
  EXPECT_EQ(unknown.exit_code, 2) << unknown.output;
  EXPECT_NE(unknown.output.find("dynamc"), std::string::npos) << unknown.output;
  EXPECT_NE(unknown.output.find("--schedulers"), std::string::npos) << unknown.output;

  const Outcome zero = run("sweep " + quote(kScene.string()) + " --threads 0,1" + out);
  EXPECT_EQ(zero.exit_code, 2) << zero.output;
  EXPECT_NE(zero.output.find("--threads: '0'"), std::string::npos) << zero.output;

  const Outcome too_many = run("sweep " + quote(kScene.string()) + " --threads 100000" + out);
  EXPECT_EQ(too_many.exit_code, 2) << too_many.output;
  EXPECT_NE(too_many.output.find("--oversubscribe"), std::string::npos) << too_many.output;

  const Outcome missing = run("sweep /nonexistent/scene.toml" + out);
  EXPECT_EQ(missing.exit_code, 2) << missing.output;
  EXPECT_NE(missing.output.find("/nonexistent/scene.toml"), std::string::npos) << missing.output;

  const Outcome directory = run("sweep " + quote(CLOTHBENCH_SOURCE_DIR) + out);
  EXPECT_EQ(directory.exit_code, 2) << directory.output;

  const Outcome not_sweep = run("table " + quote(kScene.string()));
  EXPECT_EQ(not_sweep.exit_code, 2) << not_sweep.output;
  EXPECT_NE(not_sweep.output.find("not JSON"), std::string::npos) << not_sweep.output;

  const Outcome bad_format = run("table x.json --format html");
  EXPECT_EQ(bad_format.exit_code, 2) << bad_format.output;
}

}  // namespace
