// clothbench-micro (harness/micro, Google Benchmark) smoke test: every benchmark family is
// registered at its measuring sizes (the triad at every thread count up to the cores), and with
// CLOTHBENCH_MICRO_SMOKE=1 every benchmark runs once at a tiny size (about 20 s in all), exits 0
// and writes JSON whose results and counters are finite.
// Needs a build with CLOTHBENCH_BUILD_BENCHMARKS=ON (tests/CMakeLists.txt passes the binary's
// path); skipped otherwise (the ASan build of scripts/test --sanitize turns benchmarks off).
// No timing is asserted.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <thread>

#include "harness/machine/git_revision.hpp"
#include "harness/machine/machine_context.hpp"
#include "tests/harness/clothbench_process.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::HasSubstr;

#ifdef CLOTHBENCH_MICRO_BINARY
const fs::path kMicro = CLOTHBENCH_MICRO_BINARY;
#endif

/// Exit code and output (stdout; stderr to `errors` when given) of clothbench-micro `arguments`.
clothbench_test::Outcome run_micro([[maybe_unused]] const std::string& arguments,
                                   [[maybe_unused]] const fs::path& errors = "/dev/null") {
#ifdef CLOTHBENCH_MICRO_BINARY
  return clothbench_test::run_command("timeout -s KILL 300 " +
                                      clothbench_test::quote(kMicro.string()) + " " + arguments +
                                      " 2>" + clothbench_test::quote(errors.string()));
#else
  return {};
#endif
}

/// run_micro with CLOTHBENCH_MICRO_SMOKE=1.
clothbench_test::Outcome run_micro_smoke(const std::string& arguments,
                                         const fs::path& errors = "/dev/null") {
  setenv("CLOTHBENCH_MICRO_SMOKE", "1", 1);
  clothbench_test::Outcome o = run_micro(arguments, errors);
  unsetenv("CLOTHBENCH_MICRO_SMOKE");
  return o;
}

class MicroBenchmarks : public ::testing::Test {
 protected:
  void SetUp() override {
#ifndef CLOTHBENCH_MICRO_BINARY
    GTEST_SKIP() << "built without CLOTHBENCH_BUILD_BENCHMARKS: no clothbench-micro";
#else
    ASSERT_TRUE(fs::exists(kMicro)) << "clothbench-micro not built: " << kMicro;
#endif
  }
};

TEST_F(MicroBenchmarks, EveryFamilyIsRegistered) {
  const clothbench_test::Outcome o = run_micro("--benchmark_list_tests");
  ASSERT_EQ(o.exit_code, 0) << o.output;
  for (const char* family :
       {"list_rebuild/sequential/", "list_rebuild/parallel_prefix_sum/", "mesh_rewrite/",
        "broad_phase_evaluation/box_101/", "broad_phase_steps/box_101/", "gradient/potential/101/",
        "gradient/potential_vector/101/", "newton_operator/hessian_apply/101/",
        "newton_operator/vcycle_apply/101/", "newton_operator/vcycle_apply_one_line/101/",
        "newton_operator/vcycle_factor/101/",
        "triad/", "skip_contact/", "skip_amrc/", "skip_inactive/active_lists/",
        "scheduling_overhead/static@blocks/", "scheduling_overhead/active-lists@active/",
        "scheduling_overhead_dynamic_k/falls_with_k/", "scheduling_overhead_epcc_body/dynamic:1/"}) {
    std::string line_start = "\n";  // (not "\n" + family: GCC 12 warns falsely, -Wrestrict)
    line_start += family;
    EXPECT_THAT(o.output, HasSubstr(line_start)) << family;
  }
}

TEST_F(MicroBenchmarks, TheTriadRunsAtEveryThreadCountUpToThePhysicalCores) {
  // The predictor's bandwidth ceiling reads B(P) at every P from 1 to the cores.
  const clothbench_test::Outcome o = run_micro("--benchmark_list_tests --benchmark_filter=^triad");
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const int cores = clothbench::harness::physical_cores();
  for (int threads = 1; threads <= cores; ++threads) {
    EXPECT_THAT(o.output,
                testing::ContainsRegex("triad/[0-9]+/" + std::to_string(threads) + "/real_time"))
        << threads << " threads";
  }
  EXPECT_THAT(o.output, testing::Not(testing::ContainsRegex(
                            "triad/[0-9]+/" + std::to_string(cores + 1) + "/real_time")));
}

/// Every number in a benchmark's JSON entry (its counters included) is finite. Google
/// Benchmark writes a NaN or infinity as a bare token, which json::parse already refuses.
void expect_finite_numbers(const json& b) {
  for (const auto& [key, value] : b.items()) {
    if (value.is_number()) {
      EXPECT_TRUE(std::isfinite(value.get<double>())) << b["name"] << ": " << key << " = " << value;
    }
  }
}

/// The scheduling-overhead benchmarks of `d` (a JSON run at `threads` threads) ran at 1 thread
/// and at `threads` (static@blocks at both), and counted the chunks their per-chunk figure
/// divides by exactly: ceil(n / k) for dynamic:k, one per thread for
/// static and active-lists, the same count in every loop of those, and the per-chunk overhead is
/// the per-loop overhead over one thread's share of them.
void expect_exact_chunk_counts(const json& d, int threads) {
  int dynamic_checked = 0;
  std::set<int> static_team_sizes;
  for (const json& b : d["benchmarks"]) {
    const std::string name = b["name"];
    if (name.rfind("scheduling_overhead/", 0) == 0) {
      // Every scheduler runs at 1 thread and at the run's team size (`.../threads:T/`).
      const int team = static_cast<int>(b["threads"].get<double>());
      EXPECT_TRUE(team == 1 || team == threads) << name;
      EXPECT_NE(name.find("/threads:" + std::to_string(team) + "/"), std::string::npos) << name;
      if (name.rfind("scheduling_overhead/static@blocks/", 0) == 0) static_team_sizes.insert(team);
      const auto n = static_cast<long long>(b["iterations_per_loop"].get<double>());
      const auto chunks = static_cast<long long>(b["chunks_per_loop"].get<double>());
      EXPECT_EQ(n, 1024LL * team) << name;
      // The core-to-core round trip is measured with a pair of threads on separate cores only.
      for (const char* key : {"core_round_trip_ns_before", "core_round_trip_ns_after"}) {
        if (team >= 2 && std::thread::hardware_concurrency() >= 2) {
          EXPECT_GT(b[key].get<double>(), 0.0) << name << ": " << key;
        } else {
          EXPECT_EQ(b[key].get<double>(), 0.0) << name << ": " << key;
        }
      }
      const double per_thread = std::max(1.0, static_cast<double>(chunks) / team);
      EXPECT_NEAR(b["overhead_chunk_ns"].get<double>(),
                  b["overhead_loop_us"].get<double>() * 1e3 / per_thread,
                  1e-9 * std::abs(b["overhead_loop_us"].get<double>() * 1e3) + 1e-12)
          << name;
      for (int k : {1, 2, 3, 64}) {
        if (name.rfind("scheduling_overhead/dynamic:" + std::to_string(k) + "@", 0) == 0) {
          EXPECT_EQ(chunks, (n + k - 1) / k) << name;
          EXPECT_EQ(b["chunk_count_constant"].get<double>(), 1.0) << name;
          ++dynamic_checked;
        }
      }
      if (name.rfind("scheduling_overhead/static@blocks/", 0) == 0 ||
          name.rfind("scheduling_overhead/active-lists@active/", 0) == 0) {
        EXPECT_EQ(chunks, team) << name;
        EXPECT_EQ(b["chunk_count_constant"].get<double>(), 1.0) << name;
      }
    }
    if (name.rfind("scheduling_overhead_dynamic_k/", 0) == 0) {
      EXPECT_EQ(b["chunk_counts_exact"].get<double>(), 1.0) << name;
      EXPECT_EQ(b["chunks_per_loop_dynamic1"].get<double>(), 1024.0 * threads) << name;
      EXPECT_EQ(b["chunks_per_loop_dynamic2"].get<double>(), 512.0 * threads) << name;
      EXPECT_EQ(b["chunks_per_loop_dynamic4"].get<double>(), 256.0 * threads) << name;
      EXPECT_THAT(b.value("label", ""), HasSubstr("not judged (smoke)")) << name;
      ++dynamic_checked;
    }
  }
  EXPECT_GE(dynamic_checked, 4) << "dynamic:1, 2, 3 and the dynamic:k comparison ran";
  const std::set<int> both = threads > 1 ? std::set<int>{1, threads} : std::set<int>{1};
  EXPECT_EQ(static_team_sizes, both) << "static@blocks at 1 thread and at the run's team size";
}

TEST_F(MicroBenchmarks, EveryBenchmarkRunsOnceAtASmokeSizeWithFiniteCounters) {
  // CLOTHBENCH_MICRO_SMOKE=1 (harness/micro/smoke.hpp): every benchmark at a tiny size.
  const clothbench_test::Outcome listed = run_micro_smoke("--benchmark_list_tests");
  ASSERT_EQ(listed.exit_code, 0) << listed.output;
  std::set<std::string> expected;
  std::istringstream lines(listed.output);
  for (std::string line; std::getline(lines, line);) {
    if (!line.empty()) expected.insert(line);
  }
  ASSERT_GE(expected.size(), 40u) << listed.output;
  // The sizes are the smoke sizes, not the measuring ones.
  EXPECT_TRUE(expected.count("gradient/potential/17/1/real_time")) << listed.output;
  EXPECT_FALSE(expected.count("gradient/potential/1001/1/real_time")) << listed.output;

  const fs::path errors = clothbench_test::fresh_dir("micro") += ".log";
  const clothbench_test::Outcome o =
      run_micro_smoke("--benchmark_min_time=0.001 --benchmark_format=json", errors);
  ASSERT_EQ(o.exit_code, 0) << o.output << clothbench_test::read_text(errors);
  fs::remove(errors);
  const json d = json::parse(o.output);  // throws (and fails the test) unless it is JSON
  EXPECT_GT(d["context"]["num_cpus"].get<int>(), 0);
  EXPECT_THAT(d["context"].value("clothbench_micro_smoke", ""), HasSubstr("not measurements"));
  // The machine context every clothbench result stores, with the code revision, travels with
  // the figures (once: no flat copy of the revision beside it).
  EXPECT_FALSE(d["context"].contains("clothbench_revision")) << d["context"].dump();
  const json machine = json::parse(d["context"].value("clothbench_machine", "null"));
  ASSERT_TRUE(machine.is_object()) << d["context"].dump();
  EXPECT_EQ(machine["build"]["git_revision"], clothbench::harness::git_revision());
  EXPECT_FALSE(machine["cpu"]["model"].get<std::string>().empty());
  EXPECT_GT(machine["cpu"]["cores"].get<int>(), 0);
  std::set<std::string> ran;
  for (const json& b : d["benchmarks"]) {
    const std::string name = b["name"];
    ran.insert(name);
    EXPECT_FALSE(b.contains("error_occurred") && b["error_occurred"].get<bool>())
        << name << ": " << b.value("error_message", "");
    EXPECT_GE(b["iterations"].get<long long>(), 1) << name;
    expect_finite_numbers(b);
    EXPECT_GT(b["real_time"].get<double>(), 0.0) << name;
  }
  EXPECT_EQ(ran, expected) << "every listed benchmark ran exactly under its name";
  // A few families' own counters, present and positive.
  for (const json& b : d["benchmarks"]) {
    const std::string name = b["name"];
    auto positive = [&](const char* key) {
      ASSERT_TRUE(b.contains(key) && b[key].is_number()) << key << " in " << b.dump();
      EXPECT_GT(b[key].get<double>(), 0.0) << name << ": " << key;
    };
    if (name.rfind("list_rebuild/", 0) == 0) positive("slots_per_second");
    if (name.rfind("gradient/", 0) == 0) positive("elements_per_second");
    if (name.rfind("newton_operator/", 0) == 0) {
      positive("elements_per_second");
      positive("level0_nodes");
      EXPECT_GE(b["levels"].get<double>(), 2.0) << name << ": a V-cycle needs a coarse level";
    }
    if (name.rfind("triad/", 0) == 0) positive("bytes_per_second");
    if (name.rfind("broad_phase_steps/", 0) == 0) positive("pairs_tested_off");
    if (name.rfind("skip_inactive/", 0) == 0) positive("active_share");
    if (name.rfind("scheduling_overhead/", 0) == 0) positive("loops_per_repetition");
  }
  expect_exact_chunk_counts(d, 1);
}

TEST_F(MicroBenchmarks, SchedulingOverheadCountsChunksExactlyAtTwoThreads) {
  // The structure of the overhead figures at 2 threads (smoke size; no time is judged).
  const char* previous = std::getenv("OMP_NUM_THREADS");
  const std::string saved = previous != nullptr ? previous : "";
  setenv("OMP_NUM_THREADS", "2", 1);
  const clothbench_test::Outcome o = run_micro_smoke(
      "--benchmark_filter='scheduling_overhead(/static@blocks|/active-lists|/dynamic:|_dynamic_k)' "
      "--benchmark_format=json");
  if (previous != nullptr) {
    setenv("OMP_NUM_THREADS", saved.c_str(), 1);
  } else {
    unsetenv("OMP_NUM_THREADS");
  }
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const json d = json::parse(o.output);
  ASSERT_GE(d["benchmarks"].size(), 4u) << o.output;
  expect_exact_chunk_counts(d, 2);
}

}  // namespace
