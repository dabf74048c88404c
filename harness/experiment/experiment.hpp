// `clothbench experiment NAME`: the paper's experiments, one command each, plus the study of
// run time against error. Every run is verified; results go to OUT/NAME-SIZE/ as JSON and
// Markdown (rewritten atomically after every run) and, for time-error, a PNG.
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "harness/experiment/experiment_runs.hpp"
#include "schedulers/loop_driver.hpp"

namespace clothbench::harness {

/// Names accepted by run_experiment.
inline constexpr const char* kExperimentNames[] = {"table1", "table2", "table3", "time-error"};

/// Runs the experiment `options.name`. Returns the exit code: 0 every run passed, 1 a run
/// failed verification, 2 bad input (message on stderr).
int run_experiment(const ExperimentOptions& options);

/// What each experiment gets: the options, a driver, the thread count and its output folder.
struct ExperimentContext {
  const ExperimentOptions& options;
  schedulers::LoopDriver& driver;
  int threads;
  std::filesystem::path dir;  ///< OUT/NAME-SIZE
};

/// Table 1 (finer / AMRC / coarser box drape, against a tight-tolerance reference).
int run_table1(const ExperimentContext& context);
/// Table 3 (sphere, three spheres: active particles per AMRC event).
int run_table3(const ExperimentContext& context);
/// Run time against error over a grid of cheaper settings, with the Pareto front.
int run_time_error(const ExperimentContext& context);

/// Writes NAME.json (with the machine context) and NAME.md into context.dir atomically.
void write_experiment_outputs(const ExperimentContext& context, const std::string& stem,
                              nlohmann::json document, const std::string& markdown);

/// The JSON of one verified run (figures, no surface).
nlohmann::json variant_json(const VariantRun& run);

}  // namespace clothbench::harness
