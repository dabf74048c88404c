// The scheduler spec grammar: canonical names, defaults, presets, and clear errors.
#include <string>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "schedulers/registry.hpp"
#include "schedulers/static_driver.hpp"

namespace clothbench::schedulers {
namespace {

using testing::HasSubstr;

std::string canonical(const std::string& spec) { return parse_scheduler_spec(spec).canonical(); }

TEST(SchedulerNames, DefaultsAreFilledIn) {
  EXPECT_EQ(canonical("static"), "static@blocks");
  EXPECT_EQ(canonical("static:4"), "static:4@blocks");
  EXPECT_EQ(canonical("dynamic"), "dynamic:1@blocks");
  EXPECT_EQ(canonical("guided"), "guided:1@blocks");
  EXPECT_EQ(canonical("runtime"), "runtime@blocks");
  EXPECT_EQ(canonical("taskloop"), "taskloop@blocks");
  EXPECT_EQ(canonical("taskloop:8"), "taskloop:8@blocks");
  EXPECT_EQ(canonical("fac2"), "fac2:1@blocks");
  EXPECT_EQ(canonical("tss"), "tss:1@blocks");
  EXPECT_EQ(canonical("gss:3"), "gss:3@blocks");
  EXPECT_EQ(canonical("active-lists"), "active-lists@active");
}

TEST(SchedulerNames, SpacesAndModifiers) {
  EXPECT_EQ(canonical("guided:1@blocks"), "guided:1@blocks");
  EXPECT_EQ(canonical("static@active"), "static@active");
  EXPECT_EQ(canonical("dynamic:64@active"), "dynamic:64@active");
  EXPECT_EQ(canonical("active-lists@blocks"), "active-lists@blocks");
  EXPECT_EQ(canonical("nonmonotonic:dynamic:2"), "nonmonotonic:dynamic:2@blocks");
  EXPECT_EQ(canonical("monotonic:static"), "monotonic:static@blocks");
  EXPECT_EQ(canonical("monotonic:runtime@active"), "monotonic:runtime@active");
  const SchedulerSpec spec = parse_scheduler_spec("nonmonotonic:guided:5@active");
  EXPECT_EQ(spec.modifier, OmpScheduleModifier::nonmonotonic);
  EXPECT_EQ(spec.kind, "guided");
  EXPECT_EQ(spec.chunk, 5);
  EXPECT_EQ(spec.space, IterationSpace::active);
}

TEST(SchedulerNames, PaperPresetsMapToTheirSchedules) {
  const std::vector<std::pair<std::string, std::string>> expected{
      {"paper-static", "static@blocks"},      {"paper-dynamic1", "dynamic:1@blocks"},
      {"paper-dynamic2", "dynamic:2@blocks"}, {"paper-dynamic3", "dynamic:3@blocks"},
      {"paper-guided", "guided:1@blocks"},    {"paper-active-lists", "active-lists@active"}};
  EXPECT_EQ(scheduler_presets(), expected);
  for (const auto& [preset, spec] : expected) {
    EXPECT_EQ(canonical(preset), spec);
    EXPECT_EQ(make_driver(preset)->name(), spec);
  }
  EXPECT_EQ(make_driver("paper-active-lists")->space(), IterationSpace::active);
}

TEST(SchedulerNames, AvailableSchedulersAreCanonicalAndBuildable) {
  const std::vector<std::string> names = available_schedulers();
  EXPECT_GE(names.size(), 20U);
  for (const std::string& name : names) {
    EXPECT_EQ(canonical(name), name);
    EXPECT_EQ(make_driver(name)->name(), name);
  }
}

TEST(SchedulerNames, DriverReportsItsSpace) {
  EXPECT_EQ(make_driver("dynamic:2")->space(), IterationSpace::blocks);
  EXPECT_EQ(make_driver("dynamic:2@active")->space(), IterationSpace::active);
  EXPECT_EQ(OmpStaticDriver().name(), "static@blocks");
  EXPECT_EQ(OmpStaticDriver(IterationSpace::active).name(), "static@active");
}

// Each malformed spec with a fragment its message must contain.
TEST(SchedulerNames, MalformedSpecsAreRejectedWithClearMessages) {
  const std::vector<std::pair<std::string, std::string>> cases{
      {"foo", "unknown kind 'foo'"},
      {"", "unknown kind ''"},
      {"dynamic:0", "chunk size '0' is not an integer in [1, 2147483647]"},
      {"dynamic:x", "chunk size 'x'"},
      {"dynamic:", "chunk size ''"},
      {"dynamic:-2", "chunk size '-2'"},
      {"dynamic:2x", "chunk size '2x'"},
      {"dynamic:2:3", "chunk size '2:3'"},
      {"dynamic:99999999999", "chunk size '99999999999'"},
      {"static@nowhere", "unknown iteration space '@nowhere'"},
      {"dynamic:2@", "unknown iteration space '@'"},
      {"runtime:3", "'runtime' takes no chunk size"},
      {"active-lists:4", "'active-lists' takes no chunk size"},
      {"monotonic:taskloop", "'taskloop' takes no monotonic:/nonmonotonic: modifier"},
      {"nonmonotonic:fac2:2", "'fac2' takes no monotonic:/nonmonotonic: modifier"},
      {"monotonic:monotonic:static", "unknown kind 'monotonic'"},
      {"Dynamic:2", "unknown kind 'Dynamic'"},
      {"paper-static@active", "unknown kind 'paper-static'"},
  };
  for (const auto& [spec, fragment] : cases) {
    try {
      make_driver(spec);
      ADD_FAILURE() << "'" << spec << "' was accepted";
    } catch (const std::invalid_argument& error) {
      const std::string message = error.what();
      EXPECT_THAT(message, HasSubstr("invalid scheduler '" + spec + "'"));
      EXPECT_THAT(message, HasSubstr(fragment)) << spec;
      // The message lists what is valid.
      EXPECT_THAT(message, HasSubstr("kinds: static[:k] dynamic[:k] guided[:k] runtime"));
      EXPECT_THAT(message, HasSubstr("paper-dynamic2=dynamic:2@blocks"));
    }
  }
}

}  // namespace
}  // namespace clothbench::schedulers
