// Polak-Ribiere+ nonlinear CG with a safeguarded strong-Wolfe line search (see header).
#include "kernels/cg_minimiser.hpp"

#include <cmath>

#include "kernels/line_search.hpp"

namespace clothbench::kernels {

const char* to_string(StopReason reason) {
  switch (reason) {
    case StopReason::converged:
      return "converged";
    case StopReason::iteration_cap:
      return "iteration cap";
    case StopReason::line_search_stalled:
      return "line search found no decrease";
    case StopReason::no_descent:
      return "no descent direction";
    case StopReason::time_budget:
      return "time budget";
  }
  return "?";
}

MinimiserReport minimise_step(StepObjective& objective, LoopRunner& run,
                              const MinimiserSettings& settings, double dt, double& first_alpha,
                              bool (*stop_requested)(void*), void* stop_state) {
  MinimiserReport report;
  run.set_iteration(0);
  objective.set_step_length(dt);
  objective.begin_step(run);
  Evaluation current = objective.evaluate(run);
  objective.precondition(run, current);
  report.evaluations = 1;
  report.initial = current;
  if (settings.record_values) report.values.push_back(current.value);
  bool restart = true;
  double previous_gz = current.grad_dot_z;
  double previous_alpha = first_alpha, previous_slope = 0.0;
  while (true) {
    run.set_iteration(static_cast<int>(report.iterations));  // the trace's iteration
    if (MinimiserReport::rms(current) <= settings.tolerance) {
      report.reason = StopReason::converged;
      break;
    }
    if (report.iterations >= settings.max_iterations) {
      report.reason = StopReason::iteration_cap;
      break;
    }
    if (stop_requested != nullptr && stop_requested(stop_state)) {
      report.reason = StopReason::time_budget;
      break;
    }
    if (settings.refresh_every > 0 && report.iterations > 0 &&
        report.iterations % settings.refresh_every == 0) {
      objective.refresh_preconditioner(run);
      objective.precondition(run, current);
      restart = true;  // the metric changed: old directions are no longer conjugate
    }
    const double beta =
        restart || previous_gz <= 0.0
            ? 0.0
            : std::max(0.0, (current.grad_dot_z - current.grad_old_dot_z) / previous_gz);
    double slope = objective.update_direction(run, beta);
    if (!(slope < 0.0) && beta != 0.0) {
      slope = objective.update_direction(run, 0.0);
      ++report.restarts;
    }
    if (!(slope < 0.0)) {
      report.reason = StopReason::no_descent;
      break;
    }
    previous_gz = current.grad_dot_z;
    // First trial: Nocedal-Wright's alpha_prev * slope_prev / slope inside a step,
    // the previous step's first accepted length at its start.
    double alpha = report.iterations == 0 || previous_slope >= 0.0
                       ? first_alpha
                       : previous_alpha * previous_slope / slope;
    if (!(alpha > 0.0) || !std::isfinite(alpha)) alpha = 1.0;
    const LineSearchResult ls =
        line_search(objective, run, settings, current.value, slope, alpha);
    report.evaluations += ls.evaluations;
    if (!ls.accepted) {
      // Back to the base point; its gradient must be recomputed (trials overwrote it).
      objective.move(run, -ls.end_alpha);
      current = objective.evaluate(run);
      objective.precondition(run, current);
      ++report.evaluations;
      if (restart) {
        report.reason = StopReason::line_search_stalled;
        break;
      }
      restart = true;
      ++report.restarts;
      continue;
    }
    if (report.iterations == 0) first_alpha = ls.alpha;
    previous_alpha = ls.alpha;
    previous_slope = slope;
    current = ls.at;
    objective.precondition(run, current);
    if (settings.record_values) report.values.push_back(current.value);
    restart = false;
    ++report.iterations;
  }
  report.final = current;
  return report;
}

}  // namespace clothbench::kernels
