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
