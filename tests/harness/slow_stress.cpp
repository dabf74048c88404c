// Full-size stress cells run in-process (label slow: minutes, not in the default test run;
// the quick matrix is integration_stress_quick_matrix.cpp): a set of full-size cells must pass,
// and the full-size stretched start may fail only on the cost bound (kernels/MODEL-NOTES.md,
// "Stress matrix"), so that any other failure in it is caught too.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "tests/harness/stress_cell_checks.hpp"

namespace clothbench {
namespace {

using harness::StressCellResult;
using harness::StressSize;
using stress_test::cell_of;
using stress_test::expect_passed;
using stress_test::failures;
using stress_test::Named;
using stress_test::run;

class StressCellPasses : public testing::TestWithParam<Named> {};

TEST_P(StressCellPasses, FiniteExactOutsideAndBounded) {
  const StressCellResult r = run(cell_of(GetParam().size, GetParam().name));
  expect_passed(r);
  if (r.name.find("thrashing") != std::string::npos) {
    EXPECT_GT(r.amrc_refined, 0) << "thrashing thresholds must split cells";
    EXPECT_GT(r.amrc_coarsened, 0) << "thrashing thresholds must merge cells";
  }
}

INSTANTIATE_TEST_SUITE_P(Full, StressCellPasses,
                         testing::Values(Named{StressSize::full, "base"},
                                         Named{StressSize::full, "fabric-soft-x10"},
                                         Named{StressSize::full, "dt-1e-4"},
                                         Named{StressSize::full, "dt-1e-3"},
                                         Named{StressSize::full, "long"}),
                         stress_test::test_name);

// The full-size start stretched by 20 %: the snap-back collapses edges to zero length (no
// compression resistance) and the kernel accepts steps once their halvings run out. Whether
// the minimiser then escapes the collapsed state depends on rounding (kernels/MODEL-NOTES.md,
// "Stress matrix"): the cell may pass, or fail on the cost bound and on the verifier's strain
// bound (an edge stretched beyond strain 1 as the snap-back overshoots: 2.42 on 2026-11-25) -
// and on nothing else. The state stays finite, the mass exact and the particles outside the
// sphere either way.
TEST(StressCellCollapses, FullStretchedStartCollapsesAndStaysFinite) {
  const StressCellResult r = run(cell_of(StressSize::full, "stretched-20"));
  EXPECT_LT(r.min_strain, -0.99) << "an edge of (almost) zero length";
  EXPECT_GT(r.rejected_steps, 0);
  EXPECT_FALSE(r.non_finite.has_value());
  EXPECT_EQ(r.steps_completed, r.steps_planned);
  EXPECT_LE(r.mass_drift, harness::kMassTolerance);
  EXPECT_LT(r.max_particle_penetration, r.contact_distance);
  EXPECT_LT(r.max_surface_penetration, r.contact_distance);
  EXPECT_FALSE(r.cost_trend.growing);
  for (const std::string& failure : r.failures) {
    EXPECT_THAT(failure, testing::AnyOf(testing::HasSubstr("the step cost left its bound"),
                                        testing::HasSubstr("(more than 1): the state has blown up")))
        << failures(r);
  }
}

}  // namespace
}  // namespace clothbench
