// A non-finite value is caught where it appears: the run stops at that step with a message
// naming the element and term, the summary marks it FAILED, and no NaN reaches a result file
// (the JSON holds null where a figure is not finite), and the state at that step is written
// as a diagnostic snapshot, JSON and VTK, by `run` and by every stress cell.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <sstream>
#include <string>

#include "harness/output/vtk_writer.hpp"
#include "harness/run/run_summary.hpp"
#include "harness/scene/scene.hpp"
#include "harness/stress/stress_cell.hpp"
#include "harness/stress/stress_report.hpp"
#include "kernels/simulation.hpp"
#include "schedulers/static_driver.hpp"
#include "tests/harness/clothbench_process.hpp"

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

  // The same state as a surface: the poisoned particle is flagged, every value is finite.
  const harness::SurfaceMesh surface = harness::non_finite_surface(sim);
  ASSERT_EQ(surface.points.size(), static_cast<std::size_t>(sim.mesh().slot_count()));
  ASSERT_FALSE(surface.quads.empty());
  ASSERT_EQ(surface.point_scalars.front().first, "non_finite");
  const std::vector<double>& flag = surface.point_scalars.front().second;
  const auto poisoned = static_cast<std::size_t>(sim.mesh().slot(4, 3));
  EXPECT_EQ(static_cast<int>(flag[poisoned]) & 1, 1) << "position of (4, 3) flagged";
  int flagged = 0;
  for (std::size_t k = 0; k < flag.size(); ++k) {
    if (flag[k] != 0.0) ++flagged;
    // Every flagged position really is non-finite in the state, and no other one is.
    EXPECT_EQ((static_cast<int>(flag[k]) & 1) == 1,
              !kernels::vec3(sim.state().position, static_cast<std::int64_t>(k)).allFinite())
        << "slot " << k;
  }
  EXPECT_GE(flagged, 1);
  std::string vtk;
  ASSERT_NO_THROW(vtk = harness::format_vtk(surface, "snapshot"));
  EXPECT_EQ(vtk.find("nan"), std::string::npos);
  EXPECT_EQ(vtk.find("inf"), std::string::npos);
  EXPECT_NE(vtk.find("SCALARS non_finite double 1"), std::string::npos);
}

TEST(NonFinite, AnEdgeForceAndATripleMomentAreFlaggedAndNullWhereTheyAre) {
  kernels::Simulation sim(small_sheet());
  const kernels::ClothMesh& mesh = sim.mesh();
  const std::int64_t edge_slot = mesh.slot(3, 4), moment_slot = mesh.slot(5, 2),
                     both_slot = mesh.slot(6, 3);
  const std::int64_t edge = kernels::element_id(edge_slot, 1);      // along j
  const std::int64_t moment = kernels::element_id(moment_slot, 0);  // along i
  kernels::ClothState& st = sim.state();
  st.edge_force[edge] = std::numeric_limits<double>::quiet_NaN();
  st.triple_moment[moment] = std::numeric_limits<double>::infinity();
  st.edge_force[kernels::element_id(both_slot, 0)] = -std::numeric_limits<double>::infinity();
  st.triple_moment[kernels::element_id(both_slot, 1)] = std::numeric_limits<double>::quiet_NaN();

  // The surface: 2 = an edge force at this slot, 4 = a triple moment, summed; 0 elsewhere,
  // and the flagged values written as 0 in their fields.
  const harness::SurfaceMesh surface = harness::non_finite_surface(sim);
  auto field = [&](const std::string& name) -> const std::vector<double>& {
    for (const auto& [key, values] : surface.point_scalars) {
      if (key == name) return values;
    }
    ADD_FAILURE() << "no field " << name;
    static const std::vector<double> none;
    return none;
  };
  const std::vector<double>& flag = field("non_finite");
  ASSERT_EQ(flag.size(), static_cast<std::size_t>(mesh.slot_count()));
  for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
    const double expected = s == edge_slot ? 2.0 : s == moment_slot ? 4.0 : s == both_slot ? 6.0 : 0.0;
    EXPECT_EQ(flag[static_cast<std::size_t>(s)], expected) << "slot " << s;
  }
  EXPECT_EQ(field("edge_force_j_N_per_m")[static_cast<std::size_t>(edge_slot)], 0.0);
  EXPECT_EQ(field("triple_moment_i_N")[static_cast<std::size_t>(moment_slot)], 0.0);
  EXPECT_EQ(field("edge_force_i_N_per_m")[static_cast<std::size_t>(both_slot)], 0.0);
  EXPECT_EQ(field("triple_moment_j_N")[static_cast<std::size_t>(both_slot)], 0.0);
  EXPECT_EQ(field("edge_force_i_N_per_m")[static_cast<std::size_t>(edge_slot)],
            st.edge_force[kernels::element_id(edge_slot, 0)])
      << "the finite value beside it is written as it is";

  // The JSON: null exactly at the poisoned entries, numbers everywhere else.
  harness::RunSummary summary;
  summary.non_finite_step = 3;
  summary.non_finite = sim.locate_non_finite();
  const nlohmann::json snapshot = harness::non_finite_snapshot(summary, sim);
  const nlohmann::json& forces = snapshot["edge_force_n_per_m"];
  const nlohmann::json& moments = snapshot["triple_moment_n"];
  ASSERT_EQ(forces.size(), st.edge_force.size());
  ASSERT_EQ(moments.size(), st.triple_moment.size());
  for (std::size_t id = 0; id < forces.size(); ++id) {
    EXPECT_EQ(forces[id].is_null(), !std::isfinite(st.edge_force[id])) << "edge " << id;
    EXPECT_EQ(moments[id].is_null(), !std::isfinite(st.triple_moment[id])) << "triple " << id;
  }
  EXPECT_TRUE(forces[static_cast<std::size_t>(edge)].is_null());
  EXPECT_TRUE(moments[static_cast<std::size_t>(moment)].is_null());
  for (const auto& v : snapshot["position_m"]) EXPECT_TRUE(v.is_number());
  EXPECT_EQ(snapshot["where"], summary.non_finite);
  const std::string text = forces.dump() + moments.dump();
  EXPECT_EQ(text.find("nan"), std::string::npos);
  EXPECT_EQ(text.find("inf"), std::string::npos);
}

TEST(NonFinite, StressCellWritesTheStateAsJsonAndVtk) {
  // A cloth placed at a height that is not a number: the state holds NaN from the start.
  harness::StressCell cell;
  cell.name = "height-unset";
  cell.axis = "start";
  cell.change = "origin z not a number";
  cell.scene.name = "non-finite stress cell";
  cell.scene.file = "non-finite-cell.toml";
  cell.scene.steps = 4;
  cell.scene.simulation = small_sheet();
  cell.scene.simulation.cloth.origin.z() = std::numeric_limits<double>::quiet_NaN();
  const std::filesystem::path dir = clothbench_test::fresh_dir("stress-snapshot");
  schedulers::OmpStaticDriver driver;
  const auto result = harness::run_stress_cell(cell, driver, [] { return true; }, dir);
  ASSERT_TRUE(result.has_value());
  EXPECT_FALSE(result->passed);
  ASSERT_TRUE(result->non_finite.has_value());
  EXPECT_EQ(result->non_finite->step, 1);
  EXPECT_EQ(result->steps_completed, 0);
  ASSERT_EQ(result->snapshot_files.size(), 2U);
  EXPECT_EQ(result->snapshot_files[0], dir / "height-unset-non_finite_snapshot.json");
  EXPECT_EQ(result->snapshot_files[1], dir / "height-unset-non_finite_snapshot.vtk");

  const nlohmann::json snapshot = clothbench_test::read_json(result->snapshot_files[0]);
  EXPECT_EQ(snapshot["step"], 1);
  EXPECT_EQ(snapshot["where"], result->non_finite->text);
  const std::string vtk = clothbench_test::read_text(result->snapshot_files[1]);
  EXPECT_EQ(vtk.rfind("# vtk DataFile Version 3.0\n", 0), 0U);
  EXPECT_NE(vtk.find("state at step 1"), std::string::npos);
  // Past the title line (which quotes the message) no value is NaN.
  const std::string data = vtk.substr(vtk.find("\nASCII\n"));
  EXPECT_EQ(data.find("nan"), std::string::npos) << "no NaN in the VTK file's data";
  // The flag field holds one value per slot, and some of them are set.
  const std::string field = "SCALARS non_finite double 1\nLOOKUP_TABLE default\n";
  const std::size_t at = vtk.find(field);
  ASSERT_NE(at, std::string::npos);
  std::istringstream values(vtk.substr(at + field.size()));
  const std::int64_t slots = kernels::Simulation(cell.scene.simulation).mesh().slot_count();
  int set = 0;
  for (std::int64_t k = 0; k < slots; ++k) {
    double v = -1.0;
    ASSERT_TRUE(values >> v) << "flag " << k;
    ASSERT_TRUE(v >= 0.0 && v <= 7.0) << "flag " << k << " = " << v;
    if (v != 0.0) ++set;
  }
  EXPECT_GT(set, 0);

  // The report names the snapshot's files next to stress.json; without a directory none is
  // written.
  const nlohmann::json c = harness::cell_json(*result);
  EXPECT_EQ(c["non_finite"]["snapshot"],
            nlohmann::json::array({"height-unset-non_finite_snapshot.json",
                                   "height-unset-non_finite_snapshot.vtk"}));
  const auto without = harness::run_stress_cell(cell, driver, [] { return true; });
  ASSERT_TRUE(without.has_value());
  EXPECT_TRUE(without->snapshot_files.empty());
  EXPECT_TRUE(without->non_finite.has_value());
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace clothbench
