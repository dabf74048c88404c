// A non-finite value is caught where it appears: the run stops at that step with a message
// naming the element and term, the summary marks it FAILED, and no NaN reaches a result file
// (the JSON holds null where a figure is not finite, plus a snapshot of the state).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "harness/run/run_summary.hpp"
#include "harness/scene/scene.hpp"
#include "kernels/simulation.hpp"
#include "schedulers/static_driver.hpp"

namespace clothbench {
namespace {

kernels::SimulationConfig small_sheet() {
  kernels::SimulationConfig c;
  c.cloth.particles_i = 9;
  c.cloth.particles_j = 7;
  c.cloth.block_size = 4;
  c.cloth.size_i = c.cloth.size_j = 0.2;
  return c;
}

TEST(NonFinite, LocatesTheFirstBadValueByElementAndTerm) {
  kernels::Simulation sim(small_sheet());
  EXPECT_EQ(sim.locate_non_finite(), "");
  const kernels::ClothMesh& mesh = sim.mesh();
  sim.state().edge_force[kernels::element_id(mesh.slot(3, 4), 1)] =
      std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(sim.locate_non_finite(), "tension of edge (3, 4)->(3, 5) along j = nan");
  sim.state().position[3 * mesh.slot(2, 2) + 2] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(sim.locate_non_finite(), "position of particle (2, 2) component z = inf");
}

TEST(NonFinite, RunStopsAndNoNanReachesTheResults) {
  harness::Scene scene;
  scene.name = "non-finite test";
  scene.file = "non-finite-test.toml";
  scene.steps = 5;
  scene.simulation = small_sheet();
  kernels::Simulation sim(scene.simulation);
  // An inertial target that is NaN poisons the first step's iterate at particle (4, 3).
  sim.state().target[3 * sim.mesh().slot(4, 3)] = std::numeric_limits<double>::quiet_NaN();
  schedulers::OmpStaticDriver driver;
  const harness::RunSummary summary = harness::simulate(sim, driver, scene.steps, true);
  EXPECT_FALSE(summary.verification.passed);
  EXPECT_EQ(summary.non_finite_step, 1);
  EXPECT_NE(summary.non_finite.find("(4, 3)"), std::string::npos) << summary.non_finite;
  EXPECT_TRUE(summary.steps.empty()) << "the failing step's figures go to no table";
  nlohmann::json doc;
  ASSERT_NO_THROW(doc = harness::summary_json(summary, scene, "static"));
  EXPECT_EQ(doc["verification"]["passed"], false);
  EXPECT_EQ(doc["non_finite"]["step"], 1);
  const std::string text = doc.dump();
  EXPECT_EQ(text.find("NaN"), std::string::npos);
  EXPECT_EQ(text.find("nan,"), std::string::npos);
  const nlohmann::json snapshot = harness::non_finite_snapshot(summary, sim);
  EXPECT_EQ(snapshot["where"], summary.non_finite);
  bool has_null = false;
  for (const auto& v : snapshot["position_m"]) has_null = has_null || v.is_null();
  EXPECT_TRUE(has_null);
}

}  // namespace
}  // namespace clothbench
