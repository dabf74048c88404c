// The scene's [solver] table: every choice reads, "automatic" resolves to Newton with the
// V-cycle (potential) or nonlinear CG with block Jacobi (violation), old booleans are refused
// with what to write, and every combination the kernel cannot run is located at the setting
// given, for the scene file and the kernel alike.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "harness/scene/scene.hpp"
#include "kernels/simulation.hpp"
#include "kernels/vcycle_preconditioner.hpp"

namespace {

namespace fs = std::filesystem;
namespace kernels = clothbench::kernels;
using clothbench::harness::parse_scene;
using clothbench::harness::SceneError;
using clothbench::kernels::Formulation;
using clothbench::kernels::GradientMode;
using testing::HasSubstr;
using testing::StartsWith;

const fs::path kPresets =
    fs::path(CLOTHBENCH_SOURCE_DIR) / "tests" / "data" / "scenes" / "presets.toml";

TEST(SceneLoader, ElementKernelReadsAndTheVectorOneIsRefusedForTheViolationFormulation) {
  const std::string text = "[cloth]\nparticles = [9, 9]\n[solver]\nkernel = \"vector\"\n";
  EXPECT_EQ(parse_scene(text, "kernel.toml", kPresets).simulation.solver.kernel,
            clothbench::kernels::ElementKernel::vector);
  EXPECT_EQ(parse_scene("[cloth]\nparticles = [9, 9]\n", "kernel.toml", kPresets)
                .simulation.solver.kernel,
            clothbench::kernels::ElementKernel::reference);
  EXPECT_THROW((void)parse_scene("[cloth]\nparticles = [9, 9]\n[solver]\nkernel = \"simd\"\n",
                                 "kernel.toml", kPresets),
               SceneError);
  try {
    (void)parse_scene(text + "formulation = \"violation\"\n", "kernel.toml", kPresets);
    FAIL() << "the kernel refuses this combination; the loader must too";
  } catch (const SceneError& error) {
    EXPECT_THAT(error.what(), HasSubstr("the vector element kernel is implemented for the "
                                        "potential formulation only"));
  }
}

TEST(SceneLoader, TiltedPlateauReadsAndItsUnrunnableCombinationsAreLocated) {
  const std::string base = "[cloth]\nparticles = [9, 9]\n[fabric]\ntension_plateau_slope = 1e-3\n";
  EXPECT_DOUBLE_EQ(parse_scene(base, "tilt.toml", kPresets).simulation.fabric.tension_plateau_slope,
                   1e-3);
  EXPECT_EQ(parse_scene("[cloth]\nparticles = [9, 9]\n", "tilt.toml", kPresets)
                .simulation.fabric.tension_plateau_slope,
            0.0);
  auto error_of = [](const std::string& text) -> std::string {
    try {
      (void)parse_scene(text, "tilt.toml", kPresets);
    } catch (const SceneError& error) {
      return error.what();
    }
    return {};
  };
  EXPECT_THAT(error_of("[cloth]\nparticles = [9, 9]\n[fabric]\ntension_plateau_slope = 1.5\n"),
              StartsWith("tilt.toml:4:25: [fabric] tension_plateau_slope: 1.5 is out of range"));
  EXPECT_THAT(error_of("[cloth]\nparticles = [9, 9]\n[fabric]\ntension_plateau_slope = -0.1\n"),
              StartsWith("tilt.toml:4:25: [fabric] tension_plateau_slope: -0.1 is out of range"));
  // LT = 1.9: p = 2/1.9 - 1 = 0.0526, below the slope asked for.
  EXPECT_EQ(error_of(base + "[fabric.weft]\nlt = 1.9\n"), "");
  EXPECT_THAT(error_of("[cloth]\nparticles = [9, 9]\n[fabric]\ntension_plateau_slope = 0.1\n"
                       "[fabric.weft]\nlt = 1.9\n"),
              StartsWith("tilt.toml:4:25: [fabric] tension_plateau_slope: got 0.1, not below the "
                         "weft loading exponent p = 2/LT - 1 = 0.0526316 (LT = 1.9)"));
  EXPECT_THAT(error_of(base + "[solver]\nformulation = \"violation\"\n"),
              StartsWith("tilt.toml:4:25: [fabric] tension_plateau_slope: the tilted tension "
                         "plateau is a return mapping of the potential formulation"));
  EXPECT_THAT(error_of(base + "[solver]\nkernel = \"vector\"\n"),
              StartsWith("tilt.toml:4:25: [fabric] tension_plateau_slope: the vector element "
                         "kernel implements the flat plateau of MODEL.md 4B only"));
  // The kernel refuses the same combinations for a configuration built in code.
  kernels::SimulationConfig config = parse_scene(base, "tilt.toml", kPresets).simulation;
  config.solver.kernel = kernels::ElementKernel::vector;
  EXPECT_THROW(kernels::Simulation{config}, std::invalid_argument);
  config.solver.kernel = kernels::ElementKernel::reference;
  config.fabric.tension_plateau_slope = 3.0;  // above p = 2/0.65 - 1 = 2.08
  EXPECT_THROW(kernels::Simulation{config}, std::invalid_argument);
}

TEST(SceneLoader, NumericGradientReadsAndIsRefusedWithAmrcForTheViolationFormulation) {
  const std::string text =
      "[cloth]\nparticles = [9, 9]\n[solver]\nformulation = \"violation\"\n"
      "gradient = \"numeric\"\n";
  EXPECT_EQ(parse_scene(text, "numeric.toml", kPresets).simulation.solver.gradient,
            GradientMode::numeric);
  try {
    (void)parse_scene(text + "[amrc]\nenabled = true\nlevels = 2\n", "numeric.toml", kPresets);
    FAIL() << "the kernel refuses this combination; the loader must too";
  } catch (const SceneError& error) {
    EXPECT_THAT(error.what(),
                StartsWith("numeric.toml:5:12: [solver] gradient: the numeric gradient of the "
                           "violation formulation is not available with [amrc] enabled = true"));
  }
}

TEST(SceneLoader, SolverChoicesReadEveryNameAndDefaultToNewtonWithTheVcycle) {
  using clothbench::kernels::Preconditioner;
  using clothbench::kernels::StepMethod;
  const kernels::SolverConfig defaults =
      parse_scene("[cloth]\nparticles = [9, 9]\n", "solver.toml", kPresets).simulation.solver;
  EXPECT_EQ(defaults.method, StepMethod::automatic);
  EXPECT_EQ(defaults.preconditioner, Preconditioner::automatic);
  EXPECT_EQ(kernels::resolved_method(defaults), StepMethod::newton);
  EXPECT_EQ(kernels::resolved_preconditioner(defaults), Preconditioner::vcycle);
  {  // and a Simulation runs (and reports) what they resolve to
    const kernels::Simulation sim(
        parse_scene("[cloth]\nparticles = [9, 9]\n", "solver.toml", kPresets).simulation);
    EXPECT_EQ(sim.config().solver.method, StepMethod::newton);
    EXPECT_EQ(sim.config().solver.preconditioner, Preconditioner::vcycle);
  }
  // Each method's own preconditioner; the violation formulation's own method.
  kernels::SolverConfig cg = defaults;
  cg.method = StepMethod::nonlinear_cg;
  EXPECT_EQ(kernels::resolved_preconditioner(cg), Preconditioner::block_jacobi);
  const kernels::SolverConfig violation =
      parse_scene("[cloth]\nparticles = [9, 9]\n[solver]\nformulation = \"violation\"\n",
                  "solver.toml", kPresets)
          .simulation.solver;
  EXPECT_EQ(kernels::resolved_method(violation), StepMethod::nonlinear_cg);
  EXPECT_EQ(kernels::resolved_preconditioner(violation), Preconditioner::block_jacobi);
  for (const std::string& name : clothbench::kernels::preconditioner_names()) {
    // Every preconditioner under nonlinear CG, but the multigrids, which precondition Newton's
    // inner PCG only.
    const std::string method = name == "multigrid" || name == "v-cycle"
                                   ? "method = \"newton\"\n"
                                   : "method = \"nonlinear-cg\"\n";
    const std::string text =
        "[cloth]\nparticles = [9, 9]\n[solver]\n" + method + "preconditioner = \"" + name + "\"\n";
    const Preconditioner read =
        parse_scene(text, "solver.toml", kPresets).simulation.solver.preconditioner;
    EXPECT_EQ(clothbench::kernels::to_string(read), name);
  }
  for (const std::string& name : clothbench::kernels::step_method_names()) {
    const std::string text = "[cloth]\nparticles = [9, 9]\n[solver]\nmethod = \"" + name +
                             "\"\nmax_newton_iterations = 7\nmax_linear_iterations = 11\n";
    const kernels::SolverConfig solver =
        parse_scene(text, "solver.toml", kPresets).simulation.solver;
    EXPECT_EQ(clothbench::kernels::to_string(solver.method), name);
    EXPECT_EQ(solver.max_newton_iterations, 7);
    EXPECT_EQ(solver.max_linear_iterations, 11);
  }
  const kernels::SolverConfig smoothing =
      parse_scene(
          "[cloth]\nparticles = [9, 9]\n[solver]\nmethod = \"newton\"\n"
          "smoothing_sweeps = 4\nsmoothing_threshold = 0.5\nmodel_refinements = 2\n"
          "preconditioner = \"v-cycle\"\ncoarsest_nodes = 40\n",
          "solver.toml", kPresets)
          .simulation.solver;
  EXPECT_EQ(smoothing.smoothing_sweeps, 4);
  EXPECT_EQ(smoothing.smoothing_threshold, 0.5);
  EXPECT_EQ(smoothing.model_refinements, 2);
  kernels::SolverConfig cg_solver;
  cg_solver.method = StepMethod::nonlinear_cg;
  EXPECT_EQ(kernels::effective_model_refinements(cg_solver), 0) << "CG: none";
  EXPECT_EQ(kernels::effective_model_refinements(kernels::SolverConfig{}), 1) << "Newton: one";
  EXPECT_EQ(smoothing.preconditioner, kernels::Preconditioner::vcycle);
  EXPECT_EQ(smoothing.coarsest_nodes, 40);
  EXPECT_EQ(kernels::SolverConfig{}.coarsest_nodes, kernels::VcyclePreconditioner::kCoarsestNodes);
}

TEST(SceneLoader, OldPreconditionerBooleansAreRefusedWithWhatToWrite) {
  const std::string head = "[cloth]\nparticles = [9, 9]\n[solver]\n";
  const std::pair<std::string, std::string> cases[] = {
      {"preconditioner = true\n",
       "solver.toml:4:18: [solver] preconditioner: a boolean is no longer accepted "
       "(preconditioner = true) (expected preconditioner = \"block-jacobi\""},
      {"preconditioner = false\n",
       "solver.toml:4:18: [solver] preconditioner: a boolean is no longer accepted "
       "(preconditioner = false) (expected preconditioner = \"none\""},
      {"line_solves = true\n",
       "solver.toml:4:15: [solver] line_solves: the key was replaced by a preconditioner choice "
       "(expected preconditioner = \"line-solves\" instead of line_solves = true)"},
      {"method = \"multigrid\"\n",
       "solver.toml:4:10: [solver] method: unknown value \"multigrid\" (expected one of: "
       "nonlinear-cg, newton, automatic)"},
  };
  for (const auto& [line, message] : cases) {
    try {
      (void)parse_scene(head + line, "solver.toml", kPresets);
      FAIL() << "accepted " << line;
    } catch (const SceneError& error) {
      EXPECT_THAT(error.what(), StartsWith(message)) << line;
    }
  }
}

TEST(SceneLoader, MultigridWithoutNewtonOrWithoutACoarseGridIsLocatedAtTheSettingGiven) {
  struct Case {
    std::string text;
    std::string message;
    kernels::SimulationConfig config;  ///< the same settings handed to the kernel
  };
  std::vector<Case> cases(5);
  const std::string cg = "[cloth]\nparticles = [9, 9]\n[solver]\nmethod = \"nonlinear-cg\"\n";
  cases[0].text = cg + "preconditioner = \"multigrid\"\n";
  cases[0].message =
      "solver.toml:5:18: [solver] preconditioner: the multigrid preconditioner preconditions "
      "Newton's inner linear PCG";
  cases[0].config.solver.method = kernels::StepMethod::nonlinear_cg;
  cases[0].config.solver.preconditioner = kernels::Preconditioner::multigrid;
  cases[1].text =
      "[cloth]\nparticles = [9, 9]\n[solver]\nformulation = \"violation\"\npreconditioner = "
      "\"multigrid\"\n";
  cases[1].message =
      "solver.toml:5:18: [solver] preconditioner: the multigrid preconditioner is implemented for "
      "the potential formulation's Newton method only";
  cases[1].config.solver.formulation = kernels::Formulation::violation;
  cases[1].config.solver.preconditioner = kernels::Preconditioner::multigrid;
  cases[2].text =
      "[cloth]\nparticles = [2, 2]\nsize_m = [0.01, 0.01]\n[solver]\nmethod = \"newton\"\n"
      "preconditioner = \"multigrid\"\n";
  cases[2].message =
      "solver.toml:6:18: [solver] preconditioner: a multigrid needs a coarse grid, and a cloth of "
      "fewer than 3 particles along both directions has none";
  cases[2].config.cloth.particles_i = cases[2].config.cloth.particles_j = 2;
  cases[2].config.solver.method = kernels::StepMethod::newton;
  cases[2].config.solver.preconditioner = kernels::Preconditioner::multigrid;
  cases[3].text = cg + "smoothing_sweeps = 2\n";
  cases[3].message =
      "solver.toml:5:20: [solver] smoothing_sweeps: the nonlinear smoothing runs after each of "
      "Newton's line searches";
  cases[3].config.solver.method = kernels::StepMethod::nonlinear_cg;
  cases[3].config.solver.smoothing_sweeps = 2;
  cases[4].text = cg + "model_refinements = 1\n";
  cases[4].message =
      "solver.toml:5:21: [solver] model_refinements: the model is refined along each of "
      "Newton's directions";
  cases[4].config.solver.method = kernels::StepMethod::nonlinear_cg;
  cases[4].config.solver.model_refinements = 1;
  for (const Case& c : cases) {
    try {
      (void)parse_scene(c.text, "solver.toml", kPresets);
      FAIL() << "accepted " << c.text;
    } catch (const SceneError& error) {
      EXPECT_THAT(error.what(), StartsWith(c.message)) << c.text;
    }
    EXPECT_THROW(kernels::Simulation simulation(c.config), std::invalid_argument) << c.text;
  }
  // A cloth of three particles along one direction has a coarse grid.
  EXPECT_NO_THROW((void)parse_scene(
      "[cloth]\nparticles = [3, 2]\nsize_m = [0.01, 0.01]\n[solver]\nmethod = \"newton\"\n"
      "preconditioner = \"multigrid\"\n",
      "solver.toml", kPresets));
}

TEST(SceneLoader, SolverCombinationsTheKernelCannotRunAreLocatedAtTheSettingGiven) {
  const std::string head = "[cloth]\nparticles = [9, 9]\n[solver]\nformulation = \"violation\"\n";
  struct Case {
    std::string line;
    std::string message;
  };
  const Case cases[] = {
      {"preconditioner = \"line-solves\"\n",
       "solver.toml:5:18: [solver] preconditioner: the line-solve preconditioner is implemented "
       "for the potential formulation only"},
      {"method = \"newton\"\n",
       "solver.toml:5:10: [solver] method: Newton's method is implemented for the potential "
       "formulation only"},
  };
  for (const Case& c : cases) {
    try {
      (void)parse_scene(head + c.line, "solver.toml", kPresets);
      FAIL() << "accepted " << c.line;
    } catch (const SceneError& error) {
      EXPECT_THAT(error.what(), StartsWith(c.message)) << c.line;
    }
    // The kernel refuses the same configuration (one check, kernels::validate).
    kernels::SimulationConfig config;
    config.solver.formulation = kernels::Formulation::violation;
    if (c.line.rfind("method", 0) == 0)
      config.solver.method = kernels::StepMethod::newton;
    else
      config.solver.preconditioner = kernels::Preconditioner::line_solves;
    EXPECT_THROW(kernels::Simulation simulation(config), std::invalid_argument);
  }
}

}  // namespace
