// Truncated Newton minimisation of one step of the potential formulation (MODEL.md section 5):
// each Newton iteration solves H p = -g inexactly with linear PCG on the model Hessian
// (forcing term of Eisenstat and Walker, choice 2, safeguarded) and then searches along p with
// the decrease-only line search, trying the full step first. The same stopping test as
// nonlinear CG (RMS normalised residual <= tolerance). Runs on every thread of the step's
// region; every decision depends only on reduced scalars, identical on every thread.
#pragma once

#include "kernels/cg_minimiser.hpp"
#include "kernels/potential_objective.hpp"

namespace clothbench::kernels {

/// Settings of one Newton minimisation.
struct NewtonSettings {
  double tolerance = 1e-3;        ///< stop when sqrt(cost / free particles) <= tolerance
  int max_newton_iterations = 100;
  int max_linear_iterations = 300;  ///< PCG iterations per Newton iteration
  double forcing_max = 0.5;       ///< largest (first) relative residual asked of the inner solve
  double forcing_gamma = 0.9;     ///< Eisenstat-Walker choice 2: eta = gamma (|g_k| / |g_k-1|)^2
  int max_line_search = 20;
  double armijo = 1e-4;
  double curvature = 0.9;         ///< strong Wolfe c2: loose, the Newton step is well scaled
  bool record_values = false;
  bool log_iterations = false;    ///< fill MinimiserReport::newton_log
  /// Sweeps of nonlinear block Gauss-Seidel after each line search (PotentialObjective::smooth;
  /// 0: none), relaxing the particles whose normalised residual is at least the threshold.
  int smoothing_sweeps = 0;
  double smoothing_threshold = 1e-3;
  /// Times a direction p is solved again after the model was assembled anew reaching along p
  /// itself (PotentialObjective::assemble_newton), before the line search.
  int model_refinements = 0;
  /// After an iteration whose line search took the full step, the model drops bending's floor
  /// M / kappa along the turning vector (model_hessian.hpp); false keeps it always.
  bool release_bending_floor = true;
};

/// Minimises one (sub-)step of length dt (begin_step, then Newton). The report's `iterations`
/// are Newton iterations and `linear_iterations` the inner PCG iterations summed over them.
/// `stop_requested` as for minimise_step (polled after each Newton iteration).
MinimiserReport newton_minimise_step(PotentialObjective& objective, LoopRunner& run,
                                     const NewtonSettings& settings, double dt,
                                     bool (*stop_requested)(void*) = nullptr,
                                     void* stop_state = nullptr);

}  // namespace clothbench::kernels
