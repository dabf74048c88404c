// The `clothbench strip` subcommand (CLI11): the plane-strain strip of kernels/strip_drape.hpp,
// a seconds-long stand-in for the box drape on which ideas about the step solver's outer
// iteration are screened. Kept here so that harness/main.cpp only registers it and dispatches.
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <optional>
#include <string>

#include "kernels/strip_drape.hpp"

namespace clothbench::harness {

/// Registers `strip` on `app` on construction; run() executes it after app.parse().
class StripCommand {
 public:
  explicit StripCommand(CLI::App& app);
  StripCommand(const StripCommand&) = delete;
  StripCommand& operator=(const StripCommand&) = delete;

  /// True when the parsed command line chose `strip`.
  [[nodiscard]] bool selected() const { return static_cast<bool>(*command_); }
  /// Runs the strip and prints its counts; the exit code: 0 PASSED, 1 FAILED (a step did not
  /// converge, a position is not finite or a particle is inside the box), 2 bad input.
  int run();

 private:
  CLI::App* command_ = nullptr;
  kernels::StripSettings settings_;
  std::string fabric_ = "cotton-shirting";
  std::optional<double> rt_percent_;
  std::optional<double> bending_2hb_;
  bool no_reach_ = false;
  std::filesystem::path trace_file_;
  std::filesystem::path json_file_;
};

}  // namespace clothbench::harness
