// The real `clothbench` binary given bad input: every classic scene-file mistake makes `check`
// and `run` exit with code 2 and print FILE:LINE:COLUMN: [section] key and what is wrong; an
// unknown preset lists the valid ones; a grid too large for this machine's memory is refused
// at its [cloth] particles (and `check` prints the estimate of a scene that fits); more threads
// than the hardware has are refused unless --oversubscribe is given, and then the run says it
// is oversubscribed in every output; a valid scene that overflows stops FAILED with its state
// written as JSON and VTK and no non-finite number in any file.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "tests/harness/clothbench_process.hpp"

namespace {

namespace fs = std::filesystem;
using clothbench_test::fresh_dir;
using clothbench_test::Outcome;
using clothbench_test::quote;
using clothbench_test::read_json;
using clothbench_test::run;
using testing::HasSubstr;
using testing::StartsWith;

const fs::path kScenes = fs::path(CLOTHBENCH_SOURCE_DIR) / "tests" / "data" / "scenes";
const fs::path kTiny = kScenes / "sweep-tiny.toml";
const std::string kTestPresets = "CLOTHBENCH_PRESETS=" + quote((kScenes / "presets.toml").string());

class BadInputBinary : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(clothbench_test::binary()))
        << "clothbench binary not built: " << clothbench_test::binary();
  }
};

struct Mistake {
  const char* file;     // under tests/data/scenes/bad
  const char* message;  // what follows "clothbench: FILE:"
};

void PrintTo(const Mistake& m, std::ostream* os) { *os << m.file; }

class ClassicMistake : public BadInputBinary, public testing::WithParamInterface<Mistake> {};

TEST_P(ClassicMistake, CheckAndRunExitWithCodeTwoNamingFileLineAndKey) {
  const fs::path file = kScenes / "bad" / GetParam().file;
  const std::string expected = "clothbench: " + file.string() + ":" + GetParam().message;
  const Outcome check = run("check " + quote(file.string()), kTestPresets);
  EXPECT_EQ(check.exit_code, 2) << check.output;
  EXPECT_THAT(check.output, StartsWith(expected));
  const fs::path out = fresh_dir("bad-run");
  const Outcome simulate =
      run("run " + quote(file.string()) + " --quiet --no-vtk --out " + quote(out.string()),
          kTestPresets);
  EXPECT_EQ(simulate.exit_code, 2) << simulate.output;
  EXPECT_THAT(simulate.output, StartsWith(expected));
  EXPECT_FALSE(fs::exists(out)) << "nothing is written for bad input";
}

// The mistakes of issue 7 (the loader's unit tests cover every other one).
INSTANTIATE_TEST_SUITE_P(
    Cli, ClassicMistake,
    testing::Values(
        Mistake{"missing-cloth.toml", "1:1: [cloth]: missing required section"},
        Mistake{"wrong-type.toml", "4:10: [time] step_s: got the string \"fast\" (expected"},
        Mistake{"negative-size.toml", "3:16: [cloth] size_m: -1 is out of range"},
        Mistake{"amrc-size.toml",
                "2:19: [cloth] particles: 100 particles along j is not 2^2 n + 1 (n >= 1) as "
                "[amrc] levels = 2 requires (nearest valid sizes: 97 and 101)"},
        Mistake{"thresholds-swapped.toml",
                "4:20: [amrc] refine_threshold: refine_threshold 0.05 <= coarsen_threshold 0.2"},
        Mistake{"obstacle-intersects.toml",
                "6:1: [obstacle[0]] center_m: the cloth starts inside this box: particle (2, 2) "
                "at (0, 0, 0.1) m is 0.05 m deep"},
        Mistake{"unknown-preset.toml",
                "3:10: [cloth] fabric: unknown fabric preset \"test-coton\" (did you mean "
                "'test-cotton'? valid presets in"},
        Mistake{"non-ascii-outside-string.toml",
                "2:15: TOML syntax error: unexpected U+00E9 outside a string or comment"}),
    [](const testing::TestParamInfo<Mistake>& info) {
      std::string name = fs::path(info.param.file).stem().string();
      for (char& c : name) {
        if (c == '-') c = '_';
      }
      return name;
    });

TEST_F(BadInputBinary, UnknownShippedPresetListsTheShippedOnes) {
  const fs::path file = fresh_dir("preset").string() + ".toml";
  std::ofstream(file) << "[cloth]\nparticles = [5, 5]\nfabric = \"coton-shirting\"\n";
  const Outcome o = run("check " + quote(file.string()));
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_THAT(o.output, StartsWith("clothbench: " + file.string() +
                                   ":3:10: [cloth] fabric: unknown fabric preset "
                                   "\"coton-shirting\" (did you mean 'cotton-shirting'?"));
  EXPECT_THAT(o.output, HasSubstr(": cotton-shirting, denim, polyester, silk, wool-suiting)"));
  fs::remove(file);
}

TEST_F(BadInputBinary, MemoryRefusalNamesTheLineAndColumnOfParticles) {
  const fs::path file = fresh_dir("huge").string() + ".toml";
  // 10^12 particles: hundreds of terabytes; nothing in loading allocates by the grid.
  std::ofstream(file) << "[scene]\nname = \"too large\"\n\n[cloth]\nsize_m = [1.0, 1.0]\n"
                         "particles   =   [1000000, 1000000]\n";
  const std::string expected = "clothbench: " + file.string() +
                               ":6:17: [cloth] particles: 1000000 x 1000000 particles need about ";
  const fs::path out = fresh_dir("huge-out");
  for (const std::string& command :
       {"check " + quote(file.string()),
        "run " + quote(file.string()) + " --quiet --no-vtk --out " + quote(out.string()),
        "sweep " + quote(file.string()) + " --quiet --no-plots --out " + quote(out.string())}) {
    const Outcome o = run(command);
    EXPECT_EQ(o.exit_code, 2) << command << ": " << o.output;
    EXPECT_THAT(o.output, StartsWith(expected)) << command;
    EXPECT_THAT(o.output, HasSubstr(" GiB, but this machine has ")) << command;
    EXPECT_THAT(o.output, testing::Not(HasSubstr(": OK"))) << command;
    EXPECT_FALSE(fs::exists(out)) << command << ": nothing is written for bad input";
  }
  fs::remove(file);
}

TEST_F(BadInputBinary, CheckPrintsTheMemoryEstimate) {
  const Outcome o = run("check " + quote(kTiny.string()));
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_THAT(o.output, testing::ContainsRegex(R"(
  memory      about [0-9]+\.[0-9] MiB \(estimate; this machine has [0-9]+\.[0-9] GiB\)
)"));
}

// A scene the loader accepts (every value finite) whose first step overflows: the run stops
// there FAILED (exit 1), names the term, writes the state as JSON and VTK, and no result file
// holds a NaN or an infinity.
TEST_F(BadInputBinary, ARunThatOverflowsWritesItsSnapshotAndNoNonFiniteNumber) {
  const fs::path dir = fresh_dir("overflow");
  fs::create_directories(dir);
  const fs::path scene = dir / "overflow.toml";
  std::ofstream(scene) << "[scene]\nname = \"overflow\"\nsteps = 3\n"
                          "[cloth]\nparticles = [9, 9]\nsize_m = [0.2, 0.2]\n"
                          "origin_m = [-0.1, -0.1, 0.0]\nfabric = \"test-cotton\"\n"
                          "[time]\nstep_s = 0.004\ngravity_m_s2 = [0, 0, -1e308]\n";
  const fs::path out = dir / "out";
  const Outcome o =
      run("run " + quote(scene.string()) + " --quiet --out " + quote(out.string()), kTestPresets);
  EXPECT_EQ(o.exit_code, 1) << o.output;
  EXPECT_THAT(o.output, HasSubstr("step 1: non-finite value: "));
  EXPECT_THAT(o.output, HasSubstr("\nVerification: FAILED"));
  const fs::path run_dir = out / "overflow";
  for (const char* file : {"summary.json", "non_finite_snapshot.json", "non_finite_snapshot.vtk"}) {
    ASSERT_TRUE(fs::exists(run_dir / file)) << file << "\n" << o.output;
  }
  // Strict JSON (a NaN or infinity would not parse), and finite VTK data below the title line,
  // which quotes the message.
  nlohmann::json summary, snapshot;
  ASSERT_NO_THROW(summary = read_json(run_dir / "summary.json"));
  ASSERT_NO_THROW(snapshot = read_json(run_dir / "non_finite_snapshot.json"));
  EXPECT_EQ(summary["verification"]["passed"], false);
  EXPECT_EQ(snapshot["step"], 1);
  const std::string vtk = clothbench_test::read_text(run_dir / "non_finite_snapshot.vtk");
  ASSERT_NE(vtk.find("\nASCII\n"), std::string::npos);
  const std::string data = vtk.substr(vtk.find("\nASCII\n"));
  for (const char* bad : {"nan", "NaN", "inf", "Inf"}) {
    EXPECT_EQ(data.find(bad), std::string::npos) << "the VTK data holds " << bad;
  }
  EXPECT_FALSE(fs::exists(run_dir / "final.vtk")) << "a failed run writes no final surface";
  fs::remove_all(dir);
}

TEST_F(BadInputBinary, PreconditionerOverrideSelectsLineSolvesAndMultigridOnlyWhereTheyExist) {
  const fs::path out = fresh_dir("run-lines");
  const std::string common =
      "run " + quote(kTiny.string()) + " --steps 2 --no-vtk --out " + quote(out.string());
  // The scene says nothing about the solver: Newton with the V-cycle.
  const Outcome automatic = run(common);
  ASSERT_EQ(automatic.exit_code, 0) << automatic.output;
  EXPECT_THAT(automatic.output, HasSubstr("method newton, preconditioner v-cycle\n"));
  const Outcome lines = run(common + " --method nonlinear-cg --preconditioner line-solves");
  ASSERT_EQ(lines.exit_code, 0) << lines.output;
  EXPECT_THAT(lines.output, HasSubstr("method nonlinear-cg, preconditioner line-solves\n"));
  EXPECT_THAT(lines.output, HasSubstr("\nVerification: PASSED"));
  const Outcome cg = run(common + " --method nonlinear-cg");  // its own: block Jacobi
  ASSERT_EQ(cg.exit_code, 0) << cg.output;
  EXPECT_THAT(cg.output, HasSubstr("method nonlinear-cg, preconditioner block-jacobi\n"));
  const Outcome newton = run(common + " --method newton --preconditioner line-solves");
  ASSERT_EQ(newton.exit_code, 0) << newton.output;
  EXPECT_THAT(newton.output, HasSubstr("method newton, preconditioner line-solves\n"));
  EXPECT_THAT(newton.output, HasSubstr("Newton iterations"));
  EXPECT_THAT(newton.output, HasSubstr("\nVerification: PASSED"));

  const Outcome refused = run(common + " --preconditioner line-solves --formulation violation");
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_THAT(refused.output, HasSubstr("solver.preconditioner: the line-solve preconditioner is "
                                        "implemented for the potential formulation only"));
  const Outcome violation = run(common + " --formulation violation");  // its own: CG
  ASSERT_EQ(violation.exit_code, 0) << violation.output;
  EXPECT_THAT(violation.output, HasSubstr("method nonlinear-cg, preconditioner block-jacobi\n"));
  const Outcome no_newton = run(common + " --method newton --formulation violation");
  EXPECT_EQ(no_newton.exit_code, 2) << no_newton.output;
  EXPECT_THAT(no_newton.output, HasSubstr("solver.method: Newton's method is implemented for the "
                                          "potential formulation only"));
  const Outcome old_name = run(common + " --preconditioner lines");
  EXPECT_EQ(old_name.exit_code, 2) << old_name.output;
  EXPECT_THAT(old_name.output, HasSubstr("--preconditioner"));
  // The multigrids precondition Newton's inner PCG only.
  for (const char* multigrid : {"multigrid", "v-cycle"}) {
    const std::string name = multigrid;
    const Outcome refused_alone = run(common + " --method nonlinear-cg --preconditioner " + name);
    EXPECT_EQ(refused_alone.exit_code, 2) << refused_alone.output;
    EXPECT_THAT(refused_alone.output,
                HasSubstr("solver.preconditioner: the " + name +
                          " preconditioner preconditions Newton's inner linear PCG"));
    const Outcome with_newton = run(common + " --method newton --preconditioner " + name);
    ASSERT_EQ(with_newton.exit_code, 0) << with_newton.output;
    EXPECT_THAT(with_newton.output, HasSubstr("method newton, preconditioner " + name + "\n"));
    EXPECT_THAT(with_newton.output, HasSubstr("\nVerification: PASSED"));
  }
}

TEST_F(BadInputBinary, ThreadsAboveTheHardwareNeedOversubscribeAndAreLabelled) {
  const int hardware = clothbench_test::hardware_threads();
  const std::string over = std::to_string(hardware + 1);
  const fs::path out = fresh_dir("run-oversubscribed");
  const std::string common =
      "run " + quote(kTiny.string()) + " --steps 1 --quiet --no-vtk --out " + quote(out.string());

  const Outcome refused = run(common + " --threads " + over);
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_THAT(refused.output,
              HasSubstr("--threads: " + over + " threads requested but this machine has " +
                        std::to_string(hardware) + " hardware threads"));
  EXPECT_THAT(refused.output, HasSubstr("pass --oversubscribe"));
  EXPECT_FALSE(fs::exists(out));

  // OMP_NUM_THREADS above the hardware is refused the same way.
  const Outcome from_environment = run(common, "OMP_NUM_THREADS=" + over);
  EXPECT_EQ(from_environment.exit_code, 2) << from_environment.output;
  EXPECT_THAT(from_environment.output, HasSubstr("--oversubscribe"));

  const Outcome allowed = run(common + " --threads " + over + " --oversubscribe");
  ASSERT_EQ(allowed.exit_code, 0) << allowed.output;
  EXPECT_THAT(allowed.output, HasSubstr("threads " + over + " (OVERSUBSCRIBED)"));
  EXPECT_THAT(allowed.output, HasSubstr("(" + over + " threads, oversubscribed)"));
  const auto summary = read_json(out / "sweep-tiny" / "summary.json");
  EXPECT_EQ(summary["threads"].get<int>(), hardware + 1);
  EXPECT_TRUE(summary["oversubscribed"].get<bool>());

  const Outcome fits = run(common + " --threads " + std::to_string(hardware));
  ASSERT_EQ(fits.exit_code, 0) << fits.output;
  EXPECT_THAT(fits.output, testing::Not(HasSubstr("OVERSUBSCRIBED")));
  EXPECT_FALSE(read_json(out / "sweep-tiny" / "summary.json")["oversubscribed"].get<bool>());
  fs::remove_all(out);
}

}  // namespace
