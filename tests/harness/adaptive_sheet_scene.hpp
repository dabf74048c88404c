// The small adaptive scene of the trace and predictor tests (integration_trace.cpp,
// integration_predict.cpp): one definition, so both record the same runs.
#pragma once

#include "kernels/simulation.hpp"

namespace clothbench_test {

/// A 17 x 17 sheet on a box, in 4 x 4 blocks, with two AMRC levels checked every step: the
/// lists have tiles without entries and the blocks have inactive elements.
inline clothbench::kernels::SimulationConfig adaptive_sheet_on_box() {
  namespace kernels = clothbench::kernels;
  kernels::SimulationConfig c;
  c.cloth.particles_i = 17;
  c.cloth.particles_j = 17;
  c.cloth.block_size = 4;
  c.cloth.size_i = c.cloth.size_j = 0.2;
  c.cloth.origin = {-0.1, -0.1, 2.0 * c.contact.distance};
  c.cloth.initial_crumple = 0.0;
  kernels::ObstacleConfig box;
  box.kind = kernels::ObstacleKind::box;
  box.center = {0.0, 0.0, -0.1};
  box.half_extents = {0.05, 0.05, 0.1};
  c.obstacles.push_back(box);
  c.amrc.enabled = true;
  c.amrc.levels = 2;
  c.amrc.check_every = 1;
  c.solver.max_iterations = 12;
  c.solver.max_step_halvings = 0;
  return c;
}

}  // namespace clothbench_test
