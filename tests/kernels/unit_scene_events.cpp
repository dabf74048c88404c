// Scripted scene events (MODEL.md 8): a pulled particle moves along the force and relaxes when
// it ends, a released pin falls, a moved obstacle pushes the cloth, events apply before the
// right steps, forced particles stay active under AMRC, and what the kernel refuses.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "kernel_fixtures.hpp"
#include "kernels/amrc.hpp"

namespace clothbench {
namespace {

using kernels::SceneEvent;
using kernels::SceneEventKind;
using kernels::Simulation;
using kernels::SimulationConfig;

/// A flat 9 x 9 sheet of 0.2 m held at its four corners.
SimulationConfig held_sheet() {
  SimulationConfig c;
  c.cloth.particles_i = c.cloth.particles_j = 9;
  c.cloth.block_size = 4;
  c.cloth.size_i = c.cloth.size_j = 0.2;
  c.cloth.origin = {-0.1, -0.1, 0.5};
  c.cloth.pinned = {{0, 0}, {8, 0}, {0, 8}, {8, 8}};
  c.time.step = 0.005;
  c.time.damping = 0.2;
  c.solver.tolerance = 1e-5;
  c.solver.max_iterations = 400;
  return c;
}

SceneEvent force_event(int i, int j, const Eigen::Vector3d& f, int step, int until) {
  SceneEvent e;
  e.kind = SceneEventKind::force;
  e.particle_i = i;
  e.particle_j = j;
  e.force = f;
  e.step = step;
  e.until_step = until;
  return e;
}

Eigen::Vector3d position(const Simulation& sim, int i, int j) {
  return kernels::vec3(sim.state().position, sim.mesh().slot(i, j));
}

TEST(SceneEvents, PulledParticleMovesAlongTheForceAndRelaxesWhenItEnds) {
  SimulationConfig c = held_sheet();
  c.time.gravity.setZero();  // the pull is the only load
  const Eigen::Vector3d pull(0.02, 0.01, 0.05);
  c.events = {force_event(4, 4, pull, 3, 12)};
  Simulation sim(c);
  schedulers::OmpStaticDriver driver;
  const Eigen::Vector3d start = position(sim, 4, 4);
  double during = 0.0;
  for (int step = 1; step <= 12; ++step) {
    const kernels::StepReport r = sim.step(driver);
    EXPECT_EQ(r.events, step == 3 ? std::vector<int>{0} : std::vector<int>{}) << step;
    if (step < 3) {
      EXPECT_EQ(position(sim, 4, 4), start) << "moved before the force began";
    }
  }
  const Eigen::Vector3d moved = position(sim, 4, 4) - start;
  during = moved.norm();
  ASSERT_GT(during, 1e-3);
  EXPECT_GT(moved.dot(pull.normalized()), 0.95 * during) << "not along the force: " << moved.transpose();
  EXPECT_TRUE(sim.state().external_forces.size() == 1);
  sim.step(driver);  // step 13: the force has ended
  EXPECT_TRUE(sim.state().external_forces.empty());
  EXPECT_EQ(sim.mesh().flags[sim.mesh().slot(4, 4)] & kernels::kParticleForced, 0);
  for (int step = 14; step <= 80; ++step) sim.step(driver);
  const double after = (position(sim, 4, 4) - start).norm();
  EXPECT_LT(after, 0.5 * during) << "the cloth did not relax once the pull ended";
  EXPECT_TRUE(sim.diagnostics().finite);
}

TEST(SceneEvents, ReleasedPinFalls) {
  SimulationConfig c = held_sheet();
  c.cloth.pinned = {{0, 0}, {8, 0}};
  SceneEvent release;
  release.kind = SceneEventKind::release_pin;
  release.particle_i = 8;
  release.particle_j = 0;
  release.step = release.until_step = 4;
  c.events = {release};
  Simulation sim(c);
  schedulers::OmpStaticDriver driver;
  const Eigen::Vector3d held = position(sim, 0, 0), freed = position(sim, 8, 0);
  for (int step = 1; step <= 3; ++step) sim.step(driver);
  EXPECT_EQ(position(sim, 8, 0), freed) << "a pinned particle moved";
  for (int step = 4; step <= 20; ++step) sim.step(driver);
  EXPECT_EQ(position(sim, 0, 0), held);
  EXPECT_LT(position(sim, 8, 0).z(), freed.z() - 0.005) << "the released corner did not fall";
  EXPECT_EQ(sim.mesh().flags[sim.mesh().slot(8, 0)] & kernels::kParticlePinned, 0);
  EXPECT_EQ(sim.config().cloth.pinned.size(), 1u);
  EXPECT_THROW(sim.release_pin(8, 0), std::invalid_argument);  // no longer pinned
}

TEST(SceneEvents, MovedObstaclePushesTheCloth) {
  // A cloth at rest on a table whose top then rises at 0.2 m/s for 10 steps (2 cm).
  SimulationConfig c = held_sheet();
  c.cloth.pinned.clear();
  c.cloth.origin = {-0.1, -0.1, 0.502};
  c.time.step = 0.01;
  c.solver.tolerance = 1e-4;
  kernels::ObstacleConfig table;
  table.kind = kernels::ObstacleKind::box;
  table.center = {0.0, 0.0, 0.25};
  table.half_extents = {0.3, 0.3, 0.25};
  c.obstacles = {table};
  SceneEvent lift;
  lift.kind = SceneEventKind::move_obstacle;
  lift.obstacle = 0;
  lift.velocity = {0.0, 0.0, 0.2};
  lift.step = 3;
  lift.until_step = 12;
  c.events = {lift};
  Simulation sim(c);
  schedulers::OmpStaticDriver driver;
  auto mean_height = [&] {
    double sum = 0.0;
    for (int i = 0; i < 9; ++i) {
      for (int j = 0; j < 9; ++j) sum += position(sim, i, j).z();
    }
    return sum / 81.0;
  };
  const double before = mean_height();
  for (int step = 1; step <= 20; ++step) sim.step(driver);
  EXPECT_NEAR(sim.obstacles()[0].center().z(), 0.27, 1e-12);
  EXPECT_NEAR(sim.config().obstacles[0].center.z(), 0.27, 1e-12);
  EXPECT_GT(mean_height() - before, 0.018) << "the table did not carry the cloth up";
  const kernels::StateDiagnostics d = sim.diagnostics();
  EXPECT_GT(d.min_particle_distance, 0.0) << "a particle is inside the table";
  EXPECT_NEAR(d.contact_support / d.weight, 1.0, 0.05);
}

TEST(SceneEvents, DisplacementIsAppliedOnceAndForcesOnOneParticleAdd) {
  SimulationConfig c = held_sheet();
  kernels::ObstacleConfig ball;
  ball.kind = kernels::ObstacleKind::sphere;
  ball.center = {0.0, 0.0, 0.2};
  ball.radius = 0.05;
  c.obstacles = {ball};
  SceneEvent jump;
  jump.kind = SceneEventKind::move_obstacle;
  jump.displacement = {0.01, 0.0, 0.0};
  jump.step = jump.until_step = 2;
  c.events = {jump, force_event(4, 4, {0, 0, 1e-3}, 1, 3), force_event(4, 4, {0, 0, 2e-3}, 2, 2)};
  Simulation sim(c);
  schedulers::OmpStaticDriver driver;
  const std::vector<kernels::ExternalForce>& forces = sim.state().external_forces;
  sim.step(driver);
  ASSERT_EQ(forces.size(), 1u);
  EXPECT_EQ(forces[0].force.z(), 1e-3);
  sim.step(driver);
  EXPECT_EQ(forces[0].force.z(), 1e-3 + 2e-3);
  sim.step(driver);
  EXPECT_EQ(forces[0].force.z(), 1e-3);
  sim.step(driver);
  EXPECT_TRUE(forces.empty());
  EXPECT_EQ(sim.obstacles()[0].center().x(), 0.01);
}

TEST(SceneEvents, ForcedParticleIsMadeAndKeptActiveByAmrc) {
  SimulationConfig c = held_sheet();
  c.amrc.enabled = true;
  c.amrc.levels = 2;
  Simulation sim(c);
  // Coarsen everything that can be: (3, 5) is then inside a level-2 leaf.
  kernels::AdaptiveMesh& tree = sim.begin_tree_edit();
  for (int k = 1; k <= 2; ++k) {
    for (int ci = 0; ci < (8 >> k); ++ci) {
      for (int cj = 0; cj < (8 >> k); ++cj) tree.coarsen(kernels::TreeCell{k, ci, cj}, sim.mesh());
    }
  }
  sim.end_tree_edit();
  const std::int64_t s = sim.mesh().slot(3, 5);
  ASSERT_EQ(sim.mesh().flags[s] & kernels::kParticleActive, 0);
  const double mass = sim.mesh().total_mass();
  sim.set_external_force(3, 5, {0.0, 0.0, 1e-3});
  EXPECT_NE(sim.mesh().flags[s] & kernels::kParticleActive, 0) << "not refined to a particle";
  EXPECT_TRUE(sim.adaptive_mesh()->balanced());
  EXPECT_NEAR(sim.mesh().total_mass(), mass, 1e-12 * mass);
  // A merge that would drop it is refused while the force acts, allowed once it ends.
  kernels::AdaptiveMesh& again = sim.begin_tree_edit();
  EXPECT_FALSE(again.coarsen(kernels::TreeCell{1, 1, 2}, sim.mesh()));
  sim.end_tree_edit();
  sim.clear_external_force(3, 5);
  kernels::AdaptiveMesh& last = sim.begin_tree_edit();
  EXPECT_TRUE(last.coarsen(kernels::TreeCell{1, 1, 2}, sim.mesh()));
  sim.end_tree_edit();
  EXPECT_EQ(sim.mesh().flags[s] & kernels::kParticleActive, 0);
}

TEST(SceneEvents, KernelRefusesEventsItCannotApply) {
  auto refused = [](SceneEvent e) {
    SimulationConfig c = held_sheet();
    c.events = {e};
    try {
      Simulation sim(c);
    } catch (const std::invalid_argument&) {
      return true;
    }
    return false;
  };
  SceneEvent move;
  move.kind = SceneEventKind::move_obstacle;
  move.obstacle = 0;  // the sheet has no obstacle
  EXPECT_TRUE(refused(move));
  SceneEvent release;
  release.kind = SceneEventKind::release_pin;
  release.particle_i = 4;  // not pinned
  EXPECT_TRUE(refused(release));
  EXPECT_TRUE(refused(force_event(9, 0, {0, 0, 1}, 1, 1)));  // outside the grid
  EXPECT_TRUE(refused(force_event(1, 1, {0, 0, 1}, 5, 4)));  // ends before it begins
  EXPECT_FALSE(refused(force_event(1, 1, {0, 0, 1}, 5, 5)));
  Simulation sim(held_sheet());
  EXPECT_THROW(sim.move_obstacle(0, {0, 0, 1}), std::out_of_range);
  EXPECT_THROW(sim.set_external_force(0, 9, {0, 0, 1}), std::invalid_argument);
}

}  // namespace
}  // namespace clothbench
