// The string forms of the configuration's choices and the one check of their combinations
// (see simulation_config.hpp).
#include "kernels/simulation_config.hpp"

#include <array>
#include <cmath>
#include <sstream>
#include <utility>

namespace clothbench::kernels {

namespace {

constexpr std::array<std::pair<Formulation, const char*>, 2> kFormulations{{
    {Formulation::potential, "potential"},
    {Formulation::violation, "violation"},
}};
constexpr std::array<std::pair<GradientMode, const char*>, 2> kGradientModes{{
    {GradientMode::analytic, "analytic"},
    {GradientMode::numeric, "numeric"},
}};
constexpr std::array<std::pair<ElementKernel, const char*>, 2> kElementKernels{{
    {ElementKernel::reference, "reference"},
    {ElementKernel::vector, "vector"},
}};
constexpr std::array<std::pair<StepMethod, const char*>, 3> kStepMethods{{
    {StepMethod::nonlinear_cg, "nonlinear-cg"},
    {StepMethod::newton, "newton"},
    {StepMethod::automatic, "automatic"},
}};
constexpr std::array<std::pair<Preconditioner, const char*>, 6> kPreconditioners{{
    {Preconditioner::none, "none"},
    {Preconditioner::block_jacobi, "block-jacobi"},
    {Preconditioner::line_solves, "line-solves"},
    {Preconditioner::multigrid, "multigrid"},
    {Preconditioner::vcycle, "v-cycle"},
    {Preconditioner::automatic, "automatic"},
}};

template <class Table, class Enum>
const char* name_of(const Table& table, Enum value) {
  for (const auto& [v, name] : table) {
    if (v == value) return name;
  }
  return "?";
}
template <class Table>
auto value_of(const Table& table, std::string_view text)
    -> std::optional<typename Table::value_type::first_type> {
  for (const auto& [v, name] : table) {
    if (text == name) return v;
  }
  return std::nullopt;
}
template <class Table>
std::vector<std::string> names_of(const Table& table) {
  std::vector<std::string> names;
  for (const auto& entry : table) names.emplace_back(entry.second);
  return names;
}

}  // namespace

const char* to_string(Formulation formulation) { return name_of(kFormulations, formulation); }
const char* to_string(GradientMode gradient) { return name_of(kGradientModes, gradient); }
const char* to_string(StepMethod method) { return name_of(kStepMethods, method); }
const char* to_string(Preconditioner preconditioner) {
  return name_of(kPreconditioners, preconditioner);
}
std::optional<StepMethod> step_method_from_string(std::string_view text) {
  return value_of(kStepMethods, text);
}
std::optional<Preconditioner> preconditioner_from_string(std::string_view text) {
  return value_of(kPreconditioners, text);
}
std::vector<std::string> step_method_names() { return names_of(kStepMethods); }
const char* to_string(ElementKernel kernel) { return name_of(kElementKernels, kernel); }
std::optional<ElementKernel> element_kernel_from_string(std::string_view text) {
  return value_of(kElementKernels, text);
}
std::vector<std::string> element_kernel_names() { return names_of(kElementKernels); }
std::vector<std::string> preconditioner_names() { return names_of(kPreconditioners); }

namespace {

std::string number_text(double value) {
  std::ostringstream text;
  text.precision(6);
  text << value;
  return text.str();
}

// The tilted tension plateau (kernels/tilted_plateau.hpp): R must leave the band's curves
// steeper than the line beyond EMT (R < p in both directions), and only the reference kernel
// of the potential formulation implements it.
void tilted_plateau_problems(const SimulationConfig& config, const SolverConfig& solver,
                             std::vector<ConfigProblem>& problems) {
  const double slope = config.fabric.tension_plateau_slope;
  const std::string key = "fabric.tension_plateau_slope";
  if (!(slope >= 0.0) || !std::isfinite(slope)) {
    problems.push_back({key, "", "got " + number_text(slope),
                        "expected a number >= 0 (0: the flat plateau of MODEL.md 4B)"});
    return;
  }
  if (slope == 0.0) return;
  for (const auto& [name, direction] :
       {std::pair{"warp", &config.fabric.warp}, std::pair{"weft", &config.fabric.weft}}) {
    const double p = 2.0 / direction->lt - 1.0;
    if (!(slope < p)) {
      problems.push_back(
          {key, "fabric." + std::string(name) + ".lt",
           "got " + number_text(slope) + ", not below the " + name +
               " loading exponent p = 2/LT - 1 = " + number_text(p) + " (LT = " +
               number_text(direction->lt) + ")",
           "expected 0 <= tension_plateau_slope < p, so that the band's curves stay steeper than "
           "the plateau's line beyond EMT"});
      return;
    }
  }
  if (solver.formulation == Formulation::violation) {
    problems.push_back({key, "solver.formulation",
                        "the tilted tension plateau is a return mapping of the potential "
                        "formulation; the violation formulation keeps MODEL.md's band",
                        "expected formulation = \"potential\", or tension_plateau_slope = 0"});
  } else if (solver.kernel == ElementKernel::vector) {
    problems.push_back({key, "solver.kernel",
                        "the vector element kernel implements the flat plateau of MODEL.md 4B "
                        "only",
                        "expected kernel = \"reference\" with tension_plateau_slope > 0, or "
                        "tension_plateau_slope = 0"});
  }
}

}  // namespace

std::vector<ConfigProblem> validate(const SimulationConfig& config) {
  std::vector<ConfigProblem> problems;
  const SolverConfig solver = resolved_solver(config.solver);
  const bool violation = solver.formulation == Formulation::violation;
  if (violation && solver.method == StepMethod::newton) {
    problems.push_back({"solver.method", "solver.formulation",
                        "Newton's method is implemented for the potential formulation only (the "
                        "violation formulation is a least-squares problem in positions and forces)",
                        "expected method = \"nonlinear-cg\" with formulation = \"violation\", or "
                        "formulation = \"potential\""});
  }
  if (violation && solver.preconditioner == Preconditioner::line_solves) {
    problems.push_back({"solver.preconditioner", "solver.formulation",
                        "the line-solve preconditioner is implemented for the potential "
                        "formulation only",
                        "expected preconditioner = \"block-jacobi\" or \"none\" with formulation "
                        "= \"violation\", or formulation = \"potential\""});
  }
  const bool newton_only = solver.preconditioner == Preconditioner::multigrid ||
                           solver.preconditioner == Preconditioner::vcycle;
  const std::string name = to_string(solver.preconditioner);
  if (newton_only && solver.method != StepMethod::newton && !violation) {
    problems.push_back({"solver.preconditioner", "solver.method",
                        "the " + name + " preconditioner preconditions Newton's inner linear PCG "
                        "(its coarse operator is built from the Newton model)",
                        "expected method = \"newton\" with preconditioner = \"" + name + "\", or "
                        "preconditioner = \"line-solves\" with nonlinear CG"});
  }
  if (violation && newton_only) {
    problems.push_back({"solver.preconditioner", "solver.formulation",
                        "the " + name + " preconditioner is implemented for the potential "
                        "formulation's Newton method only",
                        "expected preconditioner = \"block-jacobi\" or \"none\" with formulation "
                        "= \"violation\", or formulation = \"potential\" with method = "
                        "\"newton\""});
  }
  if (solver.preconditioner == Preconditioner::multigrid && config.cloth.particles_i < 3 &&
      config.cloth.particles_j < 3) {
    problems.push_back({"solver.preconditioner", "cloth.particles",
                        "a multigrid needs a coarse grid, and a cloth of fewer than 3 particles "
                        "along both directions has none",
                        "expected at least 3 particles along one direction, or preconditioner = "
                        "\"line-solves\""});
  }
  if (violation && solver.kernel == ElementKernel::vector) {
    problems.push_back({"solver.kernel", "solver.formulation",
                        "the vector element kernel is implemented for the potential formulation "
                        "only",
                        "expected kernel = \"reference\" with formulation = \"violation\", or "
                        "formulation = \"potential\""});
  }
  if (solver.smoothing_sweeps > 0 && solver.method != StepMethod::newton) {
    problems.push_back({"solver.smoothing_sweeps", "solver.method",
                        "the nonlinear smoothing runs after each of Newton's line searches",
                        "expected method = \"newton\" with smoothing_sweeps > 0, or "
                        "smoothing_sweeps = 0"});
  }
  if (solver.model_refinements > 0 && solver.method != StepMethod::newton) {
    problems.push_back({"solver.model_refinements", "solver.method",
                        "the model is refined along each of Newton's directions",
                        "expected method = \"newton\" with model_refinements > 0, or "
                        "model_refinements = 0"});
  }
  if (violation && solver.gradient == GradientMode::numeric && config.amrc.enabled) {
    problems.push_back({"solver.gradient", "amrc.enabled",
                        "the numeric gradient of the violation formulation is not available with "
                        "[amrc] enabled = true (ghost particles)",
                        "expected gradient = \"analytic\", formulation = \"potential\" or AMRC off"});
  }
  tilted_plateau_problems(config, solver, problems);
  return problems;
}

}  // namespace clothbench::kernels
