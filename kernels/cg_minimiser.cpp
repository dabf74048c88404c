// Polak-Ribiere+ nonlinear CG with a safeguarded strong-Wolfe line search (see header).
#include "kernels/cg_minimiser.hpp"

#include <cmath>
#include <limits>

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

namespace {

/// Minimiser of the cubic through (a, fa, da) and (b, fb, db), or NaN if it has none.
double cubic_minimiser(double a, double fa, double da, double b, double fb, double db) {
  const double d1 = da + db - 3.0 * (fa - fb) / (a - b);
  const double disc = d1 * d1 - da * db;
  if (!(disc >= 0.0)) return std::numeric_limits<double>::quiet_NaN();
  const double d2 = std::copysign(std::sqrt(disc), b - a);
  return b - (b - a) * (db + d2 - d1) / (db - da + 2.0 * d2);
}

struct LineSearchResult {
  bool accepted = false;
  double alpha = 0.0;
  double end_alpha = 0.0;  ///< step length the unknowns are left at
  Evaluation at;
  int evaluations = 0;
};

/// Strong-Wolfe search along the current direction from the base point (value phi0, slope0 < 0).
/// Accepts only points with value < phi0. Leaves the unknowns and gradient at the accepted point.
LineSearchResult line_search(StepObjective& objective, LoopRunner& run,
                             const MinimiserSettings& settings, double phi0, double slope0,
                             double alpha) {
  LineSearchResult result;
  double lo = 0.0, f_lo = phi0, d_lo = slope0;
  double hi = std::numeric_limits<double>::infinity(), f_hi = 0.0, d_hi = 0.0;
  double best_alpha = 0.0, best_value = phi0, last_alpha = -1.0;
  double at = 0.0;  // current step length from the base point
  auto go_to = [&](double target) {
    objective.move(run, target - at);
    at = target;
  };
  Evaluation best;
  for (int k = 0; k < settings.max_line_search; ++k) {
    go_to(alpha);
    const Evaluation e = objective.evaluate(run);
    ++result.evaluations;
    last_alpha = alpha;
    const bool finite = std::isfinite(e.value) && std::isfinite(e.slope);
    if (finite && e.value < best_value) {
      best_value = e.value;
      best_alpha = alpha;
      best = e;
    }
    if (!finite || e.value > phi0 + settings.armijo * alpha * slope0 || e.value >= f_lo) {
      hi = alpha;
      f_hi = finite ? e.value : std::numeric_limits<double>::infinity();
      d_hi = finite ? e.slope : 0.0;
    } else {
      if (std::abs(e.slope) <= -settings.curvature * slope0) {
        result.accepted = true;
        result.alpha = result.end_alpha = alpha;
        result.at = e;
        return result;
      }
      if (e.slope * (hi - lo) >= 0.0) {  // the minimum lies between alpha and lo
        hi = lo;
        f_hi = f_lo;
        d_hi = d_lo;
      }
      lo = alpha;
      f_lo = e.value;
      d_lo = e.slope;
    }
    // Next trial: extrapolate while unbracketed, else interpolate inside the bracket.
    if (std::isinf(hi)) {
      double next = 4.0 * lo;
      if (d_lo > slope0) next = std::min(next, lo * slope0 / (slope0 - d_lo));  // secant
      alpha = std::max(next, 1.5 * lo);
    } else {
      const double left = std::min(lo, hi), right = std::max(lo, hi), width = right - left;
      double next = std::isfinite(f_hi) ? cubic_minimiser(lo, f_lo, d_lo, hi, f_hi, d_hi)
                                        : std::numeric_limits<double>::quiet_NaN();
      if (!(next > left + 0.1 * width && next < right - 0.1 * width)) next = 0.5 * (lo + hi);
      alpha = next;
      if (width <= 1e-14 * right) break;
    }
  }
  if (best_alpha > 0.0) {
    if (last_alpha != best_alpha) {
      go_to(best_alpha);
      best = objective.evaluate(run);
      ++result.evaluations;
    }
    result.accepted = true;
    result.alpha = best_alpha;
    result.at = best;
  }
  result.end_alpha = at;
  return result;
}

}  // namespace

MinimiserReport minimise_step(StepObjective& objective, LoopRunner& run,
                              const MinimiserSettings& settings, double& first_alpha,
                              bool (*stop_requested)(void*), void* stop_state) {
  MinimiserReport report;
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
