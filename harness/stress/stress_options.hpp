// Options of `clothbench stress` (the stress matrix of issue 7) and the selection of its
// cells by name.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace clothbench::harness {

/// How much of the stress matrix runs, and how long each cell is.
enum class StressSize {
  quick,  ///< small meshes (17^2; 33^2 and 65^2 on the mesh axis), few steps: minutes on 2 cores
  full,   ///< the base scene's mesh, meshes up to 513^2, the 10,000-step run, longer runs
};

/// Everything `clothbench stress` needs, as given on the command line.
struct StressOptions {
  StressSize size = StressSize::quick;
  std::filesystem::path base_scene;  ///< empty = default_stress_base_scene()
  std::filesystem::path output_dir = "results/stress";
  std::string scheduler = "static";  ///< scheduler spec, as for `clothbench run`
  int threads = 0;                   ///< 0 = OpenMP default (OMP_NUM_THREADS or all PUs)
  bool allow_oversubscribe = false;
  /// Comma-separated glob patterns (fnmatch: *, ?, [..]) on cell names; empty = every cell.
  std::string only;
  bool quiet = false;                     ///< no per-cell lines
  std::vector<std::string> command_line;  ///< argv, recorded in the result
};

/// "quick" | "full" (std::invalid_argument naming --size otherwise) and back.
StressSize parse_stress_size(std::string_view text);
std::string to_string(StressSize size);

/// <source dir>/scenarios/stress-base.toml: the scene every cell is built from.
std::filesystem::path default_stress_base_scene();

/// True when `name` matches one of the comma-separated glob patterns of `only` (or `only`
/// is empty). Throws std::invalid_argument naming --only for an empty pattern ("a,,b").
bool cell_selected(std::string_view name, std::string_view only);

}  // namespace clothbench::harness
