// `clothbench compare` on the command line (see compare_command.hpp).
#include "harness/compare/compare_command.hpp"

#include <fmt/core.h>

#include <cmath>
#include <cstdio>
#include <exception>
#include <iostream>
#include <stdexcept>

#include "harness/output/atomic_file.hpp"
#include "harness/report/sweep_table.hpp"

namespace clothbench::harness {

namespace {
constexpr int kExitRegression = 1;
constexpr int kExitBadInput = 2;
}  // namespace

CompareCommand::CompareCommand(CLI::App& app) {
  command_ = app.add_subcommand(
      "compare",
      "Compare two sweep.json documents row by row: ratio of medians B/A with a bootstrap 95 % "
      "interval, Mann-Whitney U p-value; exit 1 when a row is significantly slower in B");
  command_->add_option("A", file_a_, "Baseline sweep.json (written by `clothbench sweep`)")
      ->required();
  command_->add_option("B", file_b_, "Contender sweep.json")->required();
  command_->add_option("--alpha", options_.alpha, "Significance level of the U test, in (0, 1)")
      ->capture_default_str();
  command_
      ->add_option("--threshold", options_.threshold,
                   "Relative slow-down of B that fails the exit code when significant "
                   "(0.05 = 5 %), >= 0")
      ->capture_default_str();
  command_->add_option("--resamples", options_.resamples, "Bootstrap resamples, 100-1000000")
      ->capture_default_str();
  command_->add_option("--json", json_file_, "Also write the comparison as JSON to this file");
}

int CompareCommand::run() {
  // Ranges checked here rather than by CLI11 so that the message names the flag and value.
  const auto bad = [](const std::string& text) {
    std::fprintf(stderr, "clothbench compare: %s\n", text.c_str());
    return kExitBadInput;
  };
  if (!(options_.alpha > 0.0 && options_.alpha < 1.0)) {
    return bad(fmt::format("--alpha: must be between 0 and 1 (exclusive), got {}", options_.alpha));
  }
  if (!(options_.threshold >= 0.0) || !std::isfinite(options_.threshold)) {
    return bad(
        fmt::format("--threshold: must be a finite number >= 0, got {}", options_.threshold));
  }
  if (options_.resamples < 100 || options_.resamples > 1000000) {
    return bad(fmt::format("--resamples: must be 100-1000000, got {}", options_.resamples));
  }
  nlohmann::json a, b;
  try {
    a = load_sweep_document(file_a_);
    b = load_sweep_document(file_b_);
  } catch (const std::invalid_argument& error) {
    return bad(error.what());
  }
  const Comparison comparison = compare_sweeps(a, b, file_a_.string(), file_b_.string(), options_);
  std::cout << format_comparison_markdown(comparison);
  if (!json_file_.empty()) {
    try {
      write_file_atomically(json_file_, comparison_json(comparison).dump(2) + "\n");
    } catch (const std::exception& error) {
      return bad(fmt::format("--json: {}", error.what()));
    }
  }
  return comparison.regressions() > 0 ? kExitRegression : 0;
}

}  // namespace clothbench::harness
