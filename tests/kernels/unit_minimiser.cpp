// The step minimisers, nonlinear CG and Newton: the objective never increases within a step,
// the step converges, a time budget stops it, and a step above the residual limit is halved.
#include <gtest/gtest.h>
#include <omp.h>

#include <string>
#include <utility>

#include "kernel_fixtures.hpp"

namespace clothbench {
namespace {

constexpr kernels::StepMethod kMethods[] = {kernels::StepMethod::nonlinear_cg,
                                            kernels::StepMethod::newton};

TEST(Minimiser, ObjectiveNeverIncreasesWithinAStep) {
  for (const auto& [method, preconditioner] :
       {std::pair{kMethods[0], true}, std::pair{kMethods[0], false}, std::pair{kMethods[1], true},
        std::pair{kMethods[1], false}}) {
    using kernels::Preconditioner;
    kernels::SimulationConfig c = testing::small_cloth(true, true);
    c.solver.method = method;
    c.solver.record_values = true;
    c.solver.reject_residual = 1e300;  // one attempt per step: this test is about the minimiser
    c.solver.preconditioner = preconditioner ? Preconditioner::block_jacobi : Preconditioner::none;
    c.solver.tolerance = 1e-6;
    c.solver.max_iterations = 300;
    kernels::Simulation sim(c);
    schedulers::OmpStaticDriver driver;
    int iterations = 0;
    for (int step = 0; step < 8; ++step) {
      const kernels::StepReport r = sim.step(driver);
      const std::vector<double>& v = r.minimiser.values;
      ASSERT_EQ(v.size(), static_cast<std::size_t>(r.minimiser.iterations) + 1);
      for (std::size_t k = 1; k < v.size(); ++k) {
        EXPECT_LT(v[k], v[k - 1]) << "step " << r.step << " iteration " << k << " "
                                  << kernels::to_string(method)
                                  << (preconditioner ? " (block Jacobi)" : " (scaled)");
      }
      iterations += r.minimiser.iterations;
    }
    EXPECT_GT(iterations, 0);
  }
}

TEST(Minimiser, ConvergesToTheToleranceOnASmallStep) {
  for (const kernels::StepMethod method : kMethods) {
    kernels::SimulationConfig c = testing::small_cloth(false, true);
    c.solver.method = method;
    c.solver.tolerance = 1e-6;
    c.solver.max_iterations = 2000;
    c.solver.reject_residual = 1e300;
    kernels::Simulation sim(c);
    schedulers::OmpStaticDriver driver;
    for (int step = 0; step < 5; ++step) {
      const kernels::StepReport r = sim.step(driver);
      EXPECT_EQ(r.minimiser.reason, kernels::StopReason::converged)
          << "step " << r.step << " " << kernels::to_string(method);
      EXPECT_LE(kernels::MinimiserReport::rms(r.minimiser.final), 1e-6);
    }
  }
}

// The time budget: a spent budget stops every step's CG at once (accepted, finite, no halving),
// and on 2 threads every thread agrees on the stop (the poll is broadcast; a disagreement
// would hang the region or diverge).
TEST(Minimiser, AnExhaustedTimeBudgetStopsEveryStep) {
  for (const auto& [method, threads] : {std::pair{kMethods[0], 1}, std::pair{kMethods[0], 2},
                                        std::pair{kMethods[1], 1}, std::pair{kMethods[1], 2}}) {
    kernels::SimulationConfig c = testing::small_cloth(true, true);
    c.solver.method = method;
    c.solver.tolerance = 1e-9;
    c.solver.max_iterations = 500;
    c.solver.reject_residual = 1e-3;  // without the budget rule these steps would be halved
    c.solver.time_budget = 1e-9;      // s: used up before the first iteration
    kernels::Simulation sim(c);
    sim.set_planned_steps(4);
    schedulers::OmpStaticDriver driver;
    omp_set_num_threads(threads);
    for (int step = 0; step < 4; ++step) {
      const kernels::StepReport r = sim.step(driver);
      EXPECT_EQ(r.minimiser.reason, kernels::StopReason::time_budget) << "step " << r.step;
      EXPECT_EQ(r.minimiser.iterations, 0);
      EXPECT_EQ(r.rejected, 0);
    }
    EXPECT_TRUE(sim.diagnostics().finite);
  }
}

// A budget larger than the run needs changes nothing: the same steps converge as without it.
TEST(Minimiser, AnAmpleTimeBudgetLeavesTheRunAlone) {
  for (const kernels::StepMethod method : kMethods) {
    kernels::SimulationConfig c = testing::small_cloth(true, true);
    c.solver.method = method;
    c.solver.tolerance = 1e-4;
    c.solver.max_iterations = 60;
    kernels::Simulation plain(c);
    c.solver.time_budget = 3600.0;
    kernels::Simulation budgeted(c);
    budgeted.set_planned_steps(3);
    schedulers::OmpStaticDriver driver;
    for (int step = 0; step < 3; ++step) {
      const kernels::StepReport a = plain.step(driver), b = budgeted.step(driver);
      EXPECT_EQ(a.minimiser.iterations, b.minimiser.iterations);
      EXPECT_EQ(a.minimiser.reason, b.minimiser.reason);
      EXPECT_NE(b.minimiser.reason, kernels::StopReason::time_budget);
    }
    EXPECT_EQ(plain.state().position, budgeted.state().position);
  }
}

}  // namespace
}  // namespace clothbench

namespace clothbench {
namespace {

TEST(StepRejection, AStepAboveTheResidualLimitIsRedoneAsHalfSteps) {
  for (const kernels::StepMethod method :
       {kernels::StepMethod::nonlinear_cg, kernels::StepMethod::newton}) {
    kernels::SimulationConfig c = testing::small_cloth(true, true);
    c.solver.method = method;
    c.solver.max_iterations = 3;  // too few to converge a full step ...
    c.solver.max_newton_iterations = 1;
    c.solver.reject_residual = 1e-3;  // ... so it is rejected and halved
    c.solver.max_step_halvings = 2;
    kernels::Simulation sim(c);
    testing::randomise_state(sim, 7);
    schedulers::OmpStaticDriver driver;
    const kernels::StepReport r = sim.step(driver);
    const std::string what = kernels::to_string(method);
    EXPECT_GT(r.rejected, 0) << what;
    EXPECT_GT(r.sub_steps, 1) << what;
    EXPECT_LE(r.sub_steps, 4) << what;  // at most two halvings
    EXPECT_EQ(sim.config().time.step, c.time.step) << "the configuration is never written";
    EXPECT_TRUE(sim.diagnostics().finite) << what;
  }
}

}  // namespace
}  // namespace clothbench
