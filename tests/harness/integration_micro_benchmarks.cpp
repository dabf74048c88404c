// clothbench-micro (harness/micro, Google Benchmark) smoke test: every benchmark family is
// registered, and one short benchmark (the sequential list rebuild on one thread, about a
// second) runs, exits 0 and writes JSON whose results and counters are finite and positive.
// Needs a build with CLOTHBENCH_BUILD_BENCHMARKS=ON (tests/CMakeLists.txt passes the binary's
// path); skipped otherwise (the ASan build of scripts/test --sanitize turns benchmarks off).
// No timing is asserted.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

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
  clothbench_test::Outcome outcome;
#ifdef CLOTHBENCH_MICRO_BINARY
  const std::string command = "timeout -s KILL 300 " + clothbench_test::quote(kMicro.string()) +
                              " " + arguments + " 2>" + clothbench_test::quote(errors.string());
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return outcome;
  char buffer[4096];
  while (std::fgets(buffer, sizeof buffer, pipe) != nullptr) outcome.output += buffer;
  const int status = pclose(pipe);
  outcome.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
#endif
  return outcome;
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
        "triad/", "skip_contact/", "skip_amrc/", "skip_inactive/active_lists/",
        "scheduling_overhead/static@blocks/", "scheduling_overhead/active-lists@active/"}) {
    std::string line_start = "\n";  // (not "\n" + family: GCC 12 warns falsely, -Wrestrict)
    line_start += family;
    EXPECT_THAT(o.output, HasSubstr(line_start)) << family;
  }
}

TEST_F(MicroBenchmarks, AShortRunWritesFiniteResultsAsJson) {
  const fs::path errors = clothbench_test::fresh_dir("micro") += ".log";
  const clothbench_test::Outcome o = run_micro(
      "--benchmark_filter='^list_rebuild/sequential/1/' --benchmark_min_time=0.001 "
      "--benchmark_format=json",
      errors);
  ASSERT_EQ(o.exit_code, 0) << o.output << clothbench_test::read_text(errors);
  fs::remove(errors);
  const json d = json::parse(o.output);  // throws (and fails the test) unless it is JSON
  EXPECT_GT(d["context"]["num_cpus"].get<int>(), 0);
  ASSERT_EQ(d["benchmarks"].size(), 1u) << d["benchmarks"].dump();
  const json& b = d["benchmarks"][0];
  EXPECT_EQ(b["name"], "list_rebuild/sequential/1/real_time");
  EXPECT_FALSE(b.contains("error_occurred")) << b.dump();
  EXPECT_GE(b["iterations"].get<long long>(), 1);
  for (const char* key : {"real_time", "cpu_time", "active_particles", "slots_per_second"}) {
    ASSERT_TRUE(b.contains(key) && b[key].is_number()) << key << " in " << b.dump();
    const double value = b[key];
    EXPECT_TRUE(std::isfinite(value) && value > 0.0) << key << " = " << value;
  }
}

}  // namespace
