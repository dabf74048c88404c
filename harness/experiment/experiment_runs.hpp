// What the paper experiments share (`clothbench experiment ...`): scenes at a chosen size,
// one verified run of a scene variant with the figures the tables need, and the distance
// between two cloth surfaces that may have different grids.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "harness/run/run_summary.hpp"
#include "harness/scene/scene.hpp"
#include "schedulers/loop_driver.hpp"

namespace clothbench::harness {

/// How large the experiment's scenes are: the paper's sizes, a laptop size, or a size for
/// the test suite (seconds).
enum class ExperimentSize { paper, small, tiny };

/// "paper" | "small" | "tiny" and back; parse throws std::invalid_argument naming `flag`.
ExperimentSize parse_experiment_size(const std::string& text, const char* flag);
std::string to_string(ExperimentSize size);

/// Options shared by every experiment, as given on the command line.
struct ExperimentOptions {
  std::string name;                          ///< table1 | table2 | table3 | time-error
  ExperimentSize size = ExperimentSize::small;
  std::filesystem::path output_dir = "results/experiments";
  std::string scheduler = "active-lists";    ///< scheduler of every run (table2: the sweep's)
  int threads = 0;                           ///< 0 = OpenMP default
  bool allow_oversubscribe = false;
  bool quiet = false;                        ///< no per-run lines
  std::optional<std::filesystem::path> scene;  ///< time-error: base scene (default table1 finer)
  std::optional<int> steps;                  ///< override every scene's step count
  /// time-error: the settings to run besides the reference and the base (labels; empty: all)
  std::vector<std::string> only;
  int retries = 2;                           ///< table2: the sweep's --retries
  bool plots = true;
  std::vector<std::string> command_line;
};

/// The surface of a cloth at the end of a run: every grid point of its finest grid, inactive
/// points interpolated on the adaptive surface (Simulation::surface_positions), row-major.
struct SurfaceSample {
  int size_i = 0, size_j = 0;
  std::vector<Eigen::Vector3d> points;  ///< size_i * size_j, (i, j) at i + size_i * j
  /// Bilinear interpolation at material coordinates (u, v) in [0, 1]^2.
  [[nodiscard]] Eigen::Vector3d at(double u, double v) const;
};

/// Distance between two surfaces at the same material points: the grid points of `reference`,
/// sampled bilinearly on `surface`. Both RMS and max are in metres.
struct SurfaceError {
  double rms = 0.0;
  double max = 0.0;
};
SurfaceError surface_error(const SurfaceSample& surface, const SurfaceSample& reference);

/// One verified run of one scene variant and the figures the experiments tabulate.
struct VariantRun {
  std::string label;                 ///< e.g. "finer", "amrc", "cg-tol-1e-3"
  std::string setting;               ///< what differs from the base scene, in words
  RunSummary summary;
  double seconds = 0.0;              ///< wall time of all steps
  std::int64_t particles_start = 0;  ///< active particles before the first step
  std::int64_t particles_end = 0;    ///< active particles after the last step
  /// Sum over steps of active elements x objective evaluations: the work a run did,
  /// independent of the machine.
  double element_updates = 0.0;
  Eigen::Vector3d contact_force = Eigen::Vector3d::Zero();  ///< total penalty force at the end, N
  SurfaceSample surface;             ///< the final surface
  bool passed = false;               ///< verification passed and the state stayed finite
};

/// Loads `file` (with the shipped presets); throws SceneError or std::invalid_argument.
Scene load_experiment_scene(const std::filesystem::path& file);

/// Sets the cloth to `particles` x `particles` keeping its physical size (AMRC levels are
/// kept; the caller chooses a size of the form 2^L n + 1). Throws std::invalid_argument.
void resize_cloth(Scene& scene, int particles);

/// Runs `scene` once with `driver` and `threads` threads (check_memory first) and returns the
/// figures. Prints one line per run unless `quiet`.
VariantRun run_variant(const Scene& scene, const std::string& label, const std::string& setting,
                       schedulers::LoopDriver& driver, int threads, bool quiet);

/// The Pareto front of points (time, error): indices of the points no other point beats in
/// both (lower or equal in both and lower in one), sorted by time.
std::vector<std::size_t> pareto_front(const std::vector<double>& time,
                                      const std::vector<double>& error);

/// A number for a Markdown cell: `digits` significant digits, or "-" when not finite.
std::string cell(double value, int digits = 4);

}  // namespace clothbench::harness
