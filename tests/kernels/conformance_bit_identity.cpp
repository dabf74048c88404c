// Bit-identity of the simulation across every scheduler backend and thread count: final
// positions, element forces and the step costs must be byte-for-byte equal (MODEL.md 7).
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include "kernel_fixtures.hpp"
#include "schedulers/registry.hpp"
#include "tests/harness/sanitizer_build.hpp"

namespace clothbench {
namespace {

/// The raw bytes of everything a run returns: shape, forces, and the cost of every step.
struct RunBytes {
  std::vector<double> position, edge_force, triple_moment, costs;
};

/// One bit-identity case: a formulation, with or without AMRC and scripted events.
struct Case {
  kernels::Formulation formulation;
  bool amrc;
  bool events = false;
  bool line_solves = false;  ///< the line-solve preconditioner instead of block Jacobi
  bool newton = false;       ///< Newton with linear PCG instead of nonlinear CG
  bool multigrid = false;    ///< Newton's PCG preconditioned by the multigrid
  bool smoothing = false;    ///< Newton with nonlinear block Gauss-Seidel after each line search
  bool vcycle = false;       ///< Newton's PCG preconditioned by the V-cycle
  bool vector = false;       ///< the vector element kernel (ElementKernel::vector)
  bool tilted = false;       ///< the tilted tension plateau ([fabric] tension_plateau_slope)
};

/// Events on every one of the four steps: a pull (on a particle AMRC may have coarsened away
/// by step 2), the box jumping and then rising, the pin let go.
std::vector<kernels::SceneEvent> scripted_events() {
  using kernels::SceneEventKind;
  std::vector<kernels::SceneEvent> events(4);
  events[0].kind = SceneEventKind::force;
  events[0].particle_i = 11;
  events[0].particle_j = 9;
  events[0].force = {0.0005, 0.0, 0.002};
  events[0].step = 1;
  events[0].until_step = 3;
  events[1].kind = SceneEventKind::force;
  events[1].particle_i = 5;
  events[1].particle_j = 3;
  events[1].force = {0.0, -0.001, 0.001};
  events[1].step = events[1].until_step = 2;
  events[2].kind = SceneEventKind::move_obstacle;
  events[2].displacement = {0.001, 0.0, 0.0};
  events[2].velocity = {0.0, 0.0, 0.05};
  events[2].step = 2;
  events[2].until_step = 4;
  events[3].kind = SceneEventKind::release_pin;
  events[3].step = events[3].until_step = 3;
  return events;
}

kernels::SimulationConfig bit_identity_scene(const Case& test_case) {
  const kernels::Formulation formulation = test_case.formulation;
  kernels::SimulationConfig c;
  c.cloth.particles_i = 23;
  c.cloth.particles_j = 19;
  c.cloth.block_size = 5;
  c.cloth.size_i = 0.44;
  c.cloth.size_j = 0.36;
  c.cloth.origin = {-0.22, -0.18, 0.103};
  c.cloth.initial_crumple = 0.002;
  c.cloth.pinned = {{0, 0}};
  c.obstacles.push_back(testing::box_obstacle({0.0, 0.0, 0.05}, {0.1, 0.1, 0.05}));
  c.time.step = 0.004;
  c.solver.formulation = formulation;
  c.solver.max_iterations = formulation == kernels::Formulation::potential ? 25 : 6;
  c.solver.tolerance = 1e-6;
  // A rejected step is redone as two halves, once: the rejection path runs in every case
  // whose solve misses its tolerance, and deeper halvings would only repeat it (nonlinear CG
  // at this step length rejects down to dt/16 otherwise, at 2-3 times the work).
  c.solver.max_step_halvings = 1;
  // Each case names its solver: nonlinear CG with block Jacobi unless it says otherwise.
  c.solver.method = kernels::StepMethod::nonlinear_cg;
  c.solver.preconditioner = kernels::Preconditioner::block_jacobi;
  if (test_case.vector) c.solver.kernel = kernels::ElementKernel::vector;
  if (test_case.line_solves) c.solver.preconditioner = kernels::Preconditioner::line_solves;
  if (test_case.multigrid) c.solver.preconditioner = kernels::Preconditioner::multigrid;
  if (test_case.vcycle) {
    // Three levels or more on these small meshes: the line sweeps of every level and the
    // coarsest solve all run.
    c.solver.preconditioner = kernels::Preconditioner::vcycle;
    c.solver.coarsest_nodes = 30;
  }
  if (test_case.newton) {
    c.solver.method = kernels::StepMethod::newton;
    c.solver.max_newton_iterations = 6;
    c.solver.max_linear_iterations = 20;
    c.solver.smoothing_sweeps = 0;  // Newton's own path; the smoothing cases add it
    if (test_case.smoothing) {
      // Colour by colour over the ghosts of the AMRC case; a low threshold so that most
      // particles move in every sweep.
      c.solver.smoothing_sweeps = 2;
      c.solver.smoothing_threshold = 1e-3;
    }
  }
  if (test_case.amrc) {
    // 25 x 17 = 2^3 n + 1; a check after every step with close thresholds, so that cells are
    // split and merged (with ghosts) while the schedulers run over the changing lists.
    c.cloth.particles_i = 25;
    c.cloth.particles_j = 17;
    c.cloth.size_i = 0.48;
    c.cloth.size_j = 0.32;
    c.cloth.origin = {-0.24, -0.16, 0.103};
    c.amrc.enabled = true;
    c.amrc.levels = 3;
    c.amrc.check_every = 1;
    c.amrc.refine_threshold = 0.35;
    c.amrc.coarsen_threshold = 0.15;
  }
  if (test_case.events) {
    c.events = scripted_events();
  }
  // Steeper than a scene would take, so that many edges sit on the line inside the band.
  if (test_case.tilted) c.fabric.tension_plateau_slope = 1e-2;
  return c;
}

RunBytes run(const std::string& scheduler, int threads, const Case& test_case) {
  omp_set_num_threads(threads);
  kernels::Simulation sim(bit_identity_scene(test_case));
  auto driver = schedulers::make_driver(scheduler);
  RunBytes out;
  for (int step = 0; step < 4; ++step) {
    const kernels::StepReport r = sim.step(*driver);
    out.costs.push_back(r.minimiser.final.cost);
    out.costs.push_back(static_cast<double>(r.events.size()));
    if (r.amrc) {
      out.costs.push_back(static_cast<double>(r.amrc->particles));
      out.costs.push_back(static_cast<double>(r.amrc->refined + r.amrc->coarsened));
    }
  }
  // Steps whose solves built the V-cycle (vcycle_after): the switch is a decision too.
  out.costs.push_back(static_cast<double>(sim.vcycle_work().steps));
  out.costs.push_back(static_cast<double>(sim.vcycle_work().factorisations));
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

class BitIdentity : public ::testing::TestWithParam<Case> {};

TEST_P(BitIdentity, EverySchedulerAndThreadCountGivesTheSameBytes) {
  const RunBytes reference = run("static", 1, GetParam());
  ASSERT_GT(reference.costs.size(), 2u);
  if (GetParam().vcycle) {
    // Each step's solves start with block Jacobi; the case must reach the V-cycle too.
    ASSERT_GT(reference.costs.back(), 0.0) << "no solve built the V-cycle";
  }
  if (GetParam().amrc) {
    ASSERT_GT(reference.costs.size(), 4u);
    double changes = 0.0;
    for (std::size_t k = 0; k + 3 < reference.costs.size(); k += 4) changes += reference.costs[k + 3];
    ASSERT_GT(changes, 0.0) << "the AMRC case must split or merge cells";
  }
  std::vector<std::string> schedulers = schedulers::available_schedulers();
  const bool quick = std::getenv("CLOTHBENCH_CONFORMANCE_QUICK") != nullptr;
  // The two-level multigrid builds and solves its coarse operator on one thread (inside
  // `omp single`); its parallel loops, the line solves, the restriction's rows and the
  // prolongation's particles, are index loops like every other case's. Under a sanitizer
  // (the kernel 5-25 times slower) its cases therefore run one scheduler per way of cutting
  // ranges, as AddressSanitizer does for every case.
  const bool legacy_multigrid = GetParam().multigrid;
  if (clothbench_test::kSanitized && (!quick || legacy_multigrid)) {
    // AddressSanitizer: one scheduler per way of cutting ranges, where an index out of bounds
    // would show. The (non)monotonic and runtime forms of a clause cut ranges as the clause
    // does; the Release builds compare all of them at every thread count, ThreadSanitizer at 2
    // (the multigrid's cases: these ten).
    const std::vector<std::string> cutting{
        "static@blocks",     "static:4@blocks",     "dynamic:3@blocks", "guided:4@blocks",
        "taskloop:4@blocks", "fac2:1@blocks",       "tss:1@blocks",     "gss:1@blocks",
        "active-lists@active", "dynamic:64@active"};
    for (const std::string& name : cutting) {
      ASSERT_NE(std::find(schedulers.begin(), schedulers.end(), name), schedulers.end()) << name;
    }
    schedulers = cutting;
  }
  // Release builds: every thread count; CLOTHBENCH_CONFORMANCE_QUICK: 1 and 2. A sanitizer
  // build (the kernel 10-25 times slower) runs its schedulers at the one split its sanitizer
  // is for, the 1-thread path being the reference run's: ThreadSanitizer (scripts/tsan-check,
  // which sets QUICK) 2 threads, where a race needs two; AddressSanitizer 3, an uneven split
  // whose ranges end inside tiles and lines, where an out-of-bounds index would be.
  std::vector<int> thread_counts{1, 2, 3, 4, 8};
  if (quick) thread_counts = {1, 2};
  if (clothbench_test::kSanitized) thread_counts = {quick ? 2 : 3};
  for (const std::string& scheduler : schedulers) {
    for (int threads : thread_counts) {
      expect_identical(reference, run(scheduler, threads, GetParam()),
                       scheduler + " with " + std::to_string(threads) + " threads");
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Formulations, BitIdentity,
                         ::testing::Values(Case{kernels::Formulation::potential, false},
                                           Case{kernels::Formulation::violation, false},
                                           Case{kernels::Formulation::potential, true},
                                           Case{kernels::Formulation::violation, true},
                                           Case{kernels::Formulation::potential, false, true},
                                           Case{kernels::Formulation::violation, true, true},
                                           Case{kernels::Formulation::potential, false, false, true},
                                           Case{kernels::Formulation::potential, true, true, true},
                                           Case{kernels::Formulation::potential, false, false, false, true},
                                           Case{kernels::Formulation::potential, true, true, false, true},
                                           Case{kernels::Formulation::potential, true, true, true, true},
                                           Case{kernels::Formulation::potential, false, false, false, true, true},
                                           Case{kernels::Formulation::potential, true, true, false, true, true},
                                           Case{kernels::Formulation::potential, false, false, true, true, false, true},
                                           Case{kernels::Formulation::potential, true, true, true, true, false, true},
                                           Case{kernels::Formulation::potential, false, false, false, true, false, true, true},
                                           Case{kernels::Formulation::potential, true, true, false, true, false, true, true},
                                           Case{kernels::Formulation::potential, false, false, false, false, false, false, false, true},
                                           Case{kernels::Formulation::potential, true, true, false, false, false, false, false, true},
                                           Case{.formulation = kernels::Formulation::potential, .amrc = false, .tilted = true},
                                           Case{.formulation = kernels::Formulation::potential, .amrc = true, .events = true,
                                                .newton = true, .vcycle = true, .tilted = true}),
                         [](const auto& info) {
                           std::string name = info.param.formulation == kernels::Formulation::potential
                                                  ? "potential"
                                                  : "violation";
                           if (info.param.amrc) name += "_amrc";
                           if (info.param.events) name += "_events";
                           if (info.param.line_solves) name += "_lines";
                           if (info.param.multigrid) name += "_multigrid";
                           if (info.param.smoothing) name += "_smoothing";
                           if (info.param.vcycle) name += "_vcycle";
                           if (info.param.vector) name += "_vector";
                           if (info.param.tilted) name += "_tilted";
                           return info.param.newton ? name + "_newton" : name;
                         });

}  // namespace
}  // namespace clothbench
