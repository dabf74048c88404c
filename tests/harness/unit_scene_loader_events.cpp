// Scene loading of scripted events ([[event]], scenarios/README.md): every mistake is reported
// at its file:line:column with its section and key; valid events round-trip to the kernel's
// SceneEvent; the shipped events scene loads.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "harness/scene/scene.hpp"

namespace {

namespace fs = std::filesystem;
using clothbench::harness::load_scene;
using clothbench::harness::parse_scene;
using clothbench::harness::SceneError;
using clothbench::kernels::SceneEventKind;
using testing::HasSubstr;
using testing::StartsWith;

const fs::path kData = fs::path(CLOTHBENCH_SOURCE_DIR) / "tests" / "data" / "scenes";
const fs::path kPresets = kData / "presets.toml";

struct Mistake {
  const char* file;      // under tests/data/scenes/bad
  const char* location;  // "LINE:COLUMN"
  const char* subject;   // "[section] key: problem" as it must appear after the location
  const char* detail;    // another fragment the message must contain
};

void PrintTo(const Mistake& m, std::ostream* os) { *os << m.file; }

class EventMistake : public testing::TestWithParam<Mistake> {};

TEST_P(EventMistake, IsReportedAtItsFileLineColumnSectionAndKey) {
  const Mistake& m = GetParam();
  const fs::path file = kData / "bad" / m.file;
  std::string message;
  try {
    (void)load_scene(file, kPresets);
  } catch (const SceneError& error) {
    message = error.what();
  }
  ASSERT_FALSE(message.empty()) << m.file << " loaded without error";
  EXPECT_THAT(message, StartsWith(file.string() + ":" + m.location + ": " + m.subject)) << message;
  EXPECT_THAT(message, HasSubstr(m.detail)) << message;
}

INSTANTIATE_TEST_SUITE_P(
    Events, EventMistake,
    testing::Values(
        Mistake{"event-unknown-kind.toml", "5:8", "[event[0]] kind: unknown value \"pull\"",
                "expected one of: move-obstacle, release-pin, force"},
        Mistake{"event-step-out-of-range.toml", "7:8", "[event[0]] step: 11 is out of range",
                "expected an integer in [1, 10]"},
        Mistake{"event-obstacle-out-of-range.toml", "9:12",
                "[event[0]] obstacle: there is no obstacle 1: the scene has 1 [[obstacle]] table",
                "expected an integer in [0, 0]"},
        Mistake{"event-particle-outside.toml", "6:16",
                "[event[0]] particle: j index 7 is outside the 5 x 5 grid", "0 <= j < 5"},
        Mistake{"event-until-before-step.toml", "8:14", "[event[0]] until_step: 3 is before step = 5",
                "expected an integer in [5, 100]"},
        Mistake{"event-unknown-key.toml", "6:1",
                "[event[0]] obstacle: unknown key for kind = \"force\"",
                "valid keys: kind, step, particle, force_N, until_step"},
        Mistake{"event-release-unpinned.toml", "7:12",
                "[event[0]] particle: particle (1, 1) is not pinned",
                "expected a particle listed in [cloth] pinned"},
        Mistake{"event-release-twice.toml", "7:12",
                "[event[0]] particle: particle (0, 0) is already released by event[1] at step 2",
                "released once"},
        Mistake{"event-missing-force.toml", "3:1", "[event[0]] force_N: missing required key",
                "expected force_N = [x, y, z], N"},
        Mistake{"event-displacement-and-velocity.toml", "11:16",
                "[event[0]] velocity_m_s: given together with displacement_m",
                "expected displacement_m = [x, y, z] (once) or velocity_m_s"},
        Mistake{"event-not-array.toml", "3:1", "[event]: events are an array of tables",
                "expected [[event]] sections"}),
    [](const testing::TestParamInfo<Mistake>& info) {
      std::string name = fs::path(info.param.file).stem().string();
      for (char& c : name) {
        if (c == '-') c = '_';
      }
      return name;
    });

TEST(SceneLoaderEvents, EveryKindRoundTripsToTheKernelsEvent) {
  const auto scene = parse_scene(R"(
[scene]
steps = 50
[cloth]
particles = [9, 9]
origin_m = [-0.5, -0.5, 0.5]
pinned = [[0, 0], [8, 0]]
[[obstacle]]
kind = "sphere"
[[obstacle]]
kind = "box"
center_m = [2, 2, 2]
[[event]]
step = 40
kind = "move-obstacle"
obstacle = 1
velocity_m_s = [0, 0, 0.1]
until_step = 45
[[event]]
step = 7
kind = "move-obstacle"
obstacle = 0
displacement_m = [0.01, 0, 0]
[[event]]
step = 30
kind = "release-pin"
particle = [8, 0]
[[event]]
step = 20
kind = "force"
particle = [4, 5]
force_N = [0, 0, 0.05]
until_step = 30
[[event]]
step = 50
kind = "force"
particle = [4, 4]
force_N = [1, 2, 3]
)",
                                 "events.toml", kPresets);
  const auto& events = scene.simulation.events;
  ASSERT_EQ(events.size(), 5u);
  EXPECT_EQ(events[0].kind, SceneEventKind::move_obstacle);
  EXPECT_EQ(events[0].obstacle, 1);
  EXPECT_EQ(events[0].step, 40);
  EXPECT_EQ(events[0].until_step, 45);
  EXPECT_EQ(events[0].velocity, Eigen::Vector3d(0, 0, 0.1));
  EXPECT_TRUE(events[0].displacement.isZero(0.0));
  EXPECT_EQ(events[1].obstacle, 0);
  EXPECT_EQ(events[1].until_step, 7);  // a displacement is applied once
  EXPECT_EQ(events[1].displacement, Eigen::Vector3d(0.01, 0, 0));
  EXPECT_EQ(events[2].kind, SceneEventKind::release_pin);
  EXPECT_EQ(events[2].particle_i, 8);
  EXPECT_EQ(events[2].particle_j, 0);
  EXPECT_EQ(events[3].kind, SceneEventKind::force);
  EXPECT_EQ(events[3].particle_i, 4);
  EXPECT_EQ(events[3].particle_j, 5);
  EXPECT_EQ(events[3].force, Eigen::Vector3d(0, 0, 0.05));
  EXPECT_EQ(events[3].until_step, 30);
  EXPECT_EQ(events[4].until_step, 50);  // one step when until_step is absent
}

TEST(SceneLoaderEvents, UntilStepBelongsToVelocityMovesOnly) {
  try {
    (void)parse_scene(R"([cloth]
particles = [5, 5]
origin_m = [-0.5, -0.5, 0.5]
[[obstacle]]
kind = "sphere"
[[event]]
kind = "move-obstacle"
step = 3
obstacle = 0
displacement_m = [0, 0, 0.1]
until_step = 4
)",
                      "until.toml", kPresets);
    ADD_FAILURE() << "until_step with a displacement was accepted";
  } catch (const SceneError& error) {
    EXPECT_THAT(error.what(), StartsWith("until.toml:11:14: [event[0]] until_step: a displacement "
                                         "is applied once"));
  }
}

TEST(SceneLoaderEvents, MoveWithoutObstaclesSaysThereIsNone) {
  try {
    (void)parse_scene("[cloth]\nparticles = [5, 5]\n[[event]]\nkind = \"move-obstacle\"\nstep = 1\n"
                      "obstacle = 0\ndisplacement_m = [0, 0, 1]\n",
                      "none.toml", kPresets);
    ADD_FAILURE() << "a move without obstacles was accepted";
  } catch (const SceneError& error) {
    EXPECT_THAT(error.what(), StartsWith("none.toml:6:12: [event[0]] obstacle: there is no "
                                         "obstacle 0: the scene has 0 [[obstacle]] tables"));
  }
}

TEST(SceneLoaderEvents, ShippedEventsSceneLoads) {
  const fs::path root = fs::path(CLOTHBENCH_SOURCE_DIR) / "scenarios";
  const auto scene = load_scene(root / "events-33.toml", root / "presets" / "fabrics.toml");
  EXPECT_EQ(scene.simulation.events.size(), 3u);
}

}  // namespace
