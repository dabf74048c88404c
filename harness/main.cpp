// The clothbench command line (CLI11).
//   clothbench run SCENE [options]   one verified simulation (harness/run/run_scene.hpp)
//   clothbench check SCENE           validate a scene file and print what it configures
//   clothbench info [--json]         the machine context (harness/machine)
// Exit codes: 0 success, 1 a run that failed verification or an internal error,
// 2 bad input (command line, scene file).
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <climits>
#include <cstdio>
#include <exception>
#include <iostream>

#include "harness/machine/machine_context.hpp"
#include "harness/run/run_scene.hpp"
#include "harness/scene/scene.hpp"

namespace {

using clothbench::harness::RunOptions;

constexpr int kExitBadInput = 2;

// `clothbench check`: the scene as the loader understood it.
int check_scene(const std::filesystem::path& file) {
  const auto scene =
      clothbench::harness::load_scene(file, clothbench::harness::default_presets_file());
  const auto& sim = scene.simulation;
  fmt::print(
      "{}: OK\n  name        {}\n  steps       {}\n  cloth       {} x {} particles, {} x {} m, "
      "block {}\n"
      "  fabric      {}\n  obstacles   {}\n  time step   {} s\n  amrc        {}\n  hash        "
      "{}\n",
      file.string(), scene.name, scene.steps, sim.cloth.particles_i, sim.cloth.particles_j,
      sim.cloth.size_i, sim.cloth.size_j, sim.cloth.block_size, sim.fabric_name,
      sim.obstacles.size(), sim.time.step,
      sim.amrc.enabled ? fmt::format("{} levels", sim.amrc.levels) : "off",
      scene.source_sha256_or_fnv);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"clothbench: OpenMP loop-scheduling benchmark on a KES cloth simulation with AMRC"};
  app.set_version_flag("--version", clothbench::harness::version_string());
  app.require_subcommand(1);

  RunOptions run;
  std::string formulation;
  std::string gradient;
  std::string preconditioner;
  int steps = 0;
  auto* run_command = app.add_subcommand("run", "Simulate a scene and verify the result");
  run_command->add_option("SCENE", run.scene_file, "Scene file (TOML, see scenarios/README.md)")
      ->required()
      ->check(CLI::ExistingFile);
  run_command
      ->add_option("--scheduler", run.scheduler,
                   "Loop scheduler, e.g. static, dynamic:2, active-lists")
      ->capture_default_str();
  run_command
      ->add_option("--threads", run.threads, "OpenMP threads (default: OMP_NUM_THREADS or all PUs)")
      ->check(CLI::Range(1, INT_MAX));
  run_command->add_flag("--oversubscribe", run.allow_oversubscribe,
                        "Allow more threads than hardware PUs");
  auto* steps_option = run_command->add_option("--steps", steps, "Override the scene's step count")
                           ->check(CLI::Range(1, INT_MAX));
  auto* formulation_option =
      run_command->add_option("--formulation", formulation, "Override the formulation")
          ->check(CLI::IsMember({"potential", "violation"}));
  auto* gradient_option = run_command->add_option("--gradient", gradient, "Override the gradient")
                              ->check(CLI::IsMember({"analytic", "numeric"}));
  auto* preconditioner_option =
      run_command
          ->add_option("--preconditioner", preconditioner, "Override block-Jacobi preconditioning")
          ->check(CLI::IsMember({"on", "off"}));
  run_command->add_option("--out", run.output_dir, "Output directory for VTK and JSON")
      ->capture_default_str();
  bool no_vtk = false;
  run_command->add_flag("--no-vtk", no_vtk, "Do not write VTK surfaces");
  run_command->add_flag("--quiet", run.quiet, "No per-step lines");

  std::filesystem::path check_file;
  auto* check_command =
      app.add_subcommand("check", "Validate a scene file and print what it sets up");
  check_command->add_option("SCENE", check_file, "Scene file (TOML)")
      ->required()
      ->check(CLI::ExistingFile);

  bool json = false;
  auto* info_command = app.add_subcommand("info", "Print the machine context");
  info_command->add_flag("--json", json, "As JSON (the block stored with every result)");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    const int code = app.exit(error);  // prints help, version or the error
    return code == 0 ? 0 : kExitBadInput;
  }

  try {
    if (*run_command) {
      if (*steps_option) run.steps = steps;
      if (*formulation_option) run.formulation = formulation;
      if (*gradient_option) run.gradient = gradient;
      if (*preconditioner_option) run.preconditioner = preconditioner == "on";
      run.write_vtk = !no_vtk;
      return clothbench::harness::run_scene(run);
    }
    if (*check_command) return check_scene(check_file);
    if (*info_command) {
      const auto context = clothbench::harness::machine_context();
      if (json) {
        std::cout << context.dump(2) << '\n';
      } else {
        std::cout << clothbench::harness::machine_summary(context);
      }
      return 0;
    }
  } catch (const clothbench::harness::SceneError& error) {
    std::fprintf(stderr, "clothbench: %s\n", error.what());
    return kExitBadInput;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "clothbench: error: %s\n", error.what());
    return 1;
  }
  return kExitBadInput;
}
