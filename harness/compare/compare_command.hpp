// The `clothbench compare A.json B.json` subcommand's command line (CLI11): its options and
// its run, kept here so that harness/main.cpp only registers it and dispatches to it.
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>

#include "harness/compare/compare_runs.hpp"

namespace clothbench::harness {

/// Registers `compare` on `app` on construction; run() executes it after app.parse().
class CompareCommand {
 public:
  explicit CompareCommand(CLI::App& app);
  CompareCommand(const CompareCommand&) = delete;
  CompareCommand& operator=(const CompareCommand&) = delete;

  /// True when the parsed command line chose `compare`.
  [[nodiscard]] bool selected() const { return static_cast<bool>(*command_); }
  /// Prints the comparison; the process exit code: 0, 1 when a row is significantly slower
  /// in B beyond --threshold, 2 bad input (a file that cannot be read or is not a sweep
  /// document, a value out of range).
  int run();

 private:
  CLI::App* command_ = nullptr;
  std::filesystem::path file_a_, file_b_, json_file_;
  CompareOptions options_;
};

}  // namespace clothbench::harness
