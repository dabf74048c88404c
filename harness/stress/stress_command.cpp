// `clothbench stress` on the command line (see stress_command.hpp).
#include "harness/stress/stress_command.hpp"

#include <climits>
#include <cstdio>
#include <stdexcept>

#include "harness/stress/stress.hpp"

namespace clothbench::harness {

StressCommand::StressCommand(CLI::App& app) {
  command_ = app.add_subcommand(
      "stress",
      "Run the stress matrix (fabrics, time steps, gravity, mesh sizes, AMRC, long runs, "
      "crumpled and stretched starts); PASSED/FAILED per cell, stress.json/.csv/.md");
  command_->add_option("--size", size_, "quick: small meshes, few steps; full: the whole matrix")
      ->capture_default_str()
      ->check(CLI::IsMember({"quick", "full"}));
  command_->add_option("--only", options_.only,
                       "Comma-separated glob patterns of the cells to run, e.g. 'dt-*,base'");
  command_
      ->add_option("--scheduler", options_.scheduler,
                   "Loop scheduler, e.g. static, dynamic:2, active-lists")
      ->capture_default_str();
  command_
      ->add_option("--threads", options_.threads,
                   "OpenMP threads (default: OMP_NUM_THREADS or all PUs)")
      ->check(CLI::Range(1, INT_MAX));
  command_->add_flag("--oversubscribe", options_.allow_oversubscribe,
                     "Allow more threads than hardware PUs");
  command_
      ->add_option("--base", options_.base_scene,
                   "Base scene (default: scenarios/stress-base.toml)")
      ->check(CLI::ExistingFile);
  command_->add_option("--out", options_.output_dir, "Output directory")->capture_default_str();
  command_->add_flag("--quiet", options_.quiet, "No per-cell lines");
}

int StressCommand::run(int argc, char** argv) {
  try {
    options_.size = parse_stress_size(size_);
    options_.command_line.assign(argv, argv + argc);
    return run_stress(options_);
  } catch (const std::invalid_argument& error) {
    std::fprintf(stderr, "clothbench stress: %s\n", error.what());
    return 2;
  }
}

}  // namespace clothbench::harness
