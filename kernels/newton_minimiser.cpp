// Truncated Newton with an Eisenstat-Walker forcing term (see header).
#include "kernels/newton_minimiser.hpp"

#include <algorithm>
#include <cmath>

#include "kernels/line_search.hpp"

namespace clothbench::kernels {

MinimiserReport newton_minimise_step(PotentialObjective& objective, LoopRunner& run,
                                     const NewtonSettings& settings, double dt,
                                     bool (*stop_requested)(void*), void* stop_state) {
  MinimiserReport report;
  run.set_iteration(0);
  objective.set_step_length(dt);
  objective.begin_step(run);  // initial guess; assembles the model there
  Evaluation current = objective.evaluate(run);
  report.evaluations = 1;
  report.initial = current;
  if (settings.record_values) report.values.push_back(current.value);
  if (settings.log_iterations) objective.edge_census(run, false);  // the branches it starts on
  MinimiserSettings search;
  search.max_line_search = settings.max_line_search;
  search.armijo = settings.armijo;
  search.curvature = settings.curvature;
  // Weighted residual norms |g|_W = sqrt(cost); the outer test is sqrt(cost / N) <= tolerance.
  double previous_norm = 0.0, forcing = settings.forcing_max;
  bool assembled = true;
  // Whether the last line search took the full step (or more): the model no longer crosses the
  // band's kinks, and bending's floor along the turning vector only slows it (model_hessian.hpp).
  bool full_step = false;
  while (true) {
    run.set_iteration(static_cast<int>(report.iterations));  // the trace's iteration
    if (MinimiserReport::rms(current) <= settings.tolerance) {
      report.reason = StopReason::converged;
      break;
    }
    if (report.iterations >= settings.max_newton_iterations) {
      report.reason = StopReason::iteration_cap;
      break;
    }
    if (stop_requested != nullptr && stop_requested(stop_state)) {
      report.reason = StopReason::time_budget;
      break;
    }
    const bool floor_along = !(settings.release_bending_floor && full_step);
    if (!assembled) objective.assemble_newton(run, /*new_step=*/false, floor_along);
    assembled = false;
    const double norm = std::sqrt(current.cost);
    const double rms_start = MinimiserReport::rms(current);
    if (report.iterations > 0) {
      // Eisenstat-Walker choice 2 with its safeguard against a sudden drop of the forcing term.
      const double ratio = norm / previous_norm;
      double next = settings.forcing_gamma * ratio * ratio;
      const double from_previous = settings.forcing_gamma * forcing * forcing;
      if (from_previous > 0.1) next = std::max(next, from_previous);
      forcing = std::min(settings.forcing_max, next);
    }
    // No need to solve far below what the outer test asks: half its residual at most.
    const double needed =
        0.5 * settings.tolerance * std::sqrt(static_cast<double>(current.free_particles)) / norm;
    forcing = std::min(settings.forcing_max, std::max(forcing, needed));
    LinearSolveReport linear;
    int linear_this_iteration = 0, refinements_done = 0;
    const auto solve = [&] {
      linear = objective.solve_newton_direction(run, forcing, settings.max_linear_iterations);
      report.linear_iterations += linear.iterations;
      linear_this_iteration += linear.iterations;
      if (!linear.positive) ++report.restarts;
    };
    solve();
    // The model reached along the previous direction; one that reaches along this one sees the
    // kinks this step would cross (an edge pulled out of slack, a triple straightened), and
    // its direction is the one searched.
    for (int r = 0; r < settings.model_refinements && linear.slope < 0.0; ++r) {
      objective.assemble_newton(run, /*new_step=*/false, floor_along);
      solve();
      ++refinements_done;
    }
    if (!(linear.slope < 0.0)) {
      report.reason = StopReason::no_descent;
      break;
    }
    const LineSearchResult ls =
        line_search(objective, run, search, current.value, linear.slope, 1.0);
    report.evaluations += ls.evaluations;
    if (!ls.accepted) {
      objective.move(run, -ls.end_alpha);
      current = objective.evaluate(run);
      ++report.evaluations;
      report.reason = StopReason::line_search_stalled;
      break;
    }
    previous_norm = norm;
    full_step = ls.alpha >= 1.0;
    current = ls.at;
    NewtonIterationRecord record;
    if (settings.log_iterations) {
      record.iteration = report.iterations;
      record.rms = rms_start;
      record.forcing = forcing;
      record.linear_iterations = linear_this_iteration;
      record.linear_relative_residual = linear.relative_residual;
      record.refinements = refinements_done;
      record.alpha = ls.alpha;
      record.line_search_evaluations = ls.evaluations;
      record.rms_line_search = MinimiserReport::rms(current);
    }
    if (settings.smoothing_sweeps > 0) {
      // Local nonlinear corrections the global model cannot make: an element past a kink of
      // its band (plateau wall, onset of tension) is relaxed particle by particle.
      const std::int64_t moved =
          objective.smooth(run, settings.smoothing_sweeps, settings.smoothing_threshold);
      report.smoothed += moved;
      record.smoothed = moved;
      if (moved > 0) {  // else the line search's evaluation still holds
        current = objective.evaluate(run);
        ++report.evaluations;
      }
    }
    if (settings.record_values) report.values.push_back(current.value);
    if (settings.log_iterations) {
      record.rms_after = MinimiserReport::rms(current);
      const EdgeCensus census = objective.edge_census(run, true);
      record.edges_slack = census.slack;
      record.edges_loading = census.loading;
      record.edges_plateau = census.plateau;
      record.edges_unloading = census.unloading;
      record.edges_changed = census.changed;
      report.newton_log.push_back(record);
    }
    ++report.iterations;
  }
  report.final = current;
  return report;
}

}  // namespace clothbench::kernels
