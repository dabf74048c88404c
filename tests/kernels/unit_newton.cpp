// The Newton step solver (kernels/newton_minimiser.hpp): the nonlinear smoothing's colours
// keep every element to one moving particle per colour and its moves only lower Phi; Newton
// (with and without the smoothing and the model's refinement) reaches the state nonlinear CG
// reaches and assembles its model as often as its refinements ask; the V-cycle is built only
// for steps whose solves need more than block Jacobi; the per-iteration log changes no bit; the
// model drops bending's floor along the turning vector only after a full step; and
// damping is a rate, so halving the step does not add damping. The model Hessian:
// unit_model_hessian.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <tuple>
#include <vector>

#include "newton_fixtures.hpp"

namespace clothbench {
namespace {

using kernels::Preconditioner;
using kernels::StepMethod;
using testing::grade_and_randomise;
using testing::graded_config;
using testing::ModelFixture;
using testing::newton_config;
using testing::small_drape;

/// The free particles that move a node: itself, or a ghost's parents (recursively).
void owners_of(const kernels::ClothMesh& mesh, std::int64_t k, std::vector<std::int64_t>& out) {
  const int d = kernels::ghost_direction(mesh.flags[k]);
  if (d < 0) {
    out.push_back(k);
    return;
  }
  const std::int64_t id = kernels::element_id(k, d);
  owners_of(mesh, mesh.prev[id], out);
  owners_of(mesh, mesh.next[id], out);
}

/// Every element's nodes, ghosts resolved into the particles that move them: no two of one
/// colour (else two threads would change one element's energy at once); every free particle
/// and only those coloured.
void expect_valid_colouring(ModelFixture& f) {
  const kernels::ClothMesh& mesh = f.sim.mesh();
  const std::vector<std::int16_t>& colour = f.objective.smoothing_colours();
  ASSERT_EQ(colour.size(), static_cast<std::size_t>(mesh.slot_count()));
  int elements = 0;
  for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
    std::vector<std::int64_t> nodes;
    const std::int64_t slot = kernels::element_slot(id);
    if (mesh.edge_active[id]) nodes = {slot, mesh.next[id]};
    if (mesh.triple_active[id]) nodes = {mesh.prev[id], slot, mesh.next[id]};
    if (nodes.empty()) continue;
    std::vector<std::int64_t> owners;
    for (std::int64_t k : nodes) owners_of(mesh, k, owners);
    std::sort(owners.begin(), owners.end());
    owners.erase(std::unique(owners.begin(), owners.end()), owners.end());
    for (std::size_t a = 0; a < owners.size(); ++a) {
      for (std::size_t b = a + 1; b < owners.size(); ++b) {
        if (colour[owners[a]] < 0 || colour[owners[b]] < 0) continue;
        EXPECT_NE(colour[owners[a]], colour[owners[b]])
            << "element " << id << " moves with slots " << owners[a] << " and " << owners[b];
      }
    }
    ++elements;
  }
  EXPECT_GT(elements, 0);
  EXPECT_GE(f.objective.smoothing_colour_count(), 3u);
  for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
    EXPECT_EQ(colour[s] >= 0, f.ctx.is_free(s)) << "slot " << s;
  }
  // Each colour's ghost list: exactly the ghosts one of its particles moves, each once, in
  // slot order.
  const auto& listed = f.objective.smoothing_ghosts();
  ASSERT_EQ(listed.size(), f.objective.smoothing_colour_count());
  std::vector<std::vector<std::int64_t>> expected(listed.size());
  for (std::int64_t g = 0; g < mesh.slot_count(); ++g) {
    if (kernels::ghost_direction(mesh.flags[g]) < 0) continue;
    std::vector<std::int64_t> owners;
    owners_of(mesh, g, owners);
    std::vector<int> colours;
    for (std::int64_t k : owners) {
      if (colour[k] >= 0) colours.push_back(colour[k]);
    }
    std::sort(colours.begin(), colours.end());
    colours.erase(std::unique(colours.begin(), colours.end()), colours.end());
    for (int c : colours) expected[static_cast<std::size_t>(c)].push_back(g);
  }
  EXPECT_EQ(listed, expected);
}

/// Every ghost of `sim` sits exactly (bit for bit) on the midpoint of its parents.
void expect_ghosts_on_midpoints(const kernels::Simulation& sim) {
  const kernels::ClothMesh& mesh = sim.mesh();
  const std::vector<double>& x = sim.state().position;
  int ghosts = 0;
  for (std::int64_t g = 0; g < mesh.slot_count(); ++g) {
    if (kernels::ghost_direction(mesh.flags[g]) < 0) continue;
    ++ghosts;
    const Eigen::Vector3d midpoint = kernels::node_value(mesh, x, g);
    EXPECT_EQ(kernels::vec3(x, g), midpoint) << "ghost " << g;
  }
  EXPECT_GT(ghosts, 0);
}

TEST(NonlinearSmoothing, NoElementMovesWithTwoParticlesOfOneColourAndPhiOnlyFalls) {
  kernels::SimulationConfig c = graded_config();
  c.solver.smoothing_sweeps = 3;
  for (unsigned seed : {1u, 2u, 3u}) {
    ModelFixture f(c);
    grade_and_randomise(f, seed);
    if (HasFatalFailure()) return;
    f.assemble();
    kernels::Evaluation before, after;
    std::int64_t moved = 0;
    f.run([&](kernels::LoopRunner& r) {
      before = f.objective.evaluate(r);
      f.objective.colour_for_smoothing(r);
      moved = f.objective.smooth(r, 3, 1e-6);
      after = f.objective.evaluate(r);
    });
    expect_valid_colouring(f);
    expect_ghosts_on_midpoints(f.sim);  // each colour refreshed the ghosts its moves moved
    EXPECT_GT(moved, 0) << "seed " << seed;
    EXPECT_LT(after.value, before.value) << "seed " << seed;
    EXPECT_LT(after.cost, before.cost) << "seed " << seed << ": the residual falls too";
  }
}

TEST(NonlinearSmoothing, TheColouringIsKeptWhileTheMeshIsUnchangedAndMadeAgainAfterAnEdit) {
  kernels::SimulationConfig c = graded_config();
  c.solver.smoothing_sweeps = 3;
  ModelFixture f(c);
  f.run([&](kernels::LoopRunner& r) { f.objective.colour_for_smoothing(r); });
  expect_valid_colouring(f);  // the uniform mesh
  const std::vector<std::int16_t> uniform = f.objective.smoothing_colours();
  testing::randomise_state(f.sim, 4);  // positions do not change the topology
  f.run([&](kernels::LoopRunner& r) { f.objective.colour_for_smoothing(r); });
  EXPECT_EQ(f.objective.smoothing_colours(), uniform);
  grade_and_randomise(f, 5);  // an AMRC edit: inactive slots, ghosts
  if (HasFatalFailure()) return;
  f.run([&](kernels::LoopRunner& r) { f.objective.colour_for_smoothing(r); });
  expect_valid_colouring(f);
  EXPECT_NE(f.objective.smoothing_colours(), uniform);
}

TEST(NewtonMinimiser, ReachesTheStateNonlinearCgReaches) {
  kernels::SimulationConfig cg = small_drape();
  cg.solver.method = StepMethod::nonlinear_cg;
  kernels::SimulationConfig newton = newton_config(cg);
  // Nonlinear CG has no multigrid: Newton-multigrid is compared with CG and line solves.
  // The last pairs: Newton with nonlinear smoothing after each line search, and without the
  // model's refinement along each direction (-1: the default, one).
  const std::tuple<Preconditioner, Preconditioner, int, int> pairs[] = {
      {Preconditioner::block_jacobi, Preconditioner::block_jacobi, 0, -1},
      {Preconditioner::line_solves, Preconditioner::line_solves, 0, -1},
      {Preconditioner::line_solves, Preconditioner::multigrid, 0, -1},
      {Preconditioner::line_solves, Preconditioner::vcycle, 0, -1},
      {Preconditioner::line_solves, Preconditioner::line_solves, 3, -1},
      {Preconditioner::line_solves, Preconditioner::line_solves, 3, 0}};
  for (const auto& [pc, p, sweeps, refinements] : pairs) {
    cg.solver.preconditioner = pc;
    newton.solver.preconditioner = p;
    newton.solver.smoothing_sweeps = sweeps;
    newton.solver.model_refinements = refinements;
    kernels::Simulation a(cg), b(newton);
    schedulers::OmpStaticDriver driver;
    int newton_iterations = 0, linear_iterations = 0;
    for (int step = 0; step < 10; ++step) {
      const kernels::StepReport ra = a.step(driver), rb = b.step(driver);
      // Nonlinear CG's line search can stall a little above the tolerance at contact onset.
      EXPECT_LE(kernels::MinimiserReport::rms(ra.minimiser.final), 1e-3) << "CG step " << ra.step;
      EXPECT_EQ(rb.minimiser.reason, kernels::StopReason::converged) << "Newton step " << rb.step;
      EXPECT_LE(kernels::MinimiserReport::rms(rb.minimiser.final), cg.solver.tolerance);
      newton_iterations += rb.minimiser.iterations;
      linear_iterations += rb.minimiser.linear_iterations;
    }
    EXPECT_GT(newton_iterations, 0);
    EXPECT_GE(linear_iterations, newton_iterations);
    double worst = 0.0;
    for (std::size_t i = 0; i < a.state().position.size(); ++i) {
      worst = std::max(worst, std::abs(a.state().position[i] - b.state().position[i]));
    }
    // Residuals of 1e-5 (Newton) to 1e-3 (CG) weights put a particle off the minimiser by
    // about r m g / (m / dt^2) <= 2e-7 m: far below the millimetres the cloth moved.
    EXPECT_LT(worst, 1e-6) << "m, preconditioner " << kernels::to_string(p);
    EXPECT_GT(std::abs(a.state().position[2] - cg.cloth.origin.z()), 1e-3) << "the cloth moved";
    EXPECT_GT(a.diagnostics().contact_support, 0.0) << "and touches the obstacles";
  }
}

TEST(NewtonMinimiser, AssemblesTheModelAgainAlongEachDirectionItsRefinementsAsk) {
  // Under the V-cycle every assembly is one factorisation: a step of N >= 1 Newton iterations
  // assembles at its start and before each later iteration (N), and again `refinements` times
  // after each direction; a step that converges at once assembles once.
  for (int refinements : {0, 1, 2}) {
    kernels::SimulationConfig c = newton_config(small_drape());
    c.solver.preconditioner = Preconditioner::vcycle;
    c.solver.vcycle_after = 0;  // the V-cycle from every step's first solve
    c.solver.model_refinements = refinements;
    kernels::Simulation sim(c);
    schedulers::OmpStaticDriver driver;
    std::int64_t expected = 0;
    int newton_iterations = 0;
    for (int step = 0; step < 8; ++step) {
      const kernels::StepReport r = sim.step(driver);
      ASSERT_EQ(r.sub_steps, 1);
      EXPECT_EQ(r.minimiser.reason, kernels::StopReason::converged) << "step " << r.step;
      const int n = r.minimiser.iterations;
      expected += n == 0 ? 1 : static_cast<std::int64_t>(n) * (1 + refinements);
      newton_iterations += n;
    }
    EXPECT_GT(newton_iterations, 8) << "the drape needs Newton iterations";
    EXPECT_EQ(sim.vcycle_work().factorisations, expected) << refinements << " refinements";
  }
}

TEST(NewtonMinimiser, LogsEveryIterationWithoutChangingTheResult) {
  // The log (SolverConfig::log_iterations) is a record only: the same bits with and without
  // it. Each record starts where the one before it ended, the first at the step's initial
  // guess and the last at its result, and its figures add up to the step's report.
  kernels::SimulationConfig c = newton_config(small_drape());
  c.solver.preconditioner = Preconditioner::vcycle;
  kernels::Simulation plain(c);
  c.solver.log_iterations = true;
  kernels::Simulation logged(c);
  schedulers::OmpStaticDriver driver;
  const int refinements = kernels::effective_model_refinements(c.solver);
  int newton_iterations = 0;
  std::int64_t changed = 0, taut = 0;
  for (int step = 0; step < 8; ++step) {
    const kernels::StepReport a = plain.step(driver);
    const kernels::StepReport b = logged.step(driver);
    EXPECT_TRUE(a.minimiser.newton_log.empty());
    const kernels::MinimiserReport& m = b.minimiser;
    ASSERT_EQ(b.sub_steps, 1);
    ASSERT_EQ(m.newton_log.size(), static_cast<std::size_t>(m.iterations)) << "step " << b.step;
    int linear = 0;
    std::int64_t smoothed = 0;
    for (std::size_t k = 0; k < m.newton_log.size(); ++k) {
      const kernels::NewtonIterationRecord& r = m.newton_log[k];
      EXPECT_EQ(r.attempt, 0);
      EXPECT_EQ(r.dt, c.time.step);
      EXPECT_EQ(r.iteration, static_cast<int>(k));
      EXPECT_EQ(r.rms, k == 0 ? kernels::MinimiserReport::rms(m.initial)
                              : m.newton_log[k - 1].rms_after);
      EXPECT_GT(r.alpha, 0.0);
      EXPECT_LE(r.alpha, 1.0);
      EXPECT_GE(r.line_search_evaluations, 1);
      EXPECT_GT(r.forcing, 0.0);
      EXPECT_EQ(r.refinements, refinements);
      EXPECT_LE(r.rms_line_search, r.rms * 1e3) << "finite and of the step's size";
      linear += r.linear_iterations;
      smoothed += r.smoothed;
      // Every active edge on one branch; the changes counted are some of them.
      const std::int64_t edges = logged.diagnostics().active_edges;
      EXPECT_EQ(r.edges_slack + r.edges_loading + r.edges_plateau + r.edges_unloading, edges);
      EXPECT_GE(r.edges_changed, 0);
      EXPECT_LE(r.edges_changed, edges);
      changed += r.edges_changed;
      taut = std::max(taut, r.edges_loading + r.edges_plateau + r.edges_unloading);
    }
    if (!m.newton_log.empty()) {
      EXPECT_EQ(m.newton_log.back().rms_after, kernels::MinimiserReport::rms(m.final));
    }
    EXPECT_EQ(linear, m.linear_iterations) << "step " << b.step;
    EXPECT_EQ(smoothed, m.smoothed) << "step " << b.step;
    EXPECT_EQ(m.iterations, a.minimiser.iterations);
    newton_iterations += m.iterations;
  }
  EXPECT_GT(newton_iterations, 8) << "the drape needs Newton iterations";
  EXPECT_GT(changed, 0) << "edges change branch as the cloth meets the obstacles";
  EXPECT_GT(taut, 0) << "some edges carry tension";
  const std::vector<double>& x = plain.state().position;
  const std::vector<double>& y = logged.state().position;
  ASSERT_EQ(x.size(), y.size());
  EXPECT_EQ(std::memcmp(x.data(), y.data(), x.size() * sizeof(double)), 0) << "the same bits";
}

TEST(NewtonMinimiser, ReleasesBendingsFloorAlongTheTurningVectorOnlyAfterAFullStep) {
  // A step's model is last assembled at the start of its last Newton iteration (refinements
  // included): it keeps bending's floor M / kappa along the turning vector (c_along = c for
  // every triple) unless the iteration before took the full step, and then some triple's
  // c_along falls below its c. Cotton's plateau carries no moment at this drape's curvatures,
  // so every step starts from previous moments far above the band (as in unit_model_hessian's
  // rolled sheet): the bent triples are on their loading branch, where M / kappa exceeds the
  // tangent.
  kernels::SimulationConfig c = newton_config(small_drape());
  c.solver.preconditioner = Preconditioner::vcycle;
  c.solver.log_iterations = true;
  // Three cloths: the drape, whose steps end with full steps; one that stops every step after
  // one Newton iteration (its last assembly is always the step's first); and one with five
  // times the step stopped after six iterations, so that some steps end on a cut one.
  kernels::Simulation drape(c);
  c.solver.max_newton_iterations = 1;
  kernels::Simulation single(c);
  c.solver.max_newton_iterations = 6;
  c.time.step = 0.02;
  kernels::Simulation capped(c);
  schedulers::OmpStaticDriver driver;
  int released = 0, kept_first = 0, kept_after_cut = 0;
  for (int step = 0; step < 36; ++step) {
    kernels::Simulation& sim = step % 3 == 0 ? drape : (step % 3 == 1 ? single : capped);
    for (double& m : sim.state().triple_moment) m = 1e3 * sim.material().bending[0].hb;
    const kernels::StepReport r = sim.step(driver);
    ASSERT_EQ(r.sub_steps, 1);
    const std::vector<kernels::NewtonIterationRecord>& log = r.minimiser.newton_log;
    // With fewer than two iterations the last assembly is the step's first, which keeps it.
    const bool full = log.size() >= 2 && log[log.size() - 2].alpha >= 1.0;
    const kernels::ModelHessian& h = *sim.model_hessian();
    const kernels::ClothMesh& mesh = sim.mesh();
    std::int64_t below = 0;
    for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
      if (!mesh.triple_active[id]) continue;
      EXPECT_LE(h.bending_along(id), h.bending_stiffness(id)) << "triple " << id;
      if (h.bending_along(id) < h.bending_stiffness(id)) ++below;
    }
    if (full) {
      EXPECT_GT(below, 0) << "step " << r.step;
      ++released;
    } else {
      EXPECT_EQ(below, 0) << "step " << r.step;
      ++(log.size() >= 2 ? kept_after_cut : kept_first);
    }
  }
  EXPECT_GT(released, 0);
  EXPECT_GT(kept_first, 0);
  EXPECT_GT(kept_after_cut, 0);
}

TEST(NewtonMinimiser, BuildsTheVcycleOnlyForStepsWhoseSolvesNeedIt) {
  kernels::SimulationConfig c = newton_config(small_drape());
  c.solver.preconditioner = Preconditioner::vcycle;
  c.solver.vcycle_after = 4;
  kernels::Simulation sim(c);
  schedulers::OmpStaticDriver driver;
  // The cloth falls freely for its first steps (contact from step 5): inertia dominates the
  // model and the blocks meet every forcing term, so no hierarchy is built.
  for (int step = 0; step < 3; ++step) {
    const kernels::StepReport r = sim.step(driver);
    EXPECT_EQ(r.minimiser.reason, kernels::StopReason::converged) << "step " << r.step;
    EXPECT_GT(r.minimiser.linear_iterations, 0) << "step " << r.step;
  }
  EXPECT_EQ(sim.vcycle_work().factorisations, 0);
  EXPECT_EQ(sim.vcycle_work().steps, 0);
  EXPECT_EQ(sim.vcycle_work().structures, 0);
  // On the obstacles the blocks stop being enough: a solve builds the V-cycle, and every later
  // assembly of that step factorises it too.
  for (int step = 3; step < 10; ++step) {
    const kernels::StepReport r = sim.step(driver);
    EXPECT_EQ(r.minimiser.reason, kernels::StopReason::converged) << "step " << r.step;
  }
  const kernels::Simulation::VcycleWork work = sim.vcycle_work();
  EXPECT_GT(work.steps, 0);
  EXPECT_LE(work.steps, 7);
  EXPECT_GE(work.factorisations, work.steps);
}

TEST(NewtonMinimiser, AVcycleNeverNeededGivesTheBitsOfBlockJacobi) {
  // With vcycle_after at the PCG cap no solve ever switches: every step runs Newton with block
  // Jacobi, bit for bit.
  kernels::SimulationConfig jacobi = newton_config(small_drape());
  jacobi.solver.preconditioner = Preconditioner::block_jacobi;
  kernels::SimulationConfig lazy = jacobi;
  lazy.solver.preconditioner = Preconditioner::vcycle;
  lazy.solver.vcycle_after = lazy.solver.max_linear_iterations;
  kernels::Simulation a(jacobi), b(lazy);
  schedulers::OmpStaticDriver driver;
  for (int step = 0; step < 8; ++step) {
    const kernels::StepReport ra = a.step(driver), rb = b.step(driver);
    EXPECT_EQ(ra.minimiser.iterations, rb.minimiser.iterations) << "step " << ra.step;
    EXPECT_EQ(ra.minimiser.linear_iterations, rb.minimiser.linear_iterations);
  }
  EXPECT_EQ(a.state().position, b.state().position);
  EXPECT_EQ(b.vcycle_work().factorisations, 0);
}

/// A free-falling 5 x 5 cloth (no obstacle, no strain) with steps of dt and the damping of
/// 0.1 per 4 ms written for that step (the scene's damping is per step of its own length).
kernels::SimulationConfig damped_fall(double dt, StepMethod method) {
  kernels::SimulationConfig c;
  c.cloth.particles_i = c.cloth.particles_j = 5;
  c.cloth.block_size = 5;
  c.cloth.size_i = c.cloth.size_j = 0.1;
  c.time.step = dt;
  c.time.damping = 1.0 - std::pow(0.9, dt / 0.004);
  c.solver.method = method;
  c.solver.tolerance = 1e-9;
  c.solver.max_iterations = 200;
  return c;
}

/// Where particle (2, 2) is after `seconds` of steps of `dt`, and its vertical velocity (the
/// last step's displacement over dt).
struct Fall {
  double velocity = 0.0;
  double height = 0.0;
};
Fall fall(kernels::SimulationConfig c, double seconds, int halvings = 0) {
  if (halvings > 0) {  // every step rejected and redone as halves, `halvings` times
    c.solver.reject_residual = -1.0;
    c.solver.max_step_halvings = halvings;
  }
  kernels::Simulation sim(c);
  schedulers::OmpStaticDriver driver;
  const int steps = static_cast<int>(std::lround(seconds / c.time.step));
  const std::int64_t s = sim.mesh().slot(2, 2);
  double before = 0.0;
  for (int k = 0; k < steps; ++k) {
    before = sim.state().position[3 * s + 2];
    const kernels::StepReport r = sim.step(driver);
    EXPECT_EQ(r.sub_steps, 1 << halvings);
  }
  return {(sim.state().position[3 * s + 2] - before) / c.time.step,
          sim.state().position[3 * s + 2]};
}

TEST(Damping, IsARateSoHalvingTheStepDoesNotAddDamping) {
  for (StepMethod method : {StepMethod::nonlinear_cg, StepMethod::newton}) {
    const Fall coarse_fall = fall(damped_fall(0.004, method), 0.1);
    const Fall fine_fall = fall(damped_fall(0.002, method), 0.1);
    const double coarse = coarse_fall.velocity, fine = fine_fall.velocity;
    // v' = g - lambda v with lambda = -ln(0.9) / 4 ms: after 0.1 s close to g / lambda.
    const double lambda = -std::log(0.9) / 0.004, g = 9.80665;
    const double exact = -g / lambda * (1.0 - std::exp(-lambda * 0.1));
    // Backward Euler's error is O(lambda dt): a few per cent here, and halving dt halves it.
    EXPECT_NEAR(coarse, exact, 0.08 * std::abs(exact));
    EXPECT_NEAR(fine, exact, 0.04 * std::abs(exact));
    EXPECT_LT(std::abs(fine - exact), std::abs(coarse - exact));
    // Had a halved step been damped as a whole one (0.9 per 2 ms), the fine velocity would be
    // about half the coarse one.
    EXPECT_LT(std::abs(fine - coarse), 0.05 * std::abs(coarse));
    // Steps rejected and redone as two halves move exactly like steps of half the length.
    const Fall halved = fall(damped_fall(0.004, method), 0.1, 1);
    EXPECT_NEAR(halved.height, fine_fall.height, 1e-9) << "m";
    EXPECT_GT(std::abs(coarse_fall.height - fine_fall.height), 1e-5) << "m: dt matters";
  }
}

}  // namespace
}  // namespace clothbench
