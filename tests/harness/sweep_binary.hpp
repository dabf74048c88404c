// The real `clothbench sweep` run as a child process on a tiny scene: what its integration
// tests share (integration_sweep.cpp: the document, resume after a kill, oversubscription, bad
// input; integration_sweep_stop.cpp: Ctrl-C and SIGTERM, stops inside a row). Both take the
// names of namespace clothbench_test whole (`using namespace`).
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>
#include <tuple>

#include "tests/harness/clothbench_process.hpp"
#include "tests/harness/sanitizer_build.hpp"

namespace clothbench_test {

/// The tiny box drape every sweep test runs.
inline const std::filesystem::path kScene =
    std::filesystem::path(CLOTHBENCH_SOURCE_DIR) / "tests/data/scenes/sweep-tiny.toml";

/// Sanitizer builds run the kernel 10 to 20 times slower: there the sweeps repeat each run
/// less, and waits are longer.
inline constexpr int kWaitSeconds = kSanitized ? 900 : 120;

class SweepBinary : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(std::filesystem::exists(binary())) << "clothbench binary not built: " << binary();
  }
};

/// (scheduler, threads, digest, passed) of every row, the part of a row that must not
/// depend on whether the sweep was interrupted.
inline std::set<std::tuple<std::string, int, std::string, bool>> row_keys(
    const nlohmann::json& d) {
  std::set<std::tuple<std::string, int, std::string, bool>> keys;
  for (const nlohmann::json& r : d["rows"]) {
    keys.emplace(r["scheduler_canonical"], r["threads"], r["verification"]["state_digest"],
                 r["verification"]["passed"]);
  }
  return keys;
}

/// Waits until OUT/sweep.json exists and `ready(document)` holds, at most `seconds`; returns
/// the document last read (null before the file exists). Fails the test on a torn
/// (unparseable) file.
template <class Ready>
nlohmann::json wait_for_document(const std::filesystem::path& out, Ready ready, int seconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(seconds);
  nlohmann::json seen;
  while (std::chrono::steady_clock::now() < deadline) {
    try {
      if (fs::exists(out / "sweep.json")) seen = read_json(out / "sweep.json");
    } catch (const nlohmann::json::exception&) {
      ADD_FAILURE() << "sweep.json was torn: writes must be atomic";
    }
    if (!seen.is_null() && ready(seen)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return seen;
}

/// Waits until OUT/sweep.json holds at least `rows` rows, at most `seconds`; returns the
/// count last seen.
inline std::size_t wait_for_rows(const std::filesystem::path& out, std::size_t rows, int seconds) {
  const nlohmann::json seen = wait_for_document(
      out, [&](const nlohmann::json& d) { return d["rows"].size() >= rows; }, seconds);
  return seen.is_null() ? 0 : seen["rows"].size();
}

/// Exit code of a shell command line (stdout and stderr discarded into `output`).
inline int run_shell(const std::string& command, std::string& output) {
  const Outcome o = run_command("timeout -s KILL 300 " + command + " 2>&1");
  output += o.output;
  return o.exit_code;
}

}  // namespace clothbench_test
