// The paper's box scene built in code for the micro-benchmarks: an n x n cloth over a 1 m
// sheet just above a 50 x 50 x 25 cm box, lightly crumpled, 5 nonlinear CG iterations a step.
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
  // Nonlinear CG, 5 iterations a step, and a step that ends at the cap is kept: the benchmarks
  // need a state with elements in every regime, not a converged one. (Under Newton with step
  // halving each step of a set-up was redone as up to 64 sub-steps: minutes at 301^2.)
  c.solver.method = kernels::StepMethod::nonlinear_cg;
  c.solver.max_iterations = 5;
  c.solver.max_step_halvings = 0;
  return c;
}

}  // namespace clothbench::micro
