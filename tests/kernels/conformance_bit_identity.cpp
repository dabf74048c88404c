// Bit-identity of the simulation across every scheduler backend and thread count: final
// positions, element forces and the step costs must be byte-for-byte equal (MODEL.md 7).
#include <gtest/gtest.h>
#include <omp.h>

#include <cstring>
#include <string>
#include <vector>

#include "kernel_fixtures.hpp"
#include "schedulers/registry.hpp"

namespace clothbench {
namespace {

/// The raw bytes of everything a run returns: shape, forces, and the cost of every step.
struct RunBytes {
  std::vector<double> position, edge_force, triple_moment, costs;
};

kernels::SimulationConfig bit_identity_scene(kernels::Formulation formulation) {
  kernels::SimulationConfig c;
  c.cloth.particles_i = 23;
  c.cloth.particles_j = 19;
  c.cloth.block_size = 5;
  c.cloth.size_i = 0.44;
  c.cloth.size_j = 0.36;
  c.cloth.origin = {-0.22, -0.18, 0.103};
  c.cloth.initial_crumple = 0.002;
  c.cloth.pinned = {{0, 0}};
  kernels::ObstacleConfig box;
  box.kind = kernels::ObstacleKind::box;
  box.center = {0.0, 0.0, 0.05};
  box.half_extents = {0.1, 0.1, 0.05};
  c.obstacles.push_back(box);
  c.time.step = 0.004;
  c.solver.formulation = formulation;
  c.solver.max_iterations = formulation == kernels::Formulation::potential ? 25 : 6;
  c.solver.tolerance = 1e-6;
  return c;
}

RunBytes run(const std::string& scheduler, int threads, kernels::Formulation formulation) {
  omp_set_num_threads(threads);
  kernels::Simulation sim(bit_identity_scene(formulation));
  auto driver = schedulers::make_driver(scheduler);
  RunBytes out;
  for (int step = 0; step < 4; ++step) out.costs.push_back(sim.step(*driver).minimiser.final.cost);
  out.position = sim.state().position;
  out.edge_force = sim.state().edge_force;
  out.triple_moment = sim.state().triple_moment;
  return out;
}

bool same_bytes(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

void expect_identical(const RunBytes& reference, const RunBytes& other, const std::string& what) {
  EXPECT_TRUE(same_bytes(reference.position, other.position)) << what << ": positions differ";
  EXPECT_TRUE(same_bytes(reference.edge_force, other.edge_force)) << what << ": tensions differ";
  EXPECT_TRUE(same_bytes(reference.triple_moment, other.triple_moment))
      << what << ": moments differ";
  EXPECT_TRUE(same_bytes(reference.costs, other.costs)) << what << ": step costs differ";
}

class BitIdentity : public ::testing::TestWithParam<kernels::Formulation> {};

TEST_P(BitIdentity, EverySchedulerAndThreadCountGivesTheSameBytes) {
  const RunBytes reference = run("static", 1, GetParam());
  ASSERT_GT(reference.costs.size(), 0u);
  std::vector<std::string> schedulers = schedulers::available_schedulers();
  const bool quick = std::getenv("CLOTHBENCH_CONFORMANCE_QUICK") != nullptr;
  for (const std::string& scheduler : schedulers) {
    for (int threads : {1, 2, 3, 4, 8}) {
      if (quick && threads > 2) continue;
      expect_identical(reference, run(scheduler, threads, GetParam()),
                       scheduler + " with " + std::to_string(threads) + " threads");
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Formulations, BitIdentity,
                         ::testing::Values(kernels::Formulation::potential,
                                           kernels::Formulation::violation),
                         [](const auto& info) {
                           return info.param == kernels::Formulation::potential ? "potential"
                                                                               : "violation";
                         });

}  // namespace
}  // namespace clothbench
