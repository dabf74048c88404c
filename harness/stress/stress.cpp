// `clothbench stress` (see stress.hpp): the cell loop, the console lines and the output files.
#include "harness/stress/stress.hpp"

#include <fmt/core.h>
#include <omp.h>

#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "harness/machine/machine_context.hpp"
#include "harness/output/atomic_file.hpp"
#include "harness/run/run_summary.hpp"
#include "harness/scene/scene.hpp"
#include "harness/stress/stress_cell.hpp"
#include "harness/stress/stress_matrix.hpp"
#include "harness/stress/stress_report.hpp"
#include "harness/sweep/stop_request.hpp"
#include "harness/sweep/sweep_document.hpp"
#include "harness/sweep/thread_binding.hpp"
#include "schedulers/registry.hpp"

namespace clothbench::harness {

using nlohmann::json;

namespace {

/// Writes stress.json, stress.md and stress.csv into `dir` (atomically, each).
void write_outputs(json& document, const std::filesystem::path& dir) {
  document["updated_utc"] = utc_now();
  check_finite(document, "stress");  // a NaN must never reach a result file
  write_file_atomically(dir / "stress.json", document.dump(2) + "\n");
  write_file_atomically(dir / "stress.md", stress_markdown(document));
  write_file_atomically(dir / "stress.csv", stress_csv(document));
}

std::string millimetres(double metres) { return fmt::format("{:.3f}", 1e3 * metres); }

std::string cell_line(const StressCellResult& r) {
  return fmt::format(
      "  {:<24} {:>11} steps  strain {:.4f}..{:.4f}  penetration {}/{} mm  cost trend {}  "
      "mass drift {:.1e}  {} {:.0f}/step (max {}{})  rejected {}  unconverged {}  {:.1f} s{}  {}\n",
      r.name, fmt::format("{}/{}", r.steps_completed, r.steps_planned), r.min_strain, r.max_strain,
      millimetres(r.max_particle_penetration), millimetres(r.max_surface_penetration),
      r.cost_trend.ratio
          ? fmt::format("{:.3g}{}{}", *r.cost_trend.ratio, r.cost_trend.growing ? " (grows)" : "",
                        r.cost_trend.assessed && !(r.cost_trend.quarter_mean[3] <= r.cost_bound)
                            ? " (above bound)"
                            : "")
          : std::string("-"),
      r.mass_drift, solver_name(r.method),
      static_cast<double>(r.cg_iterations) / std::max(1, r.steps_completed), r.max_step_iterations,
      solver_name(r.method) == "Newton"
          ? fmt::format(", PCG {:.0f}/step",
                        static_cast<double>(r.linear_iterations) / std::max(1, r.steps_completed))
          : std::string(),
      r.rejected_steps, r.unconverged_steps, r.wall_seconds,
      r.memory.scope == "unknown"
          ? std::string()
          : fmt::format("  peak {:.1f} MiB{}", static_cast<double>(r.memory.peak_bytes) / (1 << 20),
                        r.memory.scope == "run" ? "" : " (process)"),
      r.passed ? "PASSED" : "FAILED");
}

}  // namespace

int run_stress(const StressOptions& options) {
  // Everything that can be wrong with the input is checked before the first cell.
  const std::filesystem::path presets = default_presets_file();
  const std::filesystem::path base_file =
      options.base_scene.empty() ? default_stress_base_scene() : options.base_scene;
  const Scene base = load_scene(base_file, presets);
  std::vector<StressCell> cells;
  std::vector<std::string> names;
  for (StressCell& cell : stress_matrix(base, options.size, presets)) {
    names.push_back(cell.name);
    if (cell_selected(cell.name, options.only)) cells.push_back(std::move(cell));
  }
  if (cells.empty()) {
    std::string list;
    for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
    throw std::invalid_argument(fmt::format("--only: '{}' matches no cell of the {} matrix ({})",
                                            options.only, to_string(options.size), list));
  }
  for (const StressCell& cell : cells) check_memory(cell.scene);
  const int threads = resolve_threads(options.threads, options.allow_oversubscribe, "--threads");
  std::unique_ptr<schedulers::LoopDriver> driver;
  try {
    driver = schedulers::make_driver(options.scheduler);
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(fmt::format("--scheduler: {}", error.what()));
  }
  const bool oversubscribed = threads > hardware_threads();
  omp_set_num_threads(threads);

  json document = {
      {"schema", "clothbench.stress"},
      {"schema_version", kStressSchemaVersion},
      {"created_utc", utc_now()},
      {"complete", false},
      {"passed", true},
      {"command", options.command_line},
      {"settings",
       {{"size", to_string(options.size)},
        {"scheduler", driver->name()},
        {"threads", threads},
        {"oversubscribed", oversubscribed},
        {"only", options.only.empty() ? json() : json(options.only)}}},
      {"base_scene",
       {{"name", base.name},
        {"file", base.file.string()},
        {"hash", base.source_sha256_or_fnv},
        {"source", base.source_text}}},
      {"machine", machine_context()},
      {"openmp_environment", openmp_environment()},
      {"criteria",
       {{"mass_relative_tolerance", kMassTolerance},
        {"penetration",
         "no active particle inside an obstacle (as every run); the interpolated surface less "
         "than [contact] distance_m deep"},
        {"cost_growth_factor", kUnboundedGrowthFactor},
        {"cost_bound",
         "reject_residual squared: the squared RMS residual above which the kernel rejects a "
         "step and redoes it as two half steps; the last quarter's mean must stay at or below "
         "it"}}},
      {"cells", json::array()},
      {"summary", {{"planned", cells.size()}, {"finished", 0}, {"passed", 0}, {"failed", 0}}}};
  write_outputs(document, options.output_dir);
  if (!options.quiet) {
    fmt::print(
        "clothbench stress: {} size, {} of {} cells, base {} ({}), scheduler {}, {} threads{}\n",
        to_string(options.size), cells.size(), names.size(), base.name, base.file.string(),
        driver->name(), threads, oversubscribed ? " (OVERSUBSCRIBED)" : "");
    std::fflush(stdout);
  }

  // From here on Ctrl-C / SIGTERM stop the matrix after the step in progress.
  const StopRequest stop("clothbench stress", "the current step; finished cells are kept");
  int passed = 0, finished = 0;
  for (const StressCell& cell : cells) {
    if (stop.signal() != 0) break;
    const auto result = run_stress_cell(
        cell, *driver, [&] { return stop.signal() == 0; }, options.output_dir);
    if (!result) break;
    ++finished;
    passed += result->passed ? 1 : 0;
    document["cells"].push_back(cell_json(*result));
    document["summary"]["finished"] = finished;
    document["summary"]["passed"] = passed;
    document["summary"]["failed"] = finished - passed;
    document["passed"] = passed == finished;
    write_outputs(document, options.output_dir);  // a stopped matrix keeps this cell
    if (!options.quiet) {
      fmt::print("{}", cell_line(*result));
      for (const std::string& f : result->failures) fmt::print("      {}\n", f);
      for (const auto& file : result->snapshot_files) {
        fmt::print("      wrote {} (the state at the failing step)\n", file.string());
      }
      std::fflush(stdout);
    }
  }
  const auto json_file = options.output_dir / "stress.json";
  if (stop.signal() != 0 && finished < static_cast<int>(cells.size())) {
    fmt::print(stderr,
               "clothbench stress: stopped by {}: {} of {} cells are finished and kept in {}\n",
               signal_name(stop.signal()), finished, cells.size(), json_file.string());
    return 128 + stop.signal();
  }
  document["complete"] = true;
  write_outputs(document, options.output_dir);
  if (!options.quiet) {
    fmt::print("  wrote {}, stress.md, stress.csv\n", json_file.string());
  }
  fmt::print("Verification: {} ({} of {} cells passed)\n", passed == finished ? "PASSED" : "FAILED",
             passed, finished);
  return passed == finished ? 0 : 1;
}

}  // namespace clothbench::harness
