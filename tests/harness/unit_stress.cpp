// The pieces of `clothbench stress` that need no long run: the trend that decides "grows
// without bound", the split of the kernel's non-finite sentence, --only patterns, the cells
// the matrix builds from the base scene, and the records (no NaN in JSON, tables, schema).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include "harness/scene/scene.hpp"
#include "harness/stress/stress_cell.hpp"
#include "harness/stress/stress_matrix.hpp"
#include "harness/stress/stress_metrics.hpp"
#include "harness/stress/stress_options.hpp"
#include "harness/stress/stress_report.hpp"
#include "harness/sweep/sweep_document.hpp"
#include "kernels/simulation.hpp"

namespace clothbench {
namespace {

using harness::StressCell;
using harness::StressSize;
using testing::HasSubstr;

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

TEST(StressTrend, NeedsFourStepsAndSplitsIntoEvenQuarters) {
  EXPECT_FALSE(harness::trend_of({1, 2, 3}, 0.0).assessed);
  const harness::Trend t = harness::trend_of({1, 2, 3, 4, 5, 6, 7}, 0.0);
  ASSERT_TRUE(t.assessed);
  // Quarters of 7 values: [0, 1), [1, 3), [3, 5), [5, 7).
  EXPECT_DOUBLE_EQ(t.quarter_mean[0], 1.0);
  EXPECT_DOUBLE_EQ(t.quarter_mean[1], 2.5);
  EXPECT_DOUBLE_EQ(t.quarter_mean[2], 4.5);
  EXPECT_DOUBLE_EQ(t.quarter_mean[3], 6.5);
  ASSERT_TRUE(t.ratio.has_value());
  EXPECT_DOUBLE_EQ(*t.ratio, 6.5);
  EXPECT_FALSE(t.growing) << "6.5x is below the growth factor";
}

TEST(StressTrend, GrowthAboveTheFloorThatKeepsRisingIsUnbounded) {
  std::vector<double> rising;
  for (int k = 0; k < 40; ++k) rising.push_back(0.01 * std::pow(1.2, k));
  EXPECT_TRUE(harness::trend_of(rising, 0.01).growing);
  // The same growth below a floor it never leaves is bounded.
  EXPECT_FALSE(harness::trend_of(rising, 1e3).growing);
  // Up and back down again: not growing at the end.
  std::vector<double> spike(40, 0.01);
  for (int k = 20; k < 30; ++k) spike[k] = 100.0;
  EXPECT_FALSE(harness::trend_of(spike, 0.01).growing);
  // A start at zero has no ratio, and still grows when the end is far above the floor.
  std::vector<double> from_zero(8, 0.0);
  for (int k = 4; k < 8; ++k) from_zero[k] = 1.0 * k;
  const harness::Trend z = harness::trend_of(from_zero, 0.01);
  EXPECT_FALSE(z.ratio.has_value());
  EXPECT_TRUE(z.growing);
}

TEST(StressNonFinite, SplitsEveryKindOfTheKernelsSentence) {
  kernels::SimulationConfig c;
  c.cloth.particles_i = 9;
  c.cloth.particles_j = 7;
  c.cloth.block_size = 4;
  c.cloth.size_i = c.cloth.size_j = 0.2;
  kernels::Simulation sim(c);
  const kernels::ClothMesh& mesh = sim.mesh();
  kernels::ClothState& st = sim.state();

  st.triple_moment[kernels::element_id(mesh.slot(2, 3), 0)] =
      -std::numeric_limits<double>::infinity();
  harness::NonFiniteValue v = harness::parse_non_finite(7, sim.locate_non_finite());
  EXPECT_EQ(v.step, 7);
  EXPECT_EQ(v.element, "triple");
  EXPECT_EQ(v.index, "(2, 3)");
  EXPECT_EQ(v.term, "bending moment along i");
  EXPECT_EQ(v.value, "-inf");

  st.triple_moment[kernels::element_id(mesh.slot(2, 3), 0)] = 0.0;
  st.edge_force[kernels::element_id(mesh.slot(3, 4), 1)] = kNan;
  v = harness::parse_non_finite(2, sim.locate_non_finite());
  EXPECT_EQ(v.element, "edge");
  EXPECT_EQ(v.index, "(3, 4)->(3, 5)");
  EXPECT_EQ(v.term, "tension along j");
  EXPECT_EQ(v.value, "nan");

  st.position[3 * mesh.slot(8, 6) + 1] = kNan;
  v = harness::parse_non_finite(1, sim.locate_non_finite());
  EXPECT_EQ(v.element, "particle");
  EXPECT_EQ(v.index, "(8, 6)");
  EXPECT_EQ(v.term, "position y");
  EXPECT_EQ(v.text, "position of particle (8, 6) component y = nan");

  v = harness::parse_non_finite(4, "the step's cost");
  EXPECT_EQ(v.element, "step");
  EXPECT_EQ(v.index, "");
  EXPECT_EQ(v.term, "cost");
}

TEST(StressOptions, OnlyTakesCommaSeparatedGlobs) {
  EXPECT_TRUE(harness::cell_selected("dt-0.1", ""));
  EXPECT_TRUE(harness::cell_selected("dt-0.1", "dt-*"));
  EXPECT_TRUE(harness::cell_selected("dt-0.1", "base,dt-0.1"));
  EXPECT_FALSE(harness::cell_selected("stiff-x10+dt-0.1", "dt-*"));
  EXPECT_TRUE(harness::cell_selected("stiff-x10+dt-0.1", "*dt-0.1"));
  EXPECT_FALSE(harness::cell_selected("base", "mesh-?5"));
  EXPECT_THROW((void)harness::cell_selected("base", "base,,dt-*"), std::invalid_argument);
  EXPECT_EQ(harness::parse_stress_size("full"), StressSize::full);
  EXPECT_THROW((void)harness::parse_stress_size("medium"), std::invalid_argument);
}

class StressMatrix : public ::testing::Test {
 protected:
  void SetUp() override {
    base_ =
        harness::load_scene(harness::default_stress_base_scene(), harness::default_presets_file());
    quick_ = harness::stress_matrix(base_, StressSize::quick, harness::default_presets_file());
    full_ = harness::stress_matrix(base_, StressSize::full, harness::default_presets_file());
  }
  const StressCell& cell(const std::vector<StressCell>& cells, const std::string& name) {
    for (const StressCell& c : cells) {
      if (c.name == name) return c;
    }
    ADD_FAILURE() << "no cell " << name;
    return cells.front();
  }
  harness::Scene base_;
  std::vector<StressCell> quick_, full_;
};

TEST_F(StressMatrix, NamesAreUniqueAndQuickIsASmallerFull) {
  std::set<std::string> names, quick_names;
  for (const StressCell& c : full_) EXPECT_TRUE(names.insert(c.name).second) << c.name;
  for (const StressCell& c : quick_) {
    EXPECT_TRUE(quick_names.insert(c.name).second) << c.name;
    // mesh-33 is the quick size's step up; in the full size it is the base mesh.
    EXPECT_EQ(names.count(c.name), c.name == "mesh-33" ? 0u : 1u) << c.name;
  }
  EXPECT_LT(quick_.size(), full_.size());
  EXPECT_EQ(cell(full_, "base").scene.simulation.cloth.particles_i,
            base_.simulation.cloth.particles_i);
  EXPECT_EQ(cell(quick_, "base").scene.simulation.cloth.particles_i, harness::kQuickParticles);
  EXPECT_EQ(cell(quick_, "mesh-65").scene.simulation.cloth.particles_j, 65);
  for (const char* name : {"mesh-129", "mesh-257", "mesh-513"}) {
    EXPECT_EQ(cell(full_, name).scene.simulation.cloth.particles_i, std::stoi(name + 5));
  }
  EXPECT_EQ(cell(full_, "long").scene.steps, 10'000);
  EXPECT_EQ(cell(full_, "long").scene.simulation.cloth.particles_i, harness::kQuickParticles);
  EXPECT_LT(cell(quick_, "long").scene.steps, 10'000);
  for (const StressCell& c : quick_) {
    EXPECT_LE(c.scene.simulation.cloth.particles_i, 65) << c.name << ": quick meshes are small";
    EXPECT_LE(c.scene.steps, cell(full_, c.name == "mesh-33" ? "base" : c.name).scene.steps)
        << c.name;
  }
}

TEST_F(StressMatrix, EachCellChangesWhatItNames) {
  const kernels::SimulationConfig& b = base_.simulation;
  const auto& base = cell(full_, "base").scene.simulation;
  EXPECT_EQ(base.time.step, b.time.step);
  EXPECT_EQ(base.cloth.particles_i, b.cloth.particles_i);
  EXPECT_FALSE(base.amrc.enabled);

  const auto& stiff = cell(full_, "fabric-stiff-x10").scene.simulation.fabric;
  EXPECT_DOUBLE_EQ(stiff.warp.emt_percent, b.fabric.warp.emt_percent / 10);
  EXPECT_DOUBLE_EQ(stiff.weft.bending_b, b.fabric.weft.bending_b * 10);
  const auto& soft = cell(full_, "fabric-soft-x10").scene.simulation.fabric;
  EXPECT_DOUBLE_EQ(soft.weft.emt_percent, b.fabric.weft.emt_percent * 10);
  EXPECT_DOUBLE_EQ(soft.warp.bending_2hb, b.fabric.warp.bending_2hb / 10);
  EXPECT_EQ(cell(full_, "fabric-denim").scene.simulation.fabric_name, "denim");

  EXPECT_DOUBLE_EQ(cell(full_, "dt-1e-4").scene.simulation.time.step, 1e-4);
  EXPECT_DOUBLE_EQ(cell(full_, "dt-0.1").scene.simulation.time.step, 0.1);
  EXPECT_DOUBLE_EQ(cell(full_, "gravity-x50").scene.simulation.time.gravity.z(),
                   50 * b.time.gravity.z());

  const auto& thrash = cell(full_, "amrc-thrashing").scene.simulation.amrc;
  EXPECT_TRUE(thrash.enabled);
  EXPECT_EQ(thrash.check_every, 1);
  EXPECT_LT(thrash.refine_threshold, 2 * thrash.coarsen_threshold) << "closer than a factor 2";
  EXPECT_TRUE(cell(full_, "amrc-normal").scene.simulation.amrc.enabled);

  // Stretched about the centre: the sheet's middle stays over the obstacle.
  const auto& stretched = cell(full_, "stretched-20").scene.simulation.cloth;
  EXPECT_DOUBLE_EQ(stretched.initial_stretch, 0.2);
  const Eigen::Vector3d centre =
      stretched.origin +
      1.2 * 0.5 * (stretched.size_i * stretched.axis_i + stretched.size_j * stretched.axis_j);
  const Eigen::Vector3d base_centre =
      b.cloth.origin + 0.5 * (b.cloth.size_i * b.cloth.axis_i + b.cloth.size_j * b.cloth.axis_j);
  EXPECT_LT((centre - base_centre).norm(), 1e-12);

  // Crumpled by half a spacing and lifted by as much (the loader's overlap check agrees).
  const auto& crumpled = cell(full_, "amrc-thrashing+crumpled").scene.simulation;
  EXPECT_TRUE(crumpled.amrc.enabled);
  EXPECT_EQ(crumpled.amrc.check_every, 1);
  EXPECT_LT(crumpled.amrc.refine_threshold, 2 * crumpled.amrc.coarsen_threshold);
  EXPECT_DOUBLE_EQ(crumpled.cloth.initial_crumple,
                   0.5 * b.cloth.size_i / (b.cloth.particles_i - 1));
  EXPECT_DOUBLE_EQ(crumpled.cloth.origin.z(), b.cloth.origin.z() + crumpled.cloth.initial_crumple);

  const auto& combo = cell(full_, "stiff-x10+dt-0.1").scene.simulation;
  EXPECT_DOUBLE_EQ(combo.time.step, 0.1);
  EXPECT_DOUBLE_EQ(combo.fabric.warp.emt_percent, b.fabric.warp.emt_percent / 10);
}

TEST_F(StressMatrix, ABaseWithoutObstacleIsRefused) {
  harness::Scene bare = base_;
  bare.simulation.obstacles.clear();
  EXPECT_THROW(
      (void)harness::stress_matrix(bare, StressSize::quick, harness::default_presets_file()),
      std::invalid_argument);
}

TEST(StressVerdict, EachCriterionFailsTheCellOnItsOwn) {
  harness::StressCellResult sound;
  sound.contact_distance = 0.002;
  sound.cost_bound = 0.01;
  sound.cost_trend = harness::trend_of({1e-4, 1e-4, 1e-4, 1e-4}, sound.cost_bound);
  harness::judge_stress_cell(sound);
  EXPECT_TRUE(sound.passed);
  EXPECT_TRUE(sound.failures.empty());

  auto fails_with = [&](auto&& spoil, const std::string& message) {
    harness::StressCellResult r = sound;
    spoil(r);
    harness::judge_stress_cell(r);
    EXPECT_FALSE(r.passed) << message;
    ASSERT_EQ(r.failures.size(), 1u) << message;
    EXPECT_THAT(r.failures.front(), HasSubstr(message));
  };
  fails_with([](auto& r) { r.non_finite = harness::parse_non_finite(3, "the step's cost"); },
             "step 3: non-finite value: the step's cost");
  fails_with([](auto& r) { r.mass_drift = 2e-12; }, "mass drift 2e-12");
  fails_with([](auto& r) { r.mass_drift = kNan; }, "mass drift nan");
  fails_with([](auto& r) { r.max_particle_penetration = 1e-6; },
             "a particle is 1e-06 m inside an obstacle");
  fails_with([](auto& r) { r.max_surface_penetration = 0.0021; }, "the interpolated surface");
  fails_with([](auto& r) { r.max_ghost_offset = 1e-9; }, "crack");
  // Growing tenfold and more from the rejection level, and still rising.
  fails_with([](auto& r) { r.cost_trend = harness::trend_of({0.01, 0.02, 0.05, 0.2}, 0.01); },
             "grows without bound");
  // Falling, but the last quarter stays far above the rejection level: accepted only because
  // the halvings ran out (a sheet collapsed by a snap-back did this).
  fails_with([](auto& r) { r.cost_trend = harness::trend_of({1e12, 4e6, 8e6, 2e7}, 0.01); },
             "the step cost left its bound");
}

harness::StressCellResult sample_result(bool passed) {
  harness::StressCellResult r;
  r.name = "dt-0.1";
  r.axis = "time step";
  r.change = "dt = 0.1 s, gravity x50";  // a comma: quoted in CSV
  r.particles_i = r.particles_j = 33;
  r.time_step = 0.1;
  r.contact_distance = 0.002;
  r.steps_planned = 6;
  r.steps_completed = 3;
  r.non_finite = harness::parse_non_finite(4, "tension of edge (3, 4)->(3, 5) along j = nan");
  r.max_strain = kNan;  // as a diagnostics figure would be on a non-finite state
  r.min_strain = -0.25;  // edges may shorten (compression is shown, not judged)
  r.max_surface_penetration = 0.001;
  r.passed = passed;
  if (!passed)
    r.failures = {"step 4: non-finite value: tension of edge (3, 4)->(3, 5) along j = nan"};
  return r;
}

nlohmann::json sample_document(const std::vector<harness::StressCellResult>& results) {
  nlohmann::json d = {
      {"schema", "clothbench.stress"},
      {"schema_version", harness::kStressSchemaVersion},
      {"created_utc", "2024-01-01T00:00:00Z"},
      {"updated_utc", "2024-01-01T00:00:00Z"},
      {"complete", true},
      {"settings",
       {{"size", "quick"},
        {"scheduler", "static@blocks"},
        {"threads", 1},
        {"oversubscribed", false}}},
      {"base_scene", {{"name", "b"}, {"file", "b.toml"}, {"hash", "0123456789abcdef"}}},
      {"machine", nlohmann::json::object()},
      {"criteria", nlohmann::json::object()},
      {"cells", nlohmann::json::array()}};
  int passed = 0;
  for (const auto& r : results) {
    d["cells"].push_back(harness::cell_json(r));
    passed += r.passed ? 1 : 0;
  }
  const int n = static_cast<int>(results.size());
  d["passed"] = passed == n;
  d["summary"] = {{"planned", n}, {"finished", n}, {"passed", passed}, {"failed", n - passed}};
  return d;
}

TEST(StressReport, NoNanReachesTheRecordsAndTheTablesShowEveryCell) {
  const nlohmann::json d = sample_document({sample_result(false), sample_result(true)});
  EXPECT_NO_THROW(harness::check_finite(d, "stress"));
  const nlohmann::json& c = d["cells"][0];
  EXPECT_TRUE(c["max_strain"].is_null());
  EXPECT_EQ(c["non_finite"]["step"], 4);
  EXPECT_EQ(c["non_finite"]["element"], "edge");
  EXPECT_EQ(c["non_finite"]["term"], "tension along j");
  EXPECT_TRUE(c["cost_trend"]["last_to_first"].is_null()) << "3 steps are too few for a trend";
  EXPECT_TRUE(harness::validate_stress_document(d).empty())
      << harness::validate_stress_document(d).front();

  const std::string md = harness::stress_markdown(d);
  EXPECT_THAT(md, HasSubstr("| cell | change | particles | steps | first non-finite |"));
  EXPECT_THAT(md, HasSubstr("| dt-0.1 | dt = 0.1 s, gravity x50 | 33 x 33 | 3 / 6 | step 4: "
                            "tension along j of edge (3, 4)->(3, 5) = nan | -0.2500 / - | 0.000 / 1.000 |"));
  EXPECT_THAT(md, HasSubstr("| FAILED |"));
  EXPECT_THAT(md, HasSubstr("Result: FAILED (1 of 2 cells passed)"));
  EXPECT_THAT(md, HasSubstr("- dt-0.1: step 4: non-finite value"));
  EXPECT_THAT(md, testing::Not(HasSubstr("| nan")));  // a figure is "-" when not finite

  // Written before the first cell finished: no verdict yet.
  nlohmann::json started = sample_document({});
  started["complete"] = false;
  started["summary"]["planned"] = 3;
  EXPECT_THAT(harness::stress_markdown(started),
              HasSubstr("Result: NONE FINISHED YET (0 of 0 cells passed; 0 of 3 cells finished)"));

  const std::string csv = harness::stress_csv(d);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 3);
  EXPECT_THAT(csv, HasSubstr("\"dt = 0.1 s, gravity x50\""));
  EXPECT_THAT(csv, HasSubstr(",4,edge,\"(3, 4)->(3, 5)\",tension along j,nan,,"));

  nlohmann::json broken = d;
  broken["cells"][1].erase("passed");
  broken["cells"][0]["steps"]["completed"] = "three";
  const auto problems = harness::validate_stress_document(broken);
  ASSERT_EQ(problems.size(), 2u);
  EXPECT_EQ(problems[0], "stress.cells[0].steps.completed: wrong type (string)");
  EXPECT_EQ(problems[1], "stress.cells[1].passed: missing");

  // A cell's memory block is checked when present; documents from before it have none.
  nlohmann::json older = d;
  older["cells"][0].erase("memory");
  EXPECT_TRUE(harness::validate_stress_document(older).empty());
  nlohmann::json bad_memory = d;
  bad_memory["cells"][1]["memory"]["peak_resident_bytes"] = "lots";
  bad_memory["cells"][0]["memory"] = 5;
  const auto memory_problems = harness::validate_stress_document(bad_memory);
  ASSERT_EQ(memory_problems.size(), 2u);
  EXPECT_EQ(memory_problems[0], "stress.cells[0].memory: wrong type (number)");
  EXPECT_EQ(memory_problems[1], "stress.cells[1].memory.peak_resident_bytes: wrong type (string)");
}

}  // namespace
}  // namespace clothbench
