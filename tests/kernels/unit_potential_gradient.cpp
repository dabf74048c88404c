// The potential formulation's analytic gradient against central finite differences of the
// objective, and the numeric (local finite-difference) gradient mode against the analytic one.
#include <gtest/gtest.h>

#include <cmath>

#include "kernel_fixtures.hpp"

namespace clothbench {
namespace {

struct GradientComparison {
  double relative_error = 0.0;  ///< |g_fd - g| / |g| over all free coordinates
  std::size_t coordinates = 0;
};

/// Central differences of Simulation::evaluate().value over every free coordinate.
GradientComparison compare_with_finite_differences(kernels::Simulation& sim) {
  schedulers::OmpStaticDriver driver;
  sim.evaluate(driver);
  const std::vector<double> gradient = sim.state().gradient;
  std::vector<double>& x = sim.state().position;
  const double h = 1e-7;
  double diff = 0.0, norm = 0.0;
  GradientComparison out;
  for (std::int64_t s = 0; s < sim.mesh().slot_count(); ++s) {
    if ((sim.mesh().flags[s] & kernels::kParticlePinned) != 0) {
      for (int k = 0; k < 3; ++k) EXPECT_EQ(gradient[3 * s + k], 0.0) << "pinned particle moved";
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      const std::size_t i = static_cast<std::size_t>(3 * s + k);
      const double keep = x[i];
      x[i] = keep + h;
      const double plus = sim.evaluate(driver, false).value;
      x[i] = keep - h;
      const double minus = sim.evaluate(driver, false).value;
      x[i] = keep;
      const double fd = (plus - minus) / (2.0 * h);
      diff += (fd - gradient[i]) * (fd - gradient[i]);
      norm += gradient[i] * gradient[i];
      ++out.coordinates;
    }
  }
  out.relative_error = std::sqrt(diff / norm);
  return out;
}

TEST(PotentialGradient, MatchesFiniteDifferencesWithoutObstacles) {
  for (unsigned seed : {1u, 2u, 3u}) {
    kernels::Simulation sim(testing::small_cloth(false, false));
    testing::randomise_state(sim, seed);
    const GradientComparison c = compare_with_finite_differences(sim);
    EXPECT_LT(c.relative_error, 1e-6) << "seed " << seed;
    EXPECT_EQ(c.coordinates, 3u * 63u);
  }
}

TEST(PotentialGradient, MatchesFiniteDifferencesWithContactAndPins) {
  for (unsigned seed : {4u, 5u, 6u}) {
    kernels::Simulation sim(testing::small_cloth(true, true));
    testing::randomise_state(sim, seed);
    schedulers::OmpStaticDriver driver;
    sim.evaluate(driver);
    const std::vector<double> support = sim.contact_forces();
    int touching = 0;
    for (double f : support) touching += f > 0.0 ? 1 : 0;
    ASSERT_GT(touching, 0) << "the state must exercise the contact term";
    const GradientComparison c = compare_with_finite_differences(sim);
    EXPECT_LT(c.relative_error, 1e-6) << "seed " << seed;
  }
}

TEST(PotentialGradient, MatchesFiniteDifferencesWithExternalForcesAndAMovedObstacle) {
  for (unsigned seed : {7u, 8u}) {
    kernels::Simulation sim(testing::small_cloth(true, true));
    sim.move_obstacle(0, {0.003, -0.002, 0.001});
    sim.move_obstacle(1, {0.0, 0.004, -0.0005});
    sim.set_external_force(4, 3, {0.002, -0.001, 0.004});
    sim.set_external_force(2, 5, {0.0, 0.0, -0.003});
    sim.set_external_force(0, 0, {0.0, 0.0, 1.0});  // pinned: no effect
    testing::randomise_state(sim, seed);
    schedulers::OmpStaticDriver driver;
    sim.evaluate(driver);
    int touching = 0;
    for (double f : sim.contact_forces()) touching += f > 0.0 ? 1 : 0;
    ASSERT_GT(touching, 0) << "the moved obstacles must still touch the cloth";
    const GradientComparison c = compare_with_finite_differences(sim);
    EXPECT_LT(c.relative_error, 1e-6) << "seed " << seed;
  }
}

TEST(PotentialGradient, ExternalForceEntersAsMinusForceInTheGradient) {
  kernels::Simulation plain(testing::small_cloth(true, true));
  kernels::Simulation pulled(testing::small_cloth(true, true));
  testing::randomise_state(plain, 3);
  testing::randomise_state(pulled, 3);
  const Eigen::Vector3d f(0.01, -0.02, 0.03);
  pulled.set_external_force(4, 3, f);
  schedulers::OmpStaticDriver driver;
  plain.evaluate(driver);
  pulled.evaluate(driver);
  for (std::int64_t s = 0; s < plain.mesh().slot_count(); ++s) {
    const Eigen::Vector3d expected =
        kernels::vec3(plain.state().gradient, s) - (s == plain.mesh().slot(4, 3) ? f : Eigen::Vector3d::Zero());
    EXPECT_LT((kernels::vec3(pulled.state().gradient, s) - expected).norm(), 1e-12) << s;
  }
}

TEST(PotentialGradient, EveryTermOnItsOwn) {
  // Stretch only (no bending stiffness), bending dominated (very soft tension), no gravity.
  for (int variant = 0; variant < 3; ++variant) {
    kernels::SimulationConfig c = testing::small_cloth(true, true);
    if (variant == 0) c.fabric.warp.bending_b = c.fabric.weft.bending_b = 1e-9;
    if (variant == 1) c.fabric.fm_gf_per_cm = 1e-3;
    if (variant == 2) c.time.gravity.setZero();
    kernels::Simulation sim(c);
    testing::randomise_state(sim, 10u + static_cast<unsigned>(variant));
    EXPECT_LT(compare_with_finite_differences(sim).relative_error, 1e-6) << "variant " << variant;
  }
}

TEST(PotentialGradient, NumericModeAgreesWithAnalytic) {
  kernels::SimulationConfig c = testing::small_cloth(true, true);
  kernels::Simulation analytic(c);
  c.solver.gradient = kernels::GradientMode::numeric;
  c.solver.numeric_step = 1e-5;
  kernels::Simulation numeric(c);
  testing::randomise_state(analytic, 21);
  testing::randomise_state(numeric, 21);
  analytic.set_external_force(4, 3, {0.002, -0.001, 0.004});
  numeric.set_external_force(4, 3, {0.002, -0.001, 0.004});
  schedulers::OmpStaticDriver driver;
  const double value_a = analytic.evaluate(driver).value;
  const double value_n = numeric.evaluate(driver).value;
  EXPECT_EQ(value_a, value_n);  // the value is computed the same way in both modes
  double diff = 0.0, norm = 0.0;
  for (std::size_t i = 0; i < analytic.state().gradient.size(); ++i) {
    const double d = analytic.state().gradient[i] - numeric.state().gradient[i];
    diff += d * d;
    norm += analytic.state().gradient[i] * analytic.state().gradient[i];
  }
  EXPECT_LT(std::sqrt(diff / norm), 1e-6);
}

}  // namespace
}  // namespace clothbench
