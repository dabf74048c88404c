// Fixtures of the Newton solver's tests (unit_model_hessian.cpp, unit_newton.cpp): a model
// Hessian of a Simulation's own state, and the cloths both files solve.
#pragma once

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "kernel_fixtures.hpp"
#include "kernels/potential_objective.hpp"

namespace clothbench::testing {

/// The model Hessian of a Simulation's state, through a PotentialObjective of its own.
struct ModelFixture {
  explicit ModelFixture(const kernels::SimulationConfig& config)
      : sim(config),
        ctx{sim.mesh(), sim.material(), sim.obstacles(), sim.config(), sim.state()},
        objective(ctx) {}
  template <class F>
  void run(F&& f) {
    schedulers::OmpStaticDriver driver;
    kernels::LoopRunner r(driver, sim.mesh(), nullptr, kernels::Instrumentation::off, nullptr);
    f(r);
  }
  /// Ghosts on their midpoints, the per-step constants, then H at the current positions (as
  /// within a step; `floor_along`: bending's floor along the turning vector too).
  void assemble(bool floor_along = true) {
    schedulers::OmpStaticDriver driver;
    (void)sim.evaluate(driver, true);
    run([&](kernels::LoopRunner& r) {
      objective.prepare_history(r);
      objective.assemble_newton(r, /*new_step=*/false, floor_along);
    });
  }
  std::vector<double> product(std::vector<double> v) {
    std::vector<double> y(v.size(), 0.0);
    run([&](kernels::LoopRunner& r) { (void)objective.model_hessian()->apply(r, ctx, v, y); });
    return y;
  }
  /// The analytic gradient at the current positions.
  std::vector<double> gradient() {
    schedulers::OmpStaticDriver driver;
    (void)sim.evaluate(driver, true);
    return sim.state().gradient;
  }
  kernels::Simulation sim;
  kernels::StepContext ctx;
  kernels::PotentialObjective objective;
};

inline double dot(const std::vector<double>& a, const std::vector<double>& b) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) sum += a[i] * b[i];
  return sum;
}

inline std::vector<double> random_free_vector(const kernels::Simulation& sim, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<double> v(sim.state().position.size(), 0.0);
  const kernels::StepContext ctx{sim.mesh(), sim.material(), sim.obstacles(), sim.config(),
                                 const_cast<kernels::ClothState&>(sim.state())};
  for (std::int64_t s = 0; s < sim.mesh().slot_count(); ++s) {
    if (!ctx.is_free(s)) continue;
    for (int k = 0; k < 3; ++k) v[3 * s + k] = unit(rng);
  }
  return v;
}

inline kernels::SimulationConfig newton_config(kernels::SimulationConfig c) {
  c.solver.method = kernels::StepMethod::newton;
  return c;
}

/// A 9 x 9 cloth for AMRC with L = 2, with pins and obstacles (small_cloth).
inline kernels::SimulationConfig graded_config() {
  kernels::SimulationConfig c = newton_config(small_cloth(true, true));
  c.cloth.particles_i = 9;
  c.cloth.particles_j = 9;
  c.amrc.enabled = true;
  c.amrc.levels = 2;
  return c;
}

/// Coarse cells beside fine ones (ghosts on the shared sides), then a random state of `seed`.
inline void grade_and_randomise(ModelFixture& f, unsigned seed) {
  kernels::AdaptiveMesh& tree = f.sim.begin_tree_edit();
  ASSERT_TRUE(tree.coarsen(kernels::TreeCell{1, 0, 0}, f.sim.mesh()));
  ASSERT_TRUE(tree.coarsen(kernels::TreeCell{1, 3, 2}, f.sim.mesh()));
  f.sim.end_tree_edit();
  ASSERT_GT(f.sim.mesh().ghost_count(), 0);
  randomise_state(f.sim, seed);
}

/// A 13 x 13 cloth falling onto a sphere and a box from 3 mm above them.
inline kernels::SimulationConfig small_drape() {
  kernels::SimulationConfig c = small_cloth(true, false);
  c.cloth.particles_i = c.cloth.particles_j = 13;
  c.cloth.initial_crumple = 0.0;
  c.cloth.origin = {-0.1, -0.1, 0.0065};  // 3 mm above the sphere: contact from step 5
  c.time.step = 0.004;
  c.solver.tolerance = 1e-5;
  c.solver.max_iterations = 3000;
  c.solver.max_newton_iterations = 60;
  c.solver.max_linear_iterations = 500;
  c.solver.reject_residual = 1e300;
  return c;
}

}  // namespace clothbench::testing
