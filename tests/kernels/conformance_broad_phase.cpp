// The contact broad phase is exact: a run with it gives the same bytes as a run without it
// (positions, forces, every evaluation's value), for both formulations, with AMRC, under
// Newton (whose model also tests where its last direction would take each particle), with
// obstacles several of which are far from parts of the cloth, across schedulers and thread
// counts; it rules out work on such scenes; and scenes without obstacles do no contact work.
#include <gtest/gtest.h>
#include <omp.h>

#include <cstring>
#include <string>
#include <vector>

#include "kernels/simulation.hpp"
#include "schedulers/registry.hpp"

namespace clothbench {
namespace {

struct Case {
  kernels::Formulation formulation;
  bool amrc;
  bool newton = false;  ///< Newton with the V-cycle: its model's contacts reach along p too
};

/// A 25 x 17 cloth (blocks of 4) falling onto a box, a sphere and a plane below, with a
/// cylinder far away: tiles near and far from every obstacle, contact on some.
kernels::SimulationConfig contact_scene(const Case& test_case) {
  kernels::SimulationConfig c;
  c.cloth.particles_i = 25;
  c.cloth.particles_j = 17;
  c.cloth.block_size = 4;
  c.cloth.size_i = 0.48;
  c.cloth.size_j = 0.32;
  c.cloth.origin = {-0.24, -0.16, 0.1025};
  c.cloth.initial_crumple = 0.002;
  c.cloth.pinned = {{0, 0}};
  kernels::ObstacleConfig box, sphere, plane, cylinder;
  box.kind = kernels::ObstacleKind::box;
  box.center = {-0.08, 0.0, 0.05};
  box.half_extents = {0.06, 0.06, 0.05};
  sphere.kind = kernels::ObstacleKind::sphere;
  sphere.center = {0.12, 0.05, 0.04};
  sphere.radius = 0.06;
  plane.kind = kernels::ObstacleKind::plane;
  plane.center = {0.0, 0.0, 0.0};
  plane.normal = Eigen::Vector3d(0.1, 0.0, 1.0).normalized();
  cylinder.kind = kernels::ObstacleKind::cylinder;
  cylinder.center = {0.5, 0.5, 0.0};
  cylinder.axis = {0.0, 1.0, 0.0};
  c.obstacles = {box, sphere, plane, cylinder};
  c.time.step = 0.01;
  c.solver.formulation = test_case.formulation;
  c.solver.max_iterations = test_case.formulation == kernels::Formulation::potential ? 25 : 6;
  c.solver.tolerance = 1e-6;
  c.solver.record_values = true;  // every iteration's objective value is compared too
  // One halving: at this step length nonlinear CG misses its tolerance and would halve down
  // to dt/64 (violation: 64 sub-steps a step); the contacts, and the broad phase's
  // decisions, are the same kind in every sub-step, so two of them test it as well.
  c.solver.max_step_halvings = 1;
  c.solver.method = kernels::StepMethod::nonlinear_cg;
  c.solver.preconditioner = kernels::Preconditioner::block_jacobi;
  if (test_case.newton) {
    c.solver.method = kernels::StepMethod::newton;
    c.solver.preconditioner = kernels::Preconditioner::vcycle;
    c.solver.max_newton_iterations = 12;
  }
  if (test_case.amrc) {
    c.amrc.enabled = true;
    c.amrc.levels = 3;
    c.amrc.check_every = 1;
    c.amrc.refine_threshold = 0.35;
    c.amrc.coarsen_threshold = 0.15;
  }
  return c;
}

struct RunBytes {
  std::vector<double> position, edge_force, triple_moment, values;
  kernels::ContactWork work;
};

RunBytes run(const Case& test_case, bool broad_phase, const std::string& scheduler, int threads) {
  omp_set_num_threads(threads);
  kernels::SimulationConfig c = contact_scene(test_case);
  c.contact.broad_phase = broad_phase;
  kernels::Simulation sim(c);
  auto driver = schedulers::make_driver(scheduler);
  RunBytes out;
  for (int step = 0; step < 4; ++step) {
    const kernels::StepReport r = sim.step(*driver);
    out.values.insert(out.values.end(), r.minimiser.values.begin(), r.minimiser.values.end());
    out.values.push_back(r.minimiser.final.cost);
  }
  out.position = sim.state().position;
  out.edge_force = sim.state().edge_force;
  out.triple_moment = sim.state().triple_moment;
  out.work = sim.contact_work();
  return out;
}

bool same_bytes(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

class BroadPhase : public ::testing::TestWithParam<Case> {};

TEST_P(BroadPhase, OnAndOffGiveTheSameBytes) {
  const RunBytes off = run(GetParam(), false, "static", 1);
  ASSERT_GT(off.work.tested, 0);
  EXPECT_EQ(off.work.skipped, 0);
  for (const auto& [scheduler, threads] :
       std::vector<std::pair<std::string, int>>{{"static", 1}, {"dynamic:1", 3}, {"active-lists", 2}}) {
    const RunBytes on = run(GetParam(), true, scheduler, threads);
    const std::string what = scheduler + " with " + std::to_string(threads) + " threads";
    EXPECT_TRUE(same_bytes(off.position, on.position)) << what << ": positions differ";
    EXPECT_TRUE(same_bytes(off.edge_force, on.edge_force)) << what << ": tensions differ";
    EXPECT_TRUE(same_bytes(off.triple_moment, on.triple_moment)) << what << ": moments differ";
    EXPECT_TRUE(same_bytes(off.values, on.values)) << what << ": objective values differ";
    // Same evaluations; every pair is either tested or ruled out, and many are ruled out.
    EXPECT_EQ(on.work.evaluations, off.work.evaluations) << what;
    EXPECT_EQ(on.work.tested + on.work.skipped, off.work.tested) << what;
    EXPECT_GT(on.work.skipped, off.work.tested / 2) << what;
    EXPECT_GT(on.work.tested, 0) << what;
  }
}

INSTANTIATE_TEST_SUITE_P(Formulations, BroadPhase,
                         ::testing::Values(Case{kernels::Formulation::potential, false},
                                           Case{kernels::Formulation::violation, false},
                                           Case{kernels::Formulation::potential, true},
                                           Case{kernels::Formulation::violation, true},
                                           Case{kernels::Formulation::potential, true, true}),
                         [](const auto& info) {
                           std::string name = info.param.formulation == kernels::Formulation::potential
                                                  ? "potential"
                                                  : "violation";
                           if (info.param.amrc) name += "_amrc";
                           return info.param.newton ? name + "_newton" : name;
                         });

TEST(BroadPhase, SceneWithoutObstaclesDoesNoContactWork) {
  kernels::SimulationConfig c = contact_scene({kernels::Formulation::potential, false});
  c.obstacles.clear();
  for (const bool broad_phase : {true, false}) {
    c.contact.broad_phase = broad_phase;
    kernels::Simulation sim(c);
    auto driver = schedulers::make_driver("static");
    for (int step = 0; step < 2; ++step) sim.step(*driver);
    EXPECT_GT(sim.contact_work().evaluations, 0);
    EXPECT_EQ(sim.contact_work().tested, 0);
    EXPECT_EQ(sim.contact_work().skipped, 0);
  }
}

}  // namespace
}  // namespace clothbench
