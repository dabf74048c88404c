// Scene loading: every classic mistake is reported at its file:line:column with its
// section and key; a full scene round-trips; every shipped scenario and preset loads. The
// [solver] table: unit_scene_solver.cpp.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "harness/scene/scene.hpp"
#include "kernels/simulation.hpp"

namespace {

namespace fs = std::filesystem;
namespace kernels = clothbench::kernels;
using clothbench::harness::load_scene;
using clothbench::harness::parse_scene;
using clothbench::harness::SceneError;
using clothbench::kernels::Formulation;
using clothbench::kernels::GradientMode;
using clothbench::kernels::ObstacleKind;
using testing::HasSubstr;
using testing::StartsWith;

const fs::path kData = fs::path(CLOTHBENCH_SOURCE_DIR) / "tests" / "data" / "scenes";
const fs::path kPresets = kData / "presets.toml";

// The SceneError message of loading `file`, or "" when it loads.
std::string error_of(const fs::path& file, const fs::path& presets = kPresets) {
  try {
    (void)load_scene(file, presets);
  } catch (const SceneError& error) {
    return error.what();
  }
  return {};
}

struct Mistake {
  const char* file;      // under tests/data/scenes/bad
  const char* location;  // "LINE:COLUMN"
  const char* subject;   // "[section] key" as it must appear after the location
  const char* detail;    // another fragment the message must contain
};

void PrintTo(const Mistake& m, std::ostream* os) { *os << m.file; }

class SceneMistake : public testing::TestWithParam<Mistake> {};

TEST_P(SceneMistake, IsReportedAtItsFileLineColumnSectionAndKey) {
  const Mistake& m = GetParam();
  const fs::path file = kData / "bad" / m.file;
  const std::string message = error_of(file);
  ASSERT_FALSE(message.empty()) << m.file << " loaded without error";
  EXPECT_THAT(message, StartsWith(file.string() + ":" + m.location + ": " + m.subject)) << message;
  EXPECT_THAT(message, HasSubstr(m.detail)) << message;
}

INSTANTIATE_TEST_SUITE_P(
    ClassicMistakes, SceneMistake,
    testing::Values(
        Mistake{"syntax-error.toml", "3:2", "TOML syntax error", "array"},
        Mistake{"unknown-section.toml", "3:2", "[cloht]: unknown section", "did you mean 'cloth'?"},
        Mistake{"unknown-key.toml", "3:1", "[cloth] partciles_x: unknown key",
                "valid keys: particles, size_m"},
        Mistake{"wrong-type.toml", "4:10", "[time] step_s: got the string \"fast\"",
                "expected a finite number > 0"},
        Mistake{"negative-size.toml", "3:16", "[cloth] size_m: -1 is out of range", "> 0"},
        Mistake{"zero-time-step.toml", "4:10", "[time] step_s: 0 is out of range", "> 0"},
        Mistake{"non-finite.toml", "4:23", "[time] gravity_m_s2: nan is not finite",
                "finite number"},
        Mistake{"damping-one.toml", "4:11", "[time] damping: 1 is out of range", "in [0, 1)"},
        Mistake{"tolerance-zero.toml", "4:13", "[solver] tolerance: 0 is out of range", "> 0"},
        Mistake{"max-iterations-zero.toml", "4:18", "[solver] max_iterations: 0 is out of range",
                "integer in [1,"},
        Mistake{"block-one.toml", "3:9", "[cloth] block: 1 is out of range", "integer in [2,"},
        Mistake{"particles-one.toml", "2:17", "[cloth] particles: 1 is out of range",
                "integers in [2,"},
        Mistake{"unknown-formulation.toml", "4:15",
                "[solver] formulation: unknown value \"energy\"", "one of: potential, violation"},
        Mistake{"unknown-preset.toml", "3:10",
                "[cloth] fabric: unknown fabric preset \"test-coton\"",
                "did you mean 'test-cotton'? valid presets in"},
        Mistake{"thresholds-swapped.toml", "4:20",
                "[amrc] refine_threshold: refine_threshold 0.05 <= "
                "coarsen_threshold 0.2",
                "expected refine_threshold > coarsen_threshold"},
        Mistake{"amrc-size.toml", "2:19",
                "[cloth] particles: 100 particles along j is not 2^2 n + 1",
                "nearest valid sizes: 97 and 101"},
        Mistake{"pinned-out-of-range.toml", "3:20",
                "[cloth] pinned: i index 5 is outside the 5 x 5 grid", "0 <= i < 5"},
        Mistake{"zero-normal.toml", "5:10", "[obstacle[0]] normal: zero-length vector",
                "direction"},
        Mistake{"zero-axis.toml", "3:10", "[cloth] axis_i: zero-length vector", "direction"},
        Mistake{"missing-cloth.toml", "1:1", "[cloth]: missing required section",
                "particles = [I, J]"},
        Mistake{"missing-particles.toml", "1:1", "[cloth] particles: missing required key",
                "integers >= 2"},
        Mistake{"obstacle-key-for-other-kind.toml", "5:1",
                "[obstacle[0]] radius_m: unknown key for kind = \"box\"",
                "valid keys: kind, center_m, half_extents_m"},
        Mistake{"unknown-obstacle-kind.toml", "4:8", "[obstacle[0]] kind: unknown value \"cone\"",
                "plane, box, sphere, cylinder"},
        Mistake{"float-steps.toml", "2:9", "[scene] steps: got the number 10.5",
                "expected an integer"},
        Mistake{"fabric-lt.toml", "4:6", "[fabric.warp] lt: 2.5 is out of range", "in (0, 2)"},
        Mistake{"obstacle-intersects.toml", "6:1",
                "[obstacle[0]] center_m: the cloth starts inside this box: particle (2, 2) at "
                "(0, 0, 0.1) m is 0.05 m deep",
                "expected every cloth particle to start outside every obstacle"},
        Mistake{"obstacle-crumple-intersects.toml", "12:1",
                "[obstacle[1]] center_m: the cloth starts inside this plane: particle (0, 0) at "
                "(-0.1, -0.1, 0.001) m is 0.002 m deep once [cloth] initial_crumple_m = 0.003 "
                "displaces it (0.001 m outside when flat)",
                "move the obstacle or the cloth ([cloth] origin_m)"},
        Mistake{"non-ascii-outside-string.toml", "2:15",
                "TOML syntax error: unexpected U+00E9 outside a string or comment",
                "TOML allows non-ASCII characters only inside strings and comments"}),
    [](const testing::TestParamInfo<Mistake>& info) {
      std::string name = fs::path(info.param.file).stem().string();
      for (char& c : name) {
        if (c == '-') c = '_';
      }
      return name;
    });

TEST(SceneLoader, UnknownPresetListsEveryValidOne) {
  const std::string message = error_of(kData / "bad" / "unknown-preset.toml");
  EXPECT_THAT(message, HasSubstr("valid presets in " + kPresets.string() +
                                 ": test-broken, test-cotton, test-silk)"));
}

TEST(SceneLoader, AmrcSizeBelowTheSmallestNamesTheSmallest) {
  try {
    (void)parse_scene("[cloth]\nparticles = [9, 3]\n[amrc]\nenabled = true\nlevels = 2\n",
                      "small.toml", kPresets);
    FAIL() << "3 particles accepted with 2 AMRC levels";
  } catch (const SceneError& error) {
    EXPECT_THAT(error.what(), StartsWith("small.toml:2:17: [cloth] particles: 3 particles along j "
                                         "is not 2^2 n + 1 (n >= 1)"));
    EXPECT_THAT(error.what(), HasSubstr("smallest valid size: 5"));
  }
}

TEST(SceneLoader, InvalidPresetNamesThePresetFileAndTheSceneThatUsesIt) {
  const fs::path file = kData / "bad" / "broken-preset.toml";
  const std::string message = error_of(file);
  EXPECT_THAT(message,
              StartsWith(kPresets.string() + ":41:6: [test-broken.warp] lt: 2.5 is out of range"));
  EXPECT_THAT(message, HasSubstr("used at " + file.string() + ":3:10"));
}

TEST(SceneLoader, MissingPresetsFileIsReportedAtTheFabricKey) {
  const fs::path file = kData / "bad" / "unknown-preset.toml";
  const std::string message = error_of(file, kData / "no-such-presets.toml");
  EXPECT_THAT(message,
              StartsWith(file.string() + ":3:10: [cloth] fabric: cannot read the presets"));
  EXPECT_THAT(message, HasSubstr("no-such-presets.toml"));
}

TEST(SceneLoader, MissingSceneFileNamesIt) {
  const std::string message = error_of(kData / "does-not-exist.toml");
  EXPECT_THAT(message, HasSubstr("does-not-exist.toml: cannot open"));
}

TEST(SceneLoader, ParseSceneReportsTheGivenName) {
  try {
    (void)parse_scene("[cloth]\nparticles = [5, 5]\n[contact]\nstiffness = -1\n", "inline.toml",
                      kPresets);
    FAIL() << "negative stiffness accepted";
  } catch (const SceneError& error) {
    EXPECT_THAT(error.what(),
                StartsWith("inline.toml:4:13: [contact] stiffness: -1 is out of range"));
  }
}

TEST(SceneLoader, RejectsTopLevelKeysAndNonTableSections) {
  try {
    (void)parse_scene("steps = 3\n[cloth]\nparticles = [5, 5]\n", "a.toml", kPresets);
    FAIL();
  } catch (const SceneError& error) {
    EXPECT_THAT(error.what(), StartsWith("a.toml:1:1: [steps]: key outside any section"));
  }
  try {
    (void)parse_scene("time = 3\n[cloth]\nparticles = [5, 5]\n", "b.toml", kPresets);
    FAIL();
  } catch (const SceneError& error) {
    EXPECT_THAT(error.what(), StartsWith("b.toml:1:8: [time]: got the integer 3"));
  }
}

TEST(SceneLoader, MinimalSceneTakesTheDocumentedDefaults) {
  const auto scene = load_scene(kData / "minimal.toml", kPresets);
  const clothbench::kernels::SimulationConfig defaults;
  EXPECT_EQ(scene.name, "minimal");
  EXPECT_EQ(scene.steps, 100);
  EXPECT_EQ(scene.simulation.cloth.particles_i, 5);
  EXPECT_EQ(scene.simulation.cloth.particles_j, 4);
  EXPECT_EQ(scene.simulation.cloth.size_i, defaults.cloth.size_i);
  EXPECT_EQ(scene.simulation.cloth.block_size, defaults.cloth.block_size);
  EXPECT_EQ(scene.simulation.fabric_name, "default");
  EXPECT_EQ(scene.simulation.fabric.warp.lt, defaults.fabric.warp.lt);
  EXPECT_EQ(scene.simulation.time.step, defaults.time.step);
  EXPECT_EQ(scene.simulation.solver.max_iterations, defaults.solver.max_iterations);
  EXPECT_FALSE(scene.simulation.amrc.enabled);
  EXPECT_TRUE(scene.simulation.obstacles.empty());
}

TEST(SceneLoader, FullSceneRoundTripsToTheExpectedConfig) {
  const fs::path file = kData / "valid-full.toml";
  const auto scene = load_scene(file, kPresets);
  EXPECT_EQ(scene.name, "full");
  EXPECT_EQ(scene.description, "all keys");
  EXPECT_EQ(scene.file, file);
  EXPECT_THAT(scene.source_text, HasSubstr("Every key set"));
  EXPECT_EQ(scene.source_sha256_or_fnv, clothbench::harness::fnv1a64_hex(scene.source_text));
  EXPECT_EQ(scene.source_sha256_or_fnv.size(), 16u);
  EXPECT_EQ(scene.steps, 7);

  const auto& sim = scene.simulation;
  EXPECT_EQ(sim.cloth.particles_i, 17);
  EXPECT_EQ(sim.cloth.particles_j, 9);
  EXPECT_DOUBLE_EQ(sim.cloth.size_i, 0.8);
  EXPECT_DOUBLE_EQ(sim.cloth.size_j, 0.4);
  EXPECT_TRUE(sim.cloth.origin.isApprox(Eigen::Vector3d(-0.4, -0.2, 0.5)));
  EXPECT_TRUE(sim.cloth.axis_i.isApprox(Eigen::Vector3d::UnitX()));  // normalised
  EXPECT_TRUE(sim.cloth.axis_j.isApprox(-Eigen::Vector3d::UnitZ()));
  EXPECT_EQ(sim.cloth.block_size, 8);
  ASSERT_EQ(sim.cloth.pinned.size(), 2u);  // the repeated pin is one pin
  EXPECT_EQ(sim.cloth.pinned[0], std::make_pair(0, 0));
  EXPECT_EQ(sim.cloth.pinned[1], std::make_pair(16, 8));
  EXPECT_DOUBLE_EQ(sim.cloth.initial_stretch, 0.1);
  EXPECT_DOUBLE_EQ(sim.cloth.initial_crumple, 0.001);
  EXPECT_EQ(sim.cloth.initial_seed, 42u);

  // Preset test-silk with [fabric] overrides on top.
  EXPECT_EQ(sim.fabric_name, "test-silk (modified)");
  EXPECT_DOUBLE_EQ(sim.fabric.weight_mg_per_cm2, 6.5);  // preset
  EXPECT_DOUBLE_EQ(sim.fabric.fm_gf_per_cm, 400.0);     // preset
  EXPECT_DOUBLE_EQ(sim.fabric.thickness_mm, 0.25);      // override
  EXPECT_DOUBLE_EQ(sim.fabric.kappa0_per_cm, 0.2);      // override
  EXPECT_DOUBLE_EQ(sim.fabric.warp.emt_percent, 4.8);   // preset
  EXPECT_DOUBLE_EQ(sim.fabric.weft.lt, 0.6);            // override
  EXPECT_DOUBLE_EQ(sim.fabric.weft.rt_percent, 55.0);   // preset

  EXPECT_DOUBLE_EQ(sim.time.step, 0.005);
  EXPECT_DOUBLE_EQ(sim.time.damping, 0.25);
  EXPECT_TRUE(sim.time.gravity.isApprox(Eigen::Vector3d(0, -9.81, 0)));
  EXPECT_DOUBLE_EQ(sim.contact.distance, 0.003);
  EXPECT_DOUBLE_EQ(sim.contact.stiffness, 5e3);

  EXPECT_EQ(sim.solver.formulation, Formulation::violation);
  EXPECT_EQ(sim.solver.gradient, GradientMode::analytic);
  EXPECT_EQ(sim.solver.preconditioner, clothbench::kernels::Preconditioner::none);
  EXPECT_DOUBLE_EQ(sim.solver.tolerance, 1e-5);
  EXPECT_EQ(sim.solver.max_iterations, 33);
  EXPECT_DOUBLE_EQ(sim.solver.numeric_step, 1e-7);
  EXPECT_DOUBLE_EQ(sim.solver.weight_newton, 2.0);
  EXPECT_DOUBLE_EQ(sim.solver.weight_stretch, 0.5);
  EXPECT_DOUBLE_EQ(sim.solver.weight_bend, 0.25);
  EXPECT_DOUBLE_EQ(sim.solver.weight_contact, 4.0);
  EXPECT_DOUBLE_EQ(sim.solver.stretch_reference_fm, 0.0);
  EXPECT_DOUBLE_EQ(sim.solver.time_budget, 500.0);

  EXPECT_TRUE(sim.amrc.enabled);
  EXPECT_EQ(sim.amrc.levels, 3);
  EXPECT_EQ(sim.amrc.check_every, 5);
  EXPECT_DOUBLE_EQ(sim.amrc.refine_threshold, 0.3);
  EXPECT_DOUBLE_EQ(sim.amrc.coarsen_threshold, 0.1);

  ASSERT_EQ(sim.obstacles.size(), 4u);
  EXPECT_EQ(sim.obstacles[0].kind, ObstacleKind::plane);
  EXPECT_TRUE(sim.obstacles[0].center.isApprox(Eigen::Vector3d(0, 0, -1)));
  EXPECT_TRUE(sim.obstacles[0].normal.isApprox(Eigen::Vector3d::UnitZ()));
  EXPECT_EQ(sim.obstacles[1].kind, ObstacleKind::box);
  EXPECT_TRUE(sim.obstacles[1].half_extents.isApprox(Eigen::Vector3d(0.25, 0.2, 0.125)));
  EXPECT_EQ(sim.obstacles[2].kind, ObstacleKind::sphere);
  EXPECT_DOUBLE_EQ(sim.obstacles[2].radius, 0.15);
  EXPECT_TRUE(sim.obstacles[2].center.isApprox(Eigen::Vector3d(0.1, 0.2, 0.3)));
  EXPECT_EQ(sim.obstacles[3].kind, ObstacleKind::cylinder);
  EXPECT_TRUE(sim.obstacles[3].axis.isApprox(Eigen::Vector3d(0, 0.6, 0.8)));
  EXPECT_DOUBLE_EQ(sim.obstacles[3].radius, 0.05);
  EXPECT_DOUBLE_EQ(sim.obstacles[3].half_length, 0.4);
}

TEST(SceneLoader, HashIsStableAndSensitive) {
  EXPECT_EQ(clothbench::harness::fnv1a64_hex(""), "cbf29ce484222325");   // FNV-1a offset basis
  EXPECT_EQ(clothbench::harness::fnv1a64_hex("a"), "af63dc4c8601ec8c");  // published test vector
  EXPECT_NE(clothbench::harness::fnv1a64_hex("ab"), clothbench::harness::fnv1a64_hex("ba"));
}

TEST(FabricPresets, NamesAndValuesOfTheFixture) {
  EXPECT_THAT(clothbench::harness::fabric_preset_names(kPresets),
              testing::ElementsAre("test-broken", "test-cotton", "test-silk"));
  const auto cotton = clothbench::harness::load_fabric_preset(kPresets, "test-cotton");
  EXPECT_DOUBLE_EQ(cotton.weight_mg_per_cm2, 13.5);
  EXPECT_DOUBLE_EQ(cotton.warp.emt_percent, 4.2);
  EXPECT_DOUBLE_EQ(cotton.weft.bending_2hb, 0.06);
  EXPECT_DOUBLE_EQ(cotton.fm_gf_per_cm, clothbench::kernels::KesParameters{}.fm_gf_per_cm);
}

TEST(FabricPresets, UnknownNameListsTheValidOnes) {
  try {
    (void)clothbench::harness::load_fabric_preset(kPresets, "tset-silk");
    FAIL();
  } catch (const SceneError& error) {
    EXPECT_THAT(error.what(), StartsWith(kPresets.string() + ":"));
    EXPECT_THAT(error.what(), HasSubstr("[tset-silk]: unknown fabric preset"));
    EXPECT_THAT(
        error.what(),
        HasSubstr("did you mean 'test-silk'? valid presets: test-broken, test-cotton, test-silk"));
  }
}

TEST(FabricPresets, PresetsStateEveryDirectionKey) {
  try {
    (void)parse_scene("[cloth]\nparticles = [5, 5]\nfabric = \"p\"\n", "s.toml",
                      kData / "bad" / "incomplete-presets.toml");
    FAIL();
  } catch (const SceneError& error) {
    EXPECT_THAT(error.what(),
                HasSubstr("incomplete-presets.toml:4:1: [p.warp] bending_2hb: missing"));
  }
}

TEST(FabricPresets, DefaultFileHonoursTheEnvironment) {
  ASSERT_EQ(setenv("CLOTHBENCH_PRESETS", "/some/where.toml", 1), 0);
  EXPECT_EQ(clothbench::harness::default_presets_file(), fs::path("/some/where.toml"));
  ASSERT_EQ(unsetenv("CLOTHBENCH_PRESETS"), 0);
  EXPECT_EQ(clothbench::harness::default_presets_file(),
            fs::path(CLOTHBENCH_SOURCE_DIR) / "scenarios" / "presets" / "fabrics.toml");
}

TEST(ShippedFiles, EveryPresetLoads) {
  const fs::path presets =
      fs::path(CLOTHBENCH_SOURCE_DIR) / "scenarios" / "presets" / "fabrics.toml";
  ASSERT_TRUE(fs::exists(presets)) << presets;
  const auto names = clothbench::harness::fabric_preset_names(presets);
  EXPECT_EQ(names.size(), 5u) << "cotton-shirting, denim, polyester, silk, wool-suiting";
  for (const auto& name : names) {
    EXPECT_NO_THROW((void)clothbench::harness::load_fabric_preset(presets, name)) << name;
  }
}

TEST(ShippedFiles, EveryScenarioLoads) {
  const fs::path root = fs::path(CLOTHBENCH_SOURCE_DIR) / "scenarios";
  const fs::path presets = root / "presets" / "fabrics.toml";
  int count = 0;
  for (const auto& entry : fs::recursive_directory_iterator(root)) {
    if (!entry.is_regular_file() || entry.path().extension() != ".toml") continue;
    if (entry.path().parent_path() == root / "presets") continue;
    ++count;
    try {
      const auto scene = load_scene(entry.path(), presets);
      EXPECT_FALSE(scene.name.empty()) << entry.path();
    } catch (const SceneError& error) {
      ADD_FAILURE() << error.what();
    }
  }
  EXPECT_GE(count, 2);  // box-101 and table-33 at least
}

TEST(ShippedFiles, ReadmeExampleLoads) {
  const fs::path readme = fs::path(CLOTHBENCH_SOURCE_DIR) / "scenarios" / "README.md";
  std::ifstream in(readme);
  ASSERT_TRUE(in) << readme;
  std::string line, example;
  bool inside = false;
  while (std::getline(in, line)) {
    if (!inside && line == "```toml") {
      inside = true;
    } else if (inside && line == "```") {
      break;
    } else if (inside) {
      example += line + "\n";
    }
  }
  ASSERT_FALSE(example.empty()) << "no ```toml block in " << readme;
  try {
    const auto scene =
        parse_scene(example, readme,
                    fs::path(CLOTHBENCH_SOURCE_DIR) / "scenarios" / "presets" / "fabrics.toml");
    EXPECT_EQ(scene.simulation.obstacles.size(), 2u);
  } catch (const SceneError& error) {
    ADD_FAILURE() << error.what();
  }
}

}  // namespace
