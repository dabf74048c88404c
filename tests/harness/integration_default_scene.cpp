// The scene `scripts/run` sweeps (scenarios/box-49-drape.toml) stepped by `clothbench run`
// up to its first AMRC check: it passes verification, prints the AMRC event, records it in
// summary.json and, with gnuplot installed, draws the level-coloured picture (cloth.png).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "tests/harness/clothbench_process.hpp"

namespace {

using clothbench_test::fresh_dir;
using clothbench_test::quote;
using clothbench_test::read_json;
using clothbench_test::run;
using ::testing::HasSubstr;
namespace fs = std::filesystem;

TEST(DefaultScene, ThreeStepsToTheFirstAmrcCheckPassAndRecordTheEvent) {
  const fs::path scene = fs::path(CLOTHBENCH_SOURCE_DIR) / "scenarios" / "box-49-drape.toml";
  const fs::path out = fresh_dir("default-scene");
  // check_every = 3 in the scene: the first AMRC check follows step 3.
  const auto o = run("run " + quote(scene.string()) + " --steps 3 --no-vtk --out " +
                         quote(out.string()),
                     "OMP_NUM_THREADS=2");
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_THAT(o.output, HasSubstr("\nVerification: PASSED"));
  EXPECT_THAT(o.output, HasSubstr("AMRC after step    3: "));
  const fs::path dir = out / "box-49-drape";
  const nlohmann::json summary = read_json(dir / "summary.json");
  EXPECT_EQ(summary["verification"]["passed"], true) << summary["verification"].dump();
  ASSERT_TRUE(summary.contains("amrc"));
  const nlohmann::json& events = summary["amrc"]["events"];
  ASSERT_EQ(events.size(), 1u) << summary["amrc"].dump();
  EXPECT_EQ(events[0]["step"], 3);
  EXPECT_GT(events[0]["coarsened"].get<int>(), 0) << "the flat top of the box coarsens at once";
  EXPECT_LT(events[0]["particles"].get<int>(), 49 * 49);
  if (std::system("command -v gnuplot >/dev/null 2>&1") == 0) {
    EXPECT_GT(fs::file_size(dir / "cloth.png"), 0u) << o.output;
  }
  fs::remove_all(out);
}

}  // namespace
