// The cells of `clothbench stress` (issue 7): the base scene (scenarios/stress-base.toml) with
// one setting changed at a time - fabric (the five presets and two extremes), time step,
// gravity, mesh size, AMRC, run length, crumpled or stretched start - plus a few chosen
// combinations. Not the cartesian product: each cell isolates what it stresses.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "harness/scene/scene.hpp"
#include "harness/stress/stress_options.hpp"

namespace clothbench::harness {

/// One cell of the stress matrix: a complete scene, ready to simulate.
struct StressCell {
  std::string name;    ///< unique, e.g. "dt-0.1", "stiff-x10+dt-0.1" (what --only matches)
  std::string axis;    ///< what it varies: "base", "fabric", "time step", "gravity", "mesh",
                       ///< "amrc", "length", "start" or "combination"
  std::string change;  ///< the change from the base scene in words, e.g. "dt = 0.1 s"
  Scene scene;         ///< the base scene with the change applied; scene.steps = the cell's steps
};

/// Particles per side of every quick cell but the mesh axis's (the full size keeps the base
/// scene's grid): the quick matrix's "small meshes".
inline constexpr int kQuickParticles = 17;

/// The cells of `size` built from `base` (a loaded stress base scene), in a fixed order.
/// `presets_file` provides the fabric presets. Throws std::invalid_argument when the base
/// cannot carry the matrix (no obstacle, a mesh AMRC cannot coarsen, a cell whose cloth would
/// start inside an obstacle).
std::vector<StressCell> stress_matrix(const Scene& base, StressSize size,
                                      const std::filesystem::path& presets_file);

/// Thresholds of the thrashing AMRC cells (rad): closer than a factor two, so that what is
/// merged at one check turns more than the refine threshold at the next and is split again.
inline constexpr double kThrashRefineThreshold = 0.012;
inline constexpr double kThrashCoarsenThreshold = 0.01;
/// The same for the crumpled start: its triples turn by tenths of a radian (offsets of half a
/// spacing), so thresholds of hundredths would keep it at the finest mesh and never thrash.
inline constexpr double kThrashCrumpledRefineThreshold = 0.5;
inline constexpr double kThrashCrumpledCoarsenThreshold = 0.4;

}  // namespace clothbench::harness
