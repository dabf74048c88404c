// Small scenes shared by the kernel tests.
#pragma once

#include <random>

#include "kernels/simulation.hpp"
#include "schedulers/static_driver.hpp"

namespace clothbench::testing {

/// An axis-aligned box obstacle (m).
inline kernels::ObstacleConfig box_obstacle(const Eigen::Vector3d& center,
                                            const Eigen::Vector3d& half_extents) {
  kernels::ObstacleConfig box;
  box.kind = kernels::ObstacleKind::box;
  box.center = center;
  box.half_extents = half_extents;
  return box;
}

/// A small crumpled cloth with pins, random targets and random previous element forces in
/// every band regime, optionally touching obstacles: every term of the cost is exercised.
inline kernels::SimulationConfig small_cloth(bool obstacles, bool pins) {
  kernels::SimulationConfig c;
  c.cloth.particles_i = 9;
  c.cloth.particles_j = 7;
  c.cloth.block_size = 4;
  c.cloth.size_i = c.cloth.size_j = 0.2;
  c.cloth.origin = {-0.1, -0.1, 0.001};
  c.cloth.initial_crumple = 0.01;
  if (pins) c.cloth.pinned = {{0, 0}, {8, 6}};
  if (obstacles) {
    kernels::ObstacleConfig sphere;
    sphere.kind = kernels::ObstacleKind::sphere;
    sphere.center = {0.0, 0.0, -0.05};
    sphere.radius = 0.0535;
    c.obstacles.push_back(sphere);
    c.obstacles.push_back(box_obstacle({0.09, 0.0, -0.05}, {0.02, 0.2, 0.0515}));
  }
  return c;
}

/// Randomises positions, targets and previous forces of `sim` reproducibly.
inline void randomise_state(kernels::Simulation& sim, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  kernels::ClothState& st = sim.state();
  for (double& v : st.position) v += 0.003 * unit(rng);
  for (double& v : st.target) v += 0.003 * unit(rng);
  const double fm = sim.material().tensile[0].fm;
  for (double& f : st.edge_force) f = 0.02 * fm * std::abs(unit(rng));
  const double hb = sim.material().bending[0].hb;
  for (double& m : st.triple_moment) m = 2.0 * hb * std::abs(unit(rng));
}

}  // namespace clothbench::testing
