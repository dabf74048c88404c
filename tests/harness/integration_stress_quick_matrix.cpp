// The quick stress matrix (`clothbench stress --size quick`), every cell run in-process on one
// thread, in the default test run (label integration; the full-size cells are in
// slow_stress.cpp). Every cell must pass; the two cells that meet a documented limit of the
// model (kernels/MODEL-NOTES.md, "Stress matrix": the interpolated surface between particles
// cuts a curved obstacle) must fail on that limit alone, so that any other failure in them is
// caught too; and the lists here must name every cell of the matrix, so a new cell cannot be
// left out. About 40 s of CPU in a Release build (measured: 41 s wall with ctest -j2 at nice 15,
// load 3.6), half of it in stiff-x10+dt-0.1, then dt-0.1 and long (many halved sub-steps, 200
// steps). The ASan + UBSan Debug build is 10 to 25 times slower (gravity-x50 86 s, mesh-65 65 s
// under load), so sanitizer builds skip those five cells, which the Release builds of CI run;
// they still run every fabric cell, three time steps, mesh-33, both AMRC cells, both starts and
// the two combination cells (gravity through soft-x10+gravity-x50); only the length axis (long)
// is left to the Release builds.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <set>
#include <string>
#include <string_view>

#include "tests/harness/sanitizer_build.hpp"
#include "tests/harness/stress_cell_checks.hpp"

namespace clothbench {
namespace {

using harness::StressSize;
using stress_test::Named;

using clothbench_test::kSanitized;

/// Cells that take most of the matrix's time; skipped in sanitizer builds only.
bool heavy(std::string_view name) {
  return name == "stiff-x10+dt-0.1" || name == "dt-0.1" || name == "long" ||
         name == "gravity-x50" || name == "mesh-65";
}

const Named kPassing[] = {{StressSize::quick, "base"},
                          {StressSize::quick, "fabric-wool-suiting"},
                          {StressSize::quick, "fabric-silk"},
                          {StressSize::quick, "fabric-polyester"},
                          {StressSize::quick, "fabric-denim"},
                          {StressSize::quick, "fabric-stiff-x10"},
                          {StressSize::quick, "fabric-soft-x10"},
                          {StressSize::quick, "dt-1e-4"},
                          {StressSize::quick, "dt-1e-3"},
                          {StressSize::quick, "dt-0.01"},
                          {StressSize::quick, "dt-0.1"},
                          {StressSize::quick, "gravity-x50"},
                          {StressSize::quick, "mesh-33"},
                          {StressSize::quick, "mesh-65"},
                          {StressSize::quick, "amrc-normal"},
                          {StressSize::quick, "amrc-thrashing"},
                          {StressSize::quick, "long"},
                          {StressSize::quick, "crumpled"},
                          {StressSize::quick, "stretched-20"},
                          {StressSize::quick, "stiff-x10+dt-0.1"}};

const Named kAtTheSurfaceLimit[] = {{StressSize::quick, "soft-x10+gravity-x50"},
                                    {StressSize::quick, "amrc-thrashing+crumpled"}};

TEST(QuickStressMatrix, EveryCellIsTestedHere) {
  const harness::Scene base =
      harness::load_scene(harness::default_stress_base_scene(), harness::default_presets_file());
  std::set<std::string> matrix, here;
  for (const harness::StressCell& c :
       harness::stress_matrix(base, StressSize::quick, harness::default_presets_file())) {
    matrix.insert(c.name);
  }
  for (const Named& n : kPassing) here.insert(n.name);
  for (const Named& n : kAtTheSurfaceLimit) here.insert(n.name);
  EXPECT_EQ(here, matrix);
}

class QuickCellPasses : public testing::TestWithParam<Named> {};

TEST_P(QuickCellPasses, FiniteExactOutsideAndBounded) {
  if (kSanitized && heavy(GetParam().name)) {
    GTEST_SKIP() << "sanitizer build: heavy cell, run by the Release builds";
  }
  const harness::StressCellResult r =
      stress_test::run(stress_test::cell_of(GetParam().size, GetParam().name));
  stress_test::expect_passed(r);
  if (r.name.find("thrashing") != std::string::npos) {
    EXPECT_GT(r.amrc_refined, 0) << "thrashing thresholds must split cells";
    EXPECT_GT(r.amrc_coarsened, 0) << "thrashing thresholds must merge cells";
  }
}

INSTANTIATE_TEST_SUITE_P(Quick, QuickCellPasses, testing::ValuesIn(kPassing),
                         stress_test::test_name);

// The quick cells that meet the limits of the model: only the interpolated surface goes
// deeper than the contact distance (contact acts on particles; the bilinear surface between
// particles far apart cuts a curved obstacle). Everything else must hold.
class QuickCellMeetsSurfaceLimit : public testing::TestWithParam<Named> {};

TEST_P(QuickCellMeetsSurfaceLimit, OnlyTheInterpolatedSurfacePenetrates) {
  const harness::StressCellResult r =
      stress_test::run(stress_test::cell_of(GetParam().size, GetParam().name));
  EXPECT_FALSE(r.passed);
  ASSERT_EQ(r.failures.size(), 1u) << stress_test::failures(r);
  EXPECT_THAT(r.failures.front(), testing::HasSubstr("the interpolated surface went"));
  EXPECT_GT(r.max_surface_penetration, r.contact_distance);
  EXPECT_LT(r.max_surface_penetration, 2 * r.contact_distance) << "a sag, not a fall-through";
  EXPECT_EQ(r.steps_completed, r.steps_planned);
  EXPECT_LT(r.max_particle_penetration, r.contact_distance);
  EXPECT_LE(r.mass_drift, harness::kMassTolerance);
}

INSTANTIATE_TEST_SUITE_P(Quick, QuickCellMeetsSurfaceLimit, testing::ValuesIn(kAtTheSurfaceLimit),
                         stress_test::test_name);

}  // namespace
}  // namespace clothbench
