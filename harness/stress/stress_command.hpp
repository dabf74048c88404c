// The `clothbench stress` subcommand's command line (CLI11): its options and its run, kept
// here so that harness/main.cpp only registers it and dispatches to it.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "harness/stress/stress_options.hpp"

namespace clothbench::harness {

/// Registers `stress` on `app` on construction; run() executes it after app.parse().
class StressCommand {
 public:
  explicit StressCommand(CLI::App& app);
  StressCommand(const StressCommand&) = delete;
  StressCommand& operator=(const StressCommand&) = delete;

  /// True when the parsed command line chose `stress`.
  [[nodiscard]] bool selected() const { return static_cast<bool>(*command_); }
  /// Runs the matrix; the process exit code (0 passed, 1 failed, 2 bad input, 130 / 143
  /// stopped by Ctrl-C / SIGTERM). Scene-file errors propagate as SceneError.
  int run(int argc, char** argv);

 private:
  CLI::App* command_ = nullptr;
  StressOptions options_;
  std::string size_ = "quick";
};

}  // namespace clothbench::harness
