// The line search both step minimisers share (MODEL.md section 5): strong Wolfe conditions,
// cubic interpolation inside the bracket, extrapolation until bracketed, and a decrease of
// the objective as the one condition every accepted point meets.
#pragma once

#include "kernels/cg_minimiser.hpp"
#include "kernels/step_objective.hpp"

namespace clothbench::kernels {

/// Outcome of one line search.
struct LineSearchResult {
  bool accepted = false;
  double alpha = 0.0;      ///< accepted step length
  double end_alpha = 0.0;  ///< step length the unknowns are left at
  Evaluation at;           ///< evaluation at the accepted point
  int evaluations = 0;
};

/// Searches along the objective's current direction from the base point (value phi0,
/// slope0 < 0), first trying `alpha`. Uses settings.armijo, settings.curvature and
/// settings.max_line_search. Accepts only points with value < phi0 and leaves the unknowns and
/// gradient at the accepted point; when nothing is accepted the unknowns are left at
/// `end_alpha` (the caller moves back).
LineSearchResult line_search(StepObjective& objective, LoopRunner& run,
                             const MinimiserSettings& settings, double phi0, double slope0,
                             double alpha);

}  // namespace clothbench::kernels
