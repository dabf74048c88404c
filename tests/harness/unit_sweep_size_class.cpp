// The size classes of `clothbench sweep --class`: each names a shipped scene that loads, the
// classes grow in size in their order (S < W < A < B), A is the paper's own box scene, and the
// class settings yield to what the command line gives.
#include <gtest/gtest.h>

#include <filesystem>
#include <stdexcept>
#include <string>

#include "harness/scene/scene.hpp"
#include "harness/sweep/size_class.hpp"

namespace {

using namespace clothbench::harness;

TEST(SweepSizeClass, EveryClassNamesASceneThatLoadsAndTheyGrowInOrder) {
  const auto classes = size_classes();
  ASSERT_EQ(classes.size(), 4u);
  std::string names;
  std::int64_t previous = 0;
  for (const SizeClass& c : classes) {
    names += c.name;
    const Scene scene = load_scene(scenario_directory() / c.scene, default_presets_file());
    const auto& cloth = scene.simulation.cloth;
    const std::int64_t particles = static_cast<std::int64_t>(cloth.particles_i) * cloth.particles_j;
    EXPECT_GT(particles, previous) << c.name;
    previous = particles;
    EXPECT_GE(c.repeat, 1) << c.name;
    EXPECT_GE(c.warmup_steps, 0) << c.name;
    EXPECT_FALSE(c.what.empty()) << c.name;
  }
  EXPECT_EQ(names, "SWAB");
  EXPECT_EQ(find_size_class("A").scene, "paper/box-1001.toml");
}

TEST(SweepSizeClass, CommandLineSettingsWinAndASceneBesideAClassIsRefused) {
  SweepOptions options;
  options.repeat = 7;
  options.warmup_steps = 5;
  apply_size_class(find_size_class("A"), false, true, false, options);
  EXPECT_EQ(options.repeat, 7);
  EXPECT_EQ(options.warmup_steps, find_size_class("A").warmup_steps);
  EXPECT_EQ(options.scene_file, scenario_directory() / "paper/box-1001.toml");
  EXPECT_EQ(options.size_class, "A");

  SweepOptions defaults;
  apply_size_class(find_size_class("B"), false, false, false, defaults);
  EXPECT_EQ(defaults.repeat, find_size_class("B").repeat);

  SweepOptions both;
  EXPECT_THROW(apply_size_class(find_size_class("S"), true, false, false, both),
               std::invalid_argument);
  EXPECT_THROW((void)find_size_class("s"), std::invalid_argument);
  EXPECT_THROW((void)find_size_class(""), std::invalid_argument);
}

}  // namespace
