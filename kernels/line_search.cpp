// Strong-Wolfe line search with cubic interpolation that only accepts a decrease (see header).
#include "kernels/line_search.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace clothbench::kernels {

namespace {

/// Minimiser of the cubic through (a, fa, da) and (b, fb, db), or NaN if it has none.
double cubic_minimiser(double a, double fa, double da, double b, double fb, double db) {
  const double d1 = da + db - 3.0 * (fa - fb) / (a - b);
  const double disc = d1 * d1 - da * db;
  if (!(disc >= 0.0)) return std::numeric_limits<double>::quiet_NaN();
  const double d2 = std::copysign(std::sqrt(disc), b - a);
  return b - (b - a) * (db + d2 - d1) / (db - da + 2.0 * d2);
}

}  // namespace

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

}  // namespace clothbench::kernels
