// Everything the kernel needs to set up and run one simulation, in SI units.
// Plain data: the harness fills it from a scene file; the kernel validates nothing here
// that the scene loader has not already checked (see harness/scene).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "kernels/kes_parameters.hpp"

namespace clothbench::kernels {

/// Which minimisation problem one implicit step solves (MODEL.md section 4).
enum class Formulation {
  potential,  ///< positions only; forces by return mapping; incremental potential (default)
  violation,  ///< the paper's: positions and forces as unknowns, E = Cn En + Cs Es + Cb Eb
};

/// How the gradient of the step cost is computed (MODEL.md section 5).
enum class GradientMode {
  analytic,  ///< exact chain rule (fast path)
  numeric,   ///< central differences of each unknown's local cost, as the paper did
};

/// Which code evaluates the element loops of the potential formulation's gradient (issue 16).
enum class ElementKernel {
  reference,  ///< the scalar code of potential_elements.hpp (the frozen reference twin)
  vector,     ///< SIMD lanes per tile (kernels/vector/element_lanes.hpp), ISA chosen at run time
};

/// How one implicit step is minimised (MODEL.md section 5).
enum class StepMethod {
  nonlinear_cg,  ///< Polak-Ribiere+ nonlinear CG (the paper's Algorithm-I)
  newton,        ///< truncated Newton: inner linear PCG on the model Hessian (potential only)
  automatic,     ///< the formulation's own: Newton (potential), nonlinear CG (violation)
};

/// The preconditioner of the step's CG: of nonlinear CG, or of Newton's inner linear PCG.
enum class Preconditioner {
  none,          ///< positions in units of the finest spacing (P^-1 = h^2 I)
  block_jacobi,  ///< per-particle 3x3 blocks of the model stiffness
  line_solves,   ///< block-tridiagonal solves along the grid lines (potential formulation)
  multigrid,     ///< line-solve smoothing and a Galerkin coarse grid (Newton's inner PCG only)
  vcycle,        ///< V-cycle on the AMRC tree, line Gauss-Seidel smoother (Newton's inner PCG only)
  automatic,     ///< the method's own: the V-cycle under Newton, block Jacobi under nonlinear CG
};

/// The one string form of each choice ("nonlinear-cg", "newton", "automatic"; "none",
/// "block-jacobi", "line-solves", "multigrid", "v-cycle", "automatic"), used by scene files, the
/// CLI and every output; from_string returns nullopt for any other text.
const char* to_string(Formulation formulation);
const char* to_string(GradientMode gradient);
const char* to_string(StepMethod method);
const char* to_string(ElementKernel kernel);
std::optional<ElementKernel> element_kernel_from_string(std::string_view text);
std::vector<std::string> element_kernel_names();
const char* to_string(Preconditioner preconditioner);
std::optional<StepMethod> step_method_from_string(std::string_view text);
std::optional<Preconditioner> preconditioner_from_string(std::string_view text);
/// Every accepted string of the choice, in declaration order.
std::vector<std::string> step_method_names();
std::vector<std::string> preconditioner_names();

/// Analytic obstacle kinds with signed distance and normal.
enum class ObstacleKind { plane, box, sphere, cylinder };

/// One rigid obstacle. Which fields matter depends on `kind`:
/// plane: `center` (a point on it) and `normal`; box: `center`, `half_extents` (axis aligned);
/// sphere: `center`, `radius`; cylinder: `center`, `axis` (unit), `radius`, `half_length`
/// (capped at both ends).
struct ObstacleConfig {
  ObstacleKind kind = ObstacleKind::plane;
  Eigen::Vector3d center = Eigen::Vector3d::Zero();  ///< m
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< plane normal (unit)
  Eigen::Vector3d half_extents = Eigen::Vector3d::Constant(0.1);  ///< m
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  ///< cylinder axis (unit)
  double radius = 0.1;       ///< m
  double half_length = 0.1;  ///< m
};

/// The cloth sheet: an I x J particle grid, initially flat in the plane spanned by
/// `axis_i` and `axis_j` through `origin` (particle (0,0)). MODEL.md section 1.
struct ClothConfig {
  int particles_i = 101;  ///< I, particles along the warp
  int particles_j = 101;  ///< J, particles along the weft
  double size_i = 1.0;    ///< W, m
  double size_j = 1.0;    ///< H, m
  Eigen::Vector3d origin = Eigen::Vector3d(-0.5, -0.5, 0.0);  ///< m
  Eigen::Vector3d axis_i = Eigen::Vector3d::UnitX();
  Eigen::Vector3d axis_j = Eigen::Vector3d::UnitY();
  int block_size = 50;  ///< B: storage block edge, particles (paper Fig. 7)
  /// Pinned particles as (i, j) grid coordinates; they never move.
  std::vector<std::pair<int, int>> pinned;
  /// Initial strain applied uniformly in the plane (0.2 = 20 % stretched).
  double initial_stretch = 0.0;
  /// Amplitude (m) of a reproducible random out-of-plane perturbation; 0 = flat.
  double initial_crumple = 0.0;
  unsigned initial_seed = 1;
};

/// Time integration of MODEL.md section 4: x~ = x^n + keep (x^n - x^(n-1)). Damping is a rate
/// (MODEL.md 5): a (sub-)step of length h keeps (1 - damping)^(h / step) of the velocity, so a
/// step redone as two halves is damped as much as the whole step.
struct TimeConfig {
  double step = 0.01;     ///< dt, s: the scene's step (sub-steps of a halved step are shorter)
  double damping = 0.0;   ///< c_damp in [0, 1): velocity lost per step of length `step`
  Eigen::Vector3d gravity = Eigen::Vector3d(0.0, 0.0, -9.80665);  ///< m / s^2
};

/// Contact with obstacles: active within `distance` of a surface.
struct ContactConfig {
  double distance = 0.002;  ///< d, m (also the layer the interpolated surface must keep)
  /// Penalty stiffness as a multiple of the particle's weight per contact distance:
  /// k_i = stiffness * m_i |g| / d.
  double stiffness = 1.0e4;
  /// Per-tile broad phase: a tile whose particles are all farther than `distance` from an
  /// obstacle skips that obstacle's signed distance (exact: the same bits either way).
  bool broad_phase = true;
};

/// Sweeps of the nonlinear smoothing under Newton unless a scene says otherwise: on the 40-step
/// stress drape they cut Newton iterations 5x at 65^2 and 7x at 129^2 (MODEL-NOTES.md, Newton,
/// "Nonlinear smoothing").
inline constexpr int kDefaultSmoothingSweeps = 3;
/// Newton: how often a direction is solved again after the model reached along it (the
/// default under Newton; see SolverConfig::model_refinements).
inline constexpr int kDefaultModelRefinements = 1;
/// V-cycle: block-Jacobi PCG iterations a step's solves try before the V-cycle is built for
/// the rest of the step (SolverConfig::vcycle_after).
inline constexpr int kDefaultVcycleAfter = 4;

/// Minimisation of one step (MODEL.md section 5).
struct SolverConfig {
  Formulation formulation = Formulation::potential;
  GradientMode gradient = GradientMode::analytic;
  /// The element loops' code (potential formulation, analytic gradient); same model, results
  /// within the stated tolerance of each other (tests/kernels/unit_vector_elements.cpp).
  ElementKernel kernel = ElementKernel::reference;
  /// Automatic (the default): Newton with the V-cycle for the potential formulation, nonlinear
  /// CG with block Jacobi for the violation formulation (resolved_solver). Nonlinear CG with
  /// block Jacobi is the paper's own setting. Line solves: exact block-tridiagonal solves along
  /// the grid lines of both directions (potential formulation only; line_preconditioner.hpp).
  StepMethod method = StepMethod::automatic;
  Preconditioner preconditioner = Preconditioner::automatic;
  /// Stop when the RMS normalised residual sqrt(En / particles) is below this.
  double tolerance = 1.0e-3;
  /// Nonlinear CG: iterations per step.
  int max_iterations = 200;
  /// Newton: Newton iterations per step, and linear PCG iterations per Newton iteration.
  int max_newton_iterations = 100;
  int max_linear_iterations = 300;
  /// Newton: sweeps of nonlinear block Gauss-Seidel after each line search (0: none; -1:
  /// kDefaultSmoothingSweeps under Newton, none under nonlinear CG; see
  /// effective_smoothing_sweeps), and the normalised residual, as a multiple of `tolerance`,
  /// from which a particle is relaxed.
  int smoothing_sweeps = -1;
  double smoothing_threshold = 1.0;
  /// Newton: after each direction p is solved, the model is assembled again reaching along p
  /// itself and the direction solved again, this many times (0: none; -1:
  /// kDefaultModelRefinements under Newton, none under nonlinear CG).
  int model_refinements = -1;
  /// V-cycle: a level with at most this many nodes is solved directly (sparse LDL^T).
  std::int64_t coarsest_nodes = 64;
  /// V-cycle: each step's inner solves start with block Jacobi (the model's 3x3 blocks,
  /// assembled anyway); a solve that has not met its forcing term after this many PCG
  /// iterations builds the V-cycle and continues from where it is, and the step's later
  /// solves use the V-cycle from their start. A step the blocks solve (a falling sheet:
  /// inertia dominates) then never builds the hierarchy. 0: the V-cycle from every step's
  /// first solve.
  int vcycle_after = kDefaultVcycleAfter;
  /// Numeric gradient step in scaled units (fraction of the spacing / force reference).
  double numeric_step = 1.0e-6;
  /// Violation formulation weights E = Cn En + Cs Es + Cb Eb + Cc Ec.
  double weight_newton = 1.0;
  double weight_stretch = 1.0;
  double weight_bend = 1.0;
  double weight_contact = 1.0;
  /// s_ref of Es as a multiple of Fm (MODEL.md 4A); 0 selects m g / h per unit width.
  double stretch_reference_fm = 1.0e-3;
  /// A step whose final RMS residual (in units of the weight) exceeds this is rejected and
  /// redone as two steps of half the length, down to dt / 2^max_step_halvings.
  double reject_residual = 0.1;
  int max_step_halvings = 6;
  /// Record the objective after every CG iteration in StepReport (tests and studies).
  bool record_values = false;
  /// Newton: record every iteration (forcing, inner solve, line search, smoothing) in
  /// StepReport::minimiser.newton_log (`clothbench run --newton-log`). Results are unchanged.
  bool log_iterations = false;
  /// Wall-clock budget for the minimisation of the whole run, s (0 = none; the paper's
  /// time-budget mode). What is left is shared evenly by the steps still planned
  /// (Simulation::set_planned_steps); a step whose share runs out stops its CG there and is
  /// accepted if finite. Results then depend on the machine's speed: bit-identity across
  /// schedulers and thread counts is not expected with a budget.
  double time_budget = 0.0;
};

/// The method a solver configuration runs (automatic resolved by the formulation).
inline StepMethod resolved_method(const SolverConfig& solver) {
  if (solver.method != StepMethod::automatic) return solver.method;
  return solver.formulation == Formulation::violation ? StepMethod::nonlinear_cg
                                                      : StepMethod::newton;
}

/// The preconditioner a solver configuration runs (automatic resolved by the method).
inline Preconditioner resolved_preconditioner(const SolverConfig& solver) {
  if (solver.preconditioner != Preconditioner::automatic) return solver.preconditioner;
  return resolved_method(solver) == StepMethod::newton ? Preconditioner::vcycle
                                                       : Preconditioner::block_jacobi;
}

/// The configuration with its automatic choices resolved: what a Simulation runs and reports.
inline SolverConfig resolved_solver(SolverConfig solver) {
  solver.method = resolved_method(solver);
  solver.preconditioner = resolved_preconditioner(solver);
  return solver;
}

/// The sweeps of nonlinear smoothing a solver configuration runs (the automatic -1 resolved).
inline int effective_smoothing_sweeps(const SolverConfig& solver) {
  if (solver.smoothing_sweeps >= 0) return solver.smoothing_sweeps;
  return resolved_method(solver) == StepMethod::newton ? kDefaultSmoothingSweeps : 0;
}

/// The model refinements per Newton direction a solver configuration runs (-1 resolved).
inline int effective_model_refinements(const SolverConfig& solver) {
  if (solver.model_refinements >= 0) return solver.model_refinements;
  return resolved_method(solver) == StepMethod::newton ? kDefaultModelRefinements : 0;
}

/// Adaptive mesh refinement and coarsening (MODEL.md section 6); parsed now, used by AMRC.
struct AmrcConfig {
  bool enabled = false;
  int levels = 0;          ///< L: the coarsest level keeps every 2^L-th grid line
  int check_every = 3;     ///< steps between criterion checks (paper: 3)
  double refine_threshold = 0.2;   ///< refine where a triple's turning angle (rad) exceeds it
  double coarsen_threshold = 0.05; ///< coarsen where all turning angles stay below it
};

/// What a scripted scene event does (MODEL.md section 8).
enum class SceneEventKind {
  move_obstacle,  ///< translate an obstacle: once by `displacement`, per step by `velocity` dt
  release_pin,    ///< the pinned particle becomes free (at rest where it is)
  force,          ///< a constant external force on one particle (the haptic pull)
};

/// One scripted event, applied before step `step` (1-based) is simulated. Events that last
/// (a force, a move with a velocity) act on every step from `step` to `until_step` inclusive.
struct SceneEvent {
  SceneEventKind kind = SceneEventKind::force;
  int step = 1;        ///< first step it acts on
  int until_step = 1;  ///< last step it acts on (>= step; = step for one-off events)
  int obstacle = 0;    ///< move_obstacle: index into SimulationConfig::obstacles
  int particle_i = 0;  ///< release_pin, force: grid coordinates of the particle
  int particle_j = 0;
  Eigen::Vector3d displacement = Eigen::Vector3d::Zero();  ///< m, move_obstacle, once at `step`
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< m/s, move_obstacle, each step: v dt
  Eigen::Vector3d force = Eigen::Vector3d::Zero();     ///< N, force
};

/// One problem of a configuration that the kernel cannot run: the setting's key as a scene
/// file spells it ("solver.preconditioner") and what is wrong and expected.
struct ConfigProblem {
  std::string key;        ///< the setting to point at, "section.key"
  std::string other_key;  ///< the setting it conflicts with, pointed at when `key` is a default
  std::string problem;
  std::string expected;
};

/// One simulation: cloth, fabric, obstacles, time step, contact, solver, AMRC, events.
struct SimulationConfig {
  ClothConfig cloth;
  KesParameters fabric;
  std::string fabric_name = "custom";
  std::vector<ObstacleConfig> obstacles;
  TimeConfig time;
  ContactConfig contact;
  SolverConfig solver;
  AmrcConfig amrc;
  std::vector<SceneEvent> events;  ///< in file order; several may act on one step
};

/// The combinations of settings the kernel cannot run (the scene loader maps each key to its
/// file position; Simulation's constructor throws std::invalid_argument for the first).
/// Checked in one place: solver method and preconditioner against the formulation.
std::vector<ConfigProblem> validate(const SimulationConfig& config);

}  // namespace clothbench::kernels
