// Nonlinear conjugate gradient (Polak-Ribiere+, preconditioned, restart on loss of descent)
// with a strong-Wolfe line search that only ever accepts a decrease (MODEL.md section 5,
// paper Algorithm-I). Runs on every thread of the step's parallel region; all decisions
// depend only on reduced scalars, which are bit-identical on every thread.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "kernels/step_objective.hpp"

namespace clothbench::kernels {

/// Why a step's minimisation stopped.
enum class StopReason { converged, iteration_cap, line_search_stalled, no_descent, time_budget };
const char* to_string(StopReason reason);

/// Settings of one minimisation.
struct MinimiserSettings {
  double tolerance = 1e-3;      ///< stop when sqrt(cost / free particles) <= tolerance
  int max_iterations = 200;
  int max_line_search = 20;     ///< evaluations per line search
  int refresh_every = 10;       ///< rebuild the preconditioner every k iterations (0 = never)
  double armijo = 1e-4;         ///< c1
  double curvature = 0.4;       ///< c2 (strong Wolfe)
  bool record_values = false;   ///< keep the objective value after every iteration
};

/// Outcome of one step's minimisation.
/// One Newton iteration as the solver saw it (MinimiserReport::newton_log, recorded when
/// SolverConfig::log_iterations is set; `clothbench run --newton-log`). Residuals are RMS
/// normalised residuals (MinimiserReport::rms).
struct NewtonIterationRecord {
  int attempt = 0;          ///< the step's (sub-)step attempt, 0-based in the order they ran
  double dt = 0.0;          ///< that attempt's step length, s
  int iteration = 0;        ///< 0-based within the attempt
  double rms = 0.0;         ///< at the iterate the direction was solved from
  double forcing = 0.0;     ///< relative residual asked of the inner solve
  int linear_iterations = 0;         ///< PCG iterations, the model refinements' solves included
  double linear_relative_residual = 0.0;  ///< reached by the last of those solves
  int refinements = 0;      ///< solves done again after the model reached along the direction
  double alpha = 0.0;       ///< step length the line search accepted (1 = the full step)
  int line_search_evaluations = 0;
  double rms_line_search = 0.0;  ///< after the line search
  std::int64_t smoothed = 0;     ///< particle moves of the nonlinear smoothing that followed
  double rms_after = 0.0;        ///< after the smoothing: where the next iteration starts
  /// The active edges by branch where the iteration ends (PotentialObjective::edge_census:
  /// slack, loading curve, plateau, unloading curve), and how many changed branch in it.
  std::int64_t edges_slack = 0, edges_loading = 0, edges_plateau = 0, edges_unloading = 0;
  std::int64_t edges_changed = 0;
};

struct MinimiserReport {
  int iterations = 0;         ///< nonlinear CG iterations, or Newton iterations
  int linear_iterations = 0;  ///< Newton only: inner PCG iterations (products with H), summed
  int evaluations = 0;
  int restarts = 0;
  std::int64_t smoothed = 0;  ///< Newton only: particle moves of the nonlinear smoothing, summed
  StopReason reason = StopReason::iteration_cap;
  Evaluation initial;  ///< at the step's initial guess
  Evaluation final;    ///< at the accepted result
  std::vector<double> values;  ///< objective at the start and after each iteration (if recorded)
  std::vector<NewtonIterationRecord> newton_log;  ///< Newton only, if recorded: its iterations
  /// RMS normalised residual sqrt(cost / free particles) of an evaluation.
  static double rms(const Evaluation& e) {
    return e.free_particles > 0 ? std::sqrt(e.cost / static_cast<double>(e.free_particles)) : 0.0;
  }
};

/// Minimises one (sub-)step of length dt of the objective (begin_step, then CG; the caller
/// decides whether to accept the result with end_step or to reject it). `first_alpha` carries the first accepted step length from
/// step to step (in and out; every thread holds its own identical copy).
/// `stop_requested` (may be null) is polled after each iteration on every thread; it must
/// return the same answer on every thread (the caller broadcasts it).
MinimiserReport minimise_step(StepObjective& objective, LoopRunner& run,
                              const MinimiserSettings& settings, double dt, double& first_alpha,
                              bool (*stop_requested)(void*) = nullptr, void* stop_state = nullptr);

}  // namespace clothbench::kernels
