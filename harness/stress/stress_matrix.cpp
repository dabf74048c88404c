// The stress matrix's cells (see stress_matrix.hpp).
#include "harness/stress/stress_matrix.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cstdint>
#include <functional>
#include <stdexcept>

#include "harness/scene/initial_overlap.hpp"
#include "kernels/obstacle.hpp"

namespace clothbench::harness {
namespace {

/// One change of the base scene, with its description.
struct Change {
  std::string what;
  std::function<void(Scene&)> apply;
};

/// Steps of a cell at each size (0: not in that size).
struct Steps {
  int quick = 0;
  int full = 0;
};

Change fabric_preset(const std::filesystem::path& presets, const std::string& name) {
  return {fmt::format("fabric {}", name), [presets, name](Scene& s) {
            s.simulation.fabric = load_fabric_preset(presets, name);
            s.simulation.fabric_name = name;
          }};
}

/// Tensile and bending stiffness times `factor`: EMT (the strain at Fm) divided by it, B and
/// 2HB multiplied by it, in both directions (factor 10: stiffer, 0.1: softer).
Change scaled_fabric(double factor) {
  const std::string what =
      factor > 1 ? fmt::format("{:g}x stiffer", factor) : fmt::format("{:g}x softer", 1.0 / factor);
  return {
      fmt::format("fabric {} in tension and bending", what), [factor, what](Scene& s) {
        for (kernels::KesDirection* d : {&s.simulation.fabric.warp, &s.simulation.fabric.weft}) {
          d->emt_percent /= factor;
          d->bending_b *= factor;
          d->bending_2hb *= factor;
          if (!(d->emt_percent < 100.0)) {
            throw std::invalid_argument(
                fmt::format("stress matrix: the base fabric made {} has EMT {} % (expected < 100)",
                            what, d->emt_percent));
          }
        }
        s.simulation.fabric_name += " " + what;
      }};
}

Change time_step(double dt) {
  return {fmt::format("dt = {:g} s", dt), [dt](Scene& s) { s.simulation.time.step = dt; }};
}

Change gravity_times(double factor) {
  return {fmt::format("gravity x{:g}", factor),
          [factor](Scene& s) { s.simulation.time.gravity *= factor; }};
}

Change mesh(int n) {
  return {fmt::format("{} x {} particles", n, n), [n](Scene& s) {
            s.simulation.cloth.particles_i = n;
            s.simulation.cloth.particles_j = n;
          }};
}

Change amrc_normal() {
  return {"AMRC on", [](Scene& s) { s.simulation.amrc.enabled = true; }};
}

/// AMRC checked after every step with thresholds closer than a factor two (rad).
Change amrc_thrashing(double refine = kThrashRefineThreshold,
                      double coarsen = kThrashCoarsenThreshold) {
  return {fmt::format("AMRC thrashing (every step, refine > {:g} rad, coarsen < {:g} rad)", refine,
                      coarsen),
          [refine, coarsen](Scene& s) {
            kernels::AmrcConfig& a = s.simulation.amrc;
            a.enabled = true;
            a.check_every = 1;
            a.refine_threshold = refine;
            a.coarsen_threshold = coarsen;
          }};
}

/// Random out-of-plane offsets of up to half the finest spacing; the sheet is lifted by that
/// much so that no particle starts inside the obstacle it lies on.
Change crumpled() {
  return {"crumpled start (+-h/2 out of plane)", [](Scene& s) {
            kernels::ClothConfig& c = s.simulation.cloth;
            const double h =
                std::min(c.size_i / (c.particles_i - 1), c.size_j / (c.particles_j - 1));
            c.initial_crumple = 0.5 * h;
            c.origin += c.initial_crumple * c.axis_i.cross(c.axis_j).normalized();
          }};
}

/// A uniform in-plane strain at the start, about the sheet's centre.
Change stretched(double strain) {
  return {fmt::format("stretched {:g} % at the start", 100 * strain), [strain](Scene& s) {
            kernels::ClothConfig& c = s.simulation.cloth;
            const Eigen::Vector3d half = 0.5 * (c.size_i * c.axis_i + c.size_j * c.axis_j);
            c.origin = c.origin + half - (1.0 + strain) * half;
            c.initial_stretch = strain;
          }};
}

/// Refuses a cell whose cloth would start inside an obstacle or whose mesh AMRC cannot take.
void check_cell(const StressCell& cell) {
  const kernels::SimulationConfig& sim = cell.scene.simulation;
  if (sim.amrc.enabled) {
    const int stride = 1 << sim.amrc.levels;
    for (int n : {sim.cloth.particles_i, sim.cloth.particles_j}) {
      if ((n - 1) % stride != 0 || n - 1 < stride) {
        throw std::invalid_argument(fmt::format(
            "stress cell {}: {} particles is not 2^{} n + 1 as [amrc] levels = {} requires",
            cell.name, n, sim.amrc.levels, sim.amrc.levels));
      }
    }
  }
  std::int64_t budget = 1'000'000;
  for (const kernels::ObstacleConfig& o : sim.obstacles) {
    if (const auto overlap =
            scene_detail::deepest_initial_overlap(sim.cloth, kernels::Obstacle(o), budget)) {
      throw std::invalid_argument(
          fmt::format("stress cell {}: particle ({}, {}) would start {:.3g} m inside an obstacle",
                      cell.name, overlap->i, overlap->j, overlap->depth));
    }
  }
}

}  // namespace

std::vector<StressCell> stress_matrix(const Scene& base, StressSize size,
                                      const std::filesystem::path& presets_file) {
  if (base.simulation.obstacles.empty()) {
    throw std::invalid_argument(fmt::format(
        "{}: the stress base scene has no [[obstacle]] (expected the cloth to fall on one)",
        base.file.string()));
  }
  const bool full = size == StressSize::full;
  // The quick size runs every cell on a coarser sheet (kQuickParticles per side).
  Scene start = base;
  if (!full) mesh(kQuickParticles).apply(start);
  std::vector<StressCell> cells;
  auto add = [&](const std::string& name, const std::string& axis,
                 const std::vector<Change>& changes, Steps steps) {
    const int count = full ? steps.full : steps.quick;
    if (count == 0) return;  // not in this size
    StressCell cell{name, axis, "", start};
    for (const Change& c : changes) {
      cell.change += (cell.change.empty() ? "" : ", ") + c.what;
      c.apply(cell.scene);
    }
    if (cell.change.empty()) cell.change = "none (the base scene)";
    cell.scene.steps = count;
    cell.scene.name = fmt::format("{} / {}", base.name, name);
    check_cell(cell);
    cells.push_back(std::move(cell));
  };
  // Steps {quick, full}; 0: the cell is not in that size. Cells that need many sub-steps per
  // step (dt = 0.1 s, gravity x50: the kernel halves a rejected step up to 6 times) run
  // fewer steps; cheap ones (small dt) run more in the full size.
  const Steps normal{30, 150};
  const Steps substepped{4, 12};
  add("base", "base", {}, normal);
  for (const char* preset : {"wool-suiting", "silk", "polyester", "denim"}) {
    add(fmt::format("fabric-{}", preset), "fabric", {fabric_preset(presets_file, preset)}, normal);
  }
  add("fabric-stiff-x10", "fabric", {scaled_fabric(10.0)}, normal);
  add("fabric-soft-x10", "fabric", {scaled_fabric(0.1)}, normal);
  add("dt-1e-4", "time step", {time_step(1e-4)}, {30, 1500});
  add("dt-1e-3", "time step", {time_step(1e-3)}, {30, 600});
  add("dt-0.01", "time step", {time_step(0.01)}, {12, 60});
  add("dt-0.1", "time step", {time_step(0.1)}, substepped);
  add("gravity-x50", "gravity", {gravity_times(50.0)}, {12, 60});
  add("mesh-33", "mesh", {mesh(33)}, {20, 0});  // the full size's base mesh
  add("mesh-65", "mesh", {mesh(65)}, {10, 100});
  add("mesh-129", "mesh", {mesh(129)}, {0, 60});
  add("mesh-257", "mesh", {mesh(257)}, {0, 30});
  add("mesh-513", "mesh", {mesh(513)}, {0, 15});
  add("amrc-normal", "amrc", {amrc_normal()}, normal);
  add("amrc-thrashing", "amrc", {amrc_thrashing()}, normal);
  add("long", "length", {mesh(kQuickParticles)}, {200, 10'000});  // on the small mesh
  add("crumpled", "start", {crumpled()}, normal);
  add("stretched-20", "start", {stretched(0.2)}, normal);
  add("stiff-x10+dt-0.1", "combination", {scaled_fabric(10.0), time_step(0.1)}, substepped);
  add("soft-x10+gravity-x50", "combination", {scaled_fabric(0.1), gravity_times(50.0)}, {12, 60});
  add("amrc-thrashing+crumpled", "combination",
      {amrc_thrashing(kThrashCrumpledRefineThreshold, kThrashCrumpledCoarsenThreshold), crumpled()},
      normal);
  return cells;
}

}  // namespace clothbench::harness
