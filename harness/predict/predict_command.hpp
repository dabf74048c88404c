// The `clothbench predict` subcommand's command line (CLI11): a trace replayed through the
// schedulers at any thread count, or (--validate) a sweep's measured rows beside their
// predictions. Kept here so that harness/main.cpp only registers it and dispatches to it.
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <optional>
#include <string>

#include "harness/predict/bandwidth_model.hpp"
#include "harness/predict/overhead_model.hpp"

namespace clothbench::harness {

/// Registers `predict` on `app` on construction; run() executes it after app.parse().
class PredictCommand {
 public:
  explicit PredictCommand(CLI::App& app);
  PredictCommand(const PredictCommand&) = delete;
  PredictCommand& operator=(const PredictCommand&) = delete;

  /// True when the parsed command line chose `predict`.
  [[nodiscard]] bool selected() const { return static_cast<bool>(*command_); }
  /// Prints the prediction (or validation); the exit code: 0, 2 bad input (a trace, sweep,
  /// overheads or bandwidth file that cannot be read, a bad --threads or --schedulers item).
  int run();

 private:
  int run_validation(const std::optional<OverheadModel>& given,
                     const std::optional<BandwidthModel>& bandwidth);

  CLI::App* command_ = nullptr;
  std::filesystem::path trace_file_;
  std::string threads_ = "1,2,4,8,16,32,64,80,128,256,512,1024";
  std::string schedulers_;
  std::filesystem::path overheads_file_;
  std::filesystem::path bandwidth_file_;
  std::filesystem::path out_dir_;
  std::filesystem::path json_file_;
  std::filesystem::path validate_file_;
  std::filesystem::path trace_dir_;
  std::filesystem::path from_file_;
  std::filesystem::path loop_times_file_;
};

}  // namespace clothbench::harness
