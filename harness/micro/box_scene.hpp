// The paper's box scene built in code for the micro-benchmarks: an n x n cloth over a 1 m
// sheet just above a 50 x 50 x 25 cm box, lightly crumpled, 5 solver iterations a step, no halving.
#pragma once

#include "harness/micro/smoke.hpp"
#include "kernels/simulation_config.hpp"

namespace clothbench::micro {

/// (n x n; kSmokeParticles in a smoke run, smoke.hpp.)
inline kernels::SimulationConfig box_scene(int n) {
  kernels::SimulationConfig c;
  c.cloth.particles_i = c.cloth.particles_j = scaled(n, kSmokeParticles);
  c.cloth.size_i = c.cloth.size_j = 1.0;
  c.cloth.origin = {-0.5, -0.5, 0.252};
  c.cloth.initial_crumple = 0.002;
  kernels::ObstacleConfig box;
  box.kind = kernels::ObstacleKind::box;
  box.center = {0, 0, 0.125};
  box.half_extents = {0.25, 0.25, 0.125};
  c.obstacles.push_back(box);
  c.solver.max_iterations = 5;
  // A step that ends at the cap is kept: with step halving each of the set-up's steps was redone
  // as up to 64 sub-steps of 5 Newton iterations (minutes at 301^2), and the benchmarks need a
  // state with elements in every regime, not a converged one.
  c.solver.max_step_halvings = 0;
  return c;
}

}  // namespace clothbench::micro
