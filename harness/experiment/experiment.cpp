// `clothbench experiment`: dispatch, outputs, and Table 2 (which is a sweep).
#include "harness/experiment/experiment.hpp"

#include <fmt/core.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <memory>
#include <stdexcept>

#include "harness/machine/machine_context.hpp"
#include "harness/output/atomic_file.hpp"
#include "harness/run/run_summary.hpp"
#include "harness/sweep/sweep.hpp"
#include "harness/sweep/sweep_options.hpp"
#include "schedulers/registry.hpp"

namespace clothbench::harness {

namespace {

constexpr int kExitBadInput = 2;

/// A finite number, or null: no NaN or infinity reaches a result file.
nlohmann::json number(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

/// Table 2 and Fig. 12: the box sweep over the paper's schedulers and 1..cores threads.
int run_table2(const ExperimentOptions& options) {
  SweepOptions sweep;
  const std::filesystem::path paper = scenario_directory() / "paper";
  switch (options.size) {
    case ExperimentSize::paper: sweep.scene_file = paper / "box-1001.toml"; break;
    case ExperimentSize::small: sweep.scene_file = paper / "box-257.toml"; break;
    case ExperimentSize::tiny:
      sweep.scene_file = scenario_directory() / "box-101-amrc.toml";
      sweep.steps = 3;
      sweep.repeat = 1;
      sweep.warmup_steps = 0;
      break;
  }
  if (options.steps) sweep.steps = options.steps;
  sweep.schedulers = split_list(kPaperSchedulers, "--schedulers");
  if (options.threads > 0) sweep.threads = {options.threads};
  sweep.allow_oversubscribe = options.allow_oversubscribe;
  sweep.retries = options.retries;
  sweep.quiet = options.quiet;
  sweep.plots = options.plots;
  sweep.output_dir = options.output_dir / ("table2-" + to_string(options.size));
  sweep.command_line = options.command_line;
  fmt::print("clothbench experiment table2 ({}): sweep of {} into {}\n", to_string(options.size),
             sweep.scene_file.string(), sweep.output_dir.string());
  std::fflush(stdout);
  return run_sweep(sweep);
}

}  // namespace

nlohmann::json variant_json(const VariantRun& run) {
  const RunSummary& s = run.summary;
  return {{"label", run.label},
          {"setting", run.setting},
          {"passed", run.passed},
          {"failures", s.verification.failures},
          {"steps", s.steps.size()},
          {"seconds", number(run.seconds)},
          {"particles_start", run.particles_start},
          {"particles_end", run.particles_end},
          {"element_updates", number(run.element_updates)},
          {"cg_iterations", s.total_iterations},
          {"evaluations", s.total_evaluations},
          {"rejected_steps", s.rejected_steps},
          {"average_minimised_cost", number(s.average_minimised_cost)},
          {"max_surface_penetration_m", number(s.final_state.max_surface_penetration)},
          {"min_particle_distance_m", number(s.final_state.min_particle_distance)},
          {"contact_force_n",
           {number(run.contact_force.x()), number(run.contact_force.y()),
            number(run.contact_force.z())}},
          {"amrc_events", s.amrc_events.size()},
          {"mass_error", number(s.mass_error)}};
}

void write_experiment_outputs(const ExperimentContext& context, const std::string& stem,
                              nlohmann::json document, const std::string& markdown) {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  document["schema"] = "clothbench.experiment." + stem;
  document["schema_version"] = 1;
  document["size"] = to_string(context.options.size);
  document["scheduler"] = context.driver.name();
  document["threads"] = context.threads;
  document["oversubscribed"] = context.threads > hardware_threads();
  document["updated_utc"] = stamp;
  document["command"] = context.options.command_line;
  document["machine"] = machine_context();
  write_file_atomically(context.dir / (stem + ".json"), document.dump(2) + "\n");
  write_file_atomically(context.dir / (stem + ".md"), markdown);
}

int run_experiment(const ExperimentOptions& options) {
  std::unique_ptr<schedulers::LoopDriver> driver;
  int threads = 0;
  try {
    if (options.name == "table2") return run_table2(options);
    threads = resolve_threads(options.threads, options.allow_oversubscribe, "--threads");
    driver = schedulers::make_driver(options.scheduler);
  } catch (const std::invalid_argument& error) {
    fmt::print(stderr, "clothbench experiment: {}\n", error.what());
    return kExitBadInput;
  }
  const ExperimentContext context{options, *driver, threads,
                                  options.output_dir / (options.name + "-" + to_string(options.size))};
  fmt::print("clothbench experiment {} ({}): scheduler {}, threads {}{}, output {}\n",
             options.name, to_string(options.size), driver->name(), threads,
             threads > hardware_threads() ? " (OVERSUBSCRIBED)" : "", context.dir.string());
  std::fflush(stdout);
  try {
    if (options.name == "table1") return run_table1(context);
    if (options.name == "table3") return run_table3(context);
    if (options.name == "time-error") return run_time_error(context);
  } catch (const SceneError& error) {
    fmt::print(stderr, "clothbench experiment: {}\n", error.what());
    return kExitBadInput;
  } catch (const std::invalid_argument& error) {
    fmt::print(stderr, "clothbench experiment: {}\n", error.what());
    return kExitBadInput;
  }
  fmt::print(stderr, "clothbench experiment: unknown experiment '{}' (table1, table2, table3, "
             "time-error)\n", options.name);
  return kExitBadInput;
}

}  // namespace clothbench::harness
