// `clothbench strip` through the real binary (seconds):
//  - a short strip PASSES and its --json holds one entry per step whose Newton counts add up to
//    the total, the final positions, the settings and the machine context; --trace holds one
//    CSV row per Newton iteration;
//  - --rt-percent 100 reaches the fabric (the settings record it); --hat-levels and
//    --coarse-newton reach the run (settings, and the coarse count in the JSON); so does
//    --inner-stiffness, labelled as not MODEL.md 4B's rule, and refused with --path-mu0;
//  - bad input exits 2 naming the flag: an unknown fabric, a particle count below 3, a
//    coarse factor that does not divide the edges;
//    and a JSON file that cannot be written (its folder is a file) exits 2, leaving that
//    file as it was.
// No timing is asserted.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "tests/harness/clothbench_process.hpp"

namespace {

namespace fs = std::filesystem;
using clothbench_test::quote;
using clothbench_test::run;

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("clothbench-strip-" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string read(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(StripCommand, AShortStripPassesAndWritesItsCounts) {
  const fs::path dir = scratch("pass");
  const auto outcome = run("strip --particles 33 --steps 30 --json " + quote((dir / "s.json").string()) +
                           " --trace " + quote((dir / "t.csv").string()));
  ASSERT_EQ(outcome.exit_code, 0) << outcome.output;
  EXPECT_NE(outcome.output.find("PASSED"), std::string::npos) << outcome.output;
  const auto doc = nlohmann::json::parse(read(dir / "s.json"));
  ASSERT_EQ(doc.at("steps").size(), 30u);
  long sum = 0;
  for (const auto& step : doc.at("steps")) {
    EXPECT_TRUE(step.at("converged").get<bool>());
    sum += step.at("newton").get<long>();
  }
  EXPECT_EQ(sum, doc.at("newton").get<long>());
  EXPECT_GT(sum, 0);
  EXPECT_EQ(doc.at("positions_m").size(), 33u);
  EXPECT_EQ(doc.at("settings").at("particles").get<int>(), 33);
  EXPECT_TRUE(doc.at("passed").get<bool>());
  EXPECT_TRUE(doc.at("machine").is_object());
  // One header line, then one row per Newton iteration.
  std::istringstream trace(read(dir / "t.csv"));
  std::string line;
  long rows = -1;
  while (std::getline(trace, line)) ++rows;
  EXPECT_EQ(rows, sum);
  fs::remove_all(dir);
}

TEST(StripCommand, AFabricOverrideReachesTheRun) {
  const fs::path dir = scratch("override");
  const auto outcome = run("strip --particles 17 --steps 5 --rt-percent 100 --json " +
                           quote((dir / "s.json").string()));
  ASSERT_EQ(outcome.exit_code, 0) << outcome.output;
  const auto doc = nlohmann::json::parse(read(dir / "s.json"));
  EXPECT_EQ(doc.at("settings").at("warp_rt_percent").get<double>(), 100.0);
  fs::remove_all(dir);
}

TEST(StripCommand, CoarseCorrectionsReachTheRun) {
  const fs::path dir = scratch("coarse");
  const auto outcome = run("strip --particles 33 --steps 30 --hat-levels 3 --coarse-newton 2 "
                           "--coarse-factor 4 --json " + quote((dir / "s.json").string()));
  ASSERT_EQ(outcome.exit_code, 0) << outcome.output;
  EXPECT_NE(outcome.output.find("coarse-subspace Newton iterations"), std::string::npos)
      << outcome.output;
  const auto doc = nlohmann::json::parse(read(dir / "s.json"));
  EXPECT_EQ(doc.at("settings").at("hat_levels").get<int>(), 3);
  EXPECT_EQ(doc.at("settings").at("coarse_newton").get<int>(), 2);
  EXPECT_EQ(doc.at("settings").at("coarse_factor").get<int>(), 4);
  long coarse = 0;
  for (const auto& step : doc.at("steps")) coarse += step.at("coarse").get<long>();
  EXPECT_EQ(coarse, doc.at("coarse").get<long>());
  EXPECT_GT(coarse, 0);  // the landing's steps do not converge in one fine iteration
  EXPECT_TRUE(doc.at("passed").get<bool>());
  fs::remove_all(dir);
}

TEST(StripCommand, TheTiltedPlateauReachesTheRunAndIsLabelled) {
  const fs::path dir = scratch("tilt");
  auto outcome = run("strip --particles 33 --steps 30 --inner-stiffness 1e-3 --json " +
                     quote((dir / "s.json").string()));
  ASSERT_EQ(outcome.exit_code, 0) << outcome.output;
  EXPECT_NE(outcome.output.find("not MODEL.md 4B's rule"), std::string::npos) << outcome.output;
  const auto doc = nlohmann::json::parse(read(dir / "s.json"));
  EXPECT_EQ(doc.at("settings").at("inner_stiffness").get<double>(), 1e-3);
  outcome = run("strip --particles 33 --steps 1 --inner-stiffness 1e-3 --path-mu0 0.1");
  EXPECT_EQ(outcome.exit_code, 2) << outcome.output;
  EXPECT_NE(outcome.output.find("--inner-stiffness"), std::string::npos) << outcome.output;
  fs::remove_all(dir);
}

TEST(StripCommand, BadInputExitsTwoNamingTheFlag) {
  auto outcome = run("strip --fabric no-such-cloth --steps 1");
  EXPECT_EQ(outcome.exit_code, 2);
  EXPECT_NE(outcome.output.find("--fabric"), std::string::npos) << outcome.output;
  outcome = run("strip --particles 2");
  EXPECT_EQ(outcome.exit_code, 2);
  EXPECT_NE(outcome.output.find("--particles"), std::string::npos) << outcome.output;
  // A coarse spacing that does not divide the strip's 32 edges, or leaves one coarse edge.
  for (const char* factor : {"5", "32"}) {
    outcome = run(std::string("strip --particles 33 --steps 1 --coarse-newton 1 --coarse-factor ") +
                  factor);
    EXPECT_EQ(outcome.exit_code, 2) << outcome.output;
    EXPECT_NE(outcome.output.find("--coarse-factor"), std::string::npos) << outcome.output;
  }
  // A JSON file under a regular file cannot be written.
  const fs::path dir = scratch("unwritable");
  std::ofstream(dir / "blocker") << "not a directory\n";
  outcome = run("strip --particles 9 --steps 1 --json " + quote((dir / "blocker" / "s.json").string()));
  EXPECT_EQ(outcome.exit_code, 2) << outcome.output;
  EXPECT_EQ(read(dir / "blocker"), "not a directory\n");
  fs::remove_all(dir);
}

}  // namespace
