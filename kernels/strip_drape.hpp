// A plane-strain strip of the paper's box drape, for screening ideas about the step solver's
// outer iteration (MODEL-NOTES, "Path-following on the band, tried on a strip and dropped").
//
// One grid line of particles in the x-z plane, 1 m long, each particle standing for a 1 m wide
// strip of cloth. The fabric's warp band and return mapping are the kernel's
// (kes_material.hpp). The strip falls from 2 cm above a 50 cm wide, 25 cm high box, with the
// scene's contact penalty. Each step minimises the same incremental potential as
// MODEL.md 4B with Newton's method, and each Newton system is solved exactly
// (sparse LDLT, one thread). What remains is the outer iteration of the kernel's solver:
// - the model Hessian (edge tangents, bending Gauss-Newton, contact k n n^T, inertia);
// - the model reaching along its last direction (secant, memory, bending M / kappa);
// - one model refinement;
// - the Armijo line search with the full step first;
// - the nonlinear smoothing sweeps.
// Optionally a path-following variant smooths the bands within the step, and two kinds of
// coarse correction move many particles at once (hat functions of every level, moved one at
// a time like the smoothing; Newton on a coarse subspace), and a tilted tension plateau (a
// model variant): MODEL-NOTES, "Coarse corrections and a tilted plateau, screened on the
// strip".
//
// It runs in seconds and its Newton counts per step follow the cloth's (the README's figures).
// It is not a scheduler workload: nothing here goes through the LoopRunner.
#pragma once

#include <Eigen/Core>
#include <cstdio>
#include <vector>

#include "kernels/kes_material.hpp"
#include "kernels/kes_parameters.hpp"

namespace clothbench::kernels {

/// Settings of a strip run. The defaults are the kernel's solver on paper/box-1001's fabric,
/// step and contact.
struct StripSettings {
  int particles = 257;          ///< along 1 m (>= 3)
  int steps = 100;              ///< steps of `step_s`
  double step_s = 0.004;        ///< time step, s
  double damping = 0.1;         ///< velocity lost per 4 ms, applied as a rate
  double tolerance = 1e-2;      ///< stop test: RMS of |residual| / (m |g|) over the particles
  int max_iterations = 1000;    ///< Newton iterations a step before the step counts as failed
  int smoothing_sweeps = 3;     ///< nonlinear smoothing after each line search (0 = none)
  int model_refinements = 1;    ///< models assembled again along their own direction
  bool reach = true;            ///< the model reaches along its last direction (with memory)
  double memory = 0.3;          ///< share of an element's previous model stiffness kept
  /// Multilevel subspace correction (0 = off): before the fine smoothing, each coarser
  /// level l = hat_levels .. 1 (hat functions 2^l particles wide, clamped to the strip's
  /// length) moves one hat at a time by a local Newton step with halving on the exact
  /// local energy, like the fine smoothing moves one particle.
  int hat_levels = 0;
  int hat_sweeps = 1;           ///< passes over the coarse levels per smoothing
  /// Two-level Newton (0 = off): after each fine iteration and its smoothing, up to this many
  /// Newton iterations on the coarse subspace x + P v (every coarse_factor-th particle,
  /// linear interpolation between; coarse_factor divides particles - 1): model P^T H P of
  /// the model without reach, Armijo on the fine potential, then the fine smoothing. They
  /// are counted apart from the fine Newton iterations (StripStep::coarse).
  int coarse_newton = 0;
  int coarse_factor = 2;
  /// A tilted tension plateau (0 = MODEL.md 4B's rule): the force is
  /// clamp(f_prev + E (eps - eps_prev), tU(eps), tL(eps)) with eps_prev the edge's strain at
  /// the end of the last step and E = inner_stiffness Fm / EMT (a model change screened here,
  /// not the contract). The bending band is left as it is. Not combined with path-following.
  double inner_stiffness = 0.0;
  /// Path-following on the band (0 = off): the plateau's jump and (for tension) a barrier
  /// on the force are smoothed with width mu, started at path_mu0, multiplied by
  /// path_shrink when the smoothed residual is path_sigma of the stage's first, and set to
  /// 0 below path_mu_min. The stop test is always on the exact law.
  double path_mu0 = 0.0;
  double path_shrink = 0.1;
  double path_sigma = 0.1;
  double path_mu_min = 1e-3;
  KesParameters fabric;         ///< the warp direction is used for edges and triples
};

/// One step of a strip run.
struct StripStep {
  int newton = 0;          ///< Newton iterations
  int evaluations = 0;     ///< potential evaluations in the line searches
  int coarse = 0;          ///< coarse-subspace Newton iterations (coarse_newton > 0)
  int hat_moves = 0;       ///< hat moves that lowered the energy (hat_levels > 0)
  double residual = 0.0;   ///< RMS normalised residual at the end of the step (exact law)
  bool converged = false;  ///< residual below the tolerance within max_iterations
};

/// What a strip run did.
struct StripResult {
  std::vector<StripStep> steps;
  long newton = 0;
  long evaluations = 0;
  long coarse = 0;
  long hat_moves = 0;
  bool all_converged = true;
  std::vector<Eigen::Vector2d> positions;  ///< final (x, z) of every particle, m
  double lowest_z = 0.0;                   ///< lowest particle at the end, m
  double deepest_penetration = 0.0;        ///< largest depth below the box's surface, m (>= 0)
};

/// Runs the strip. When `trace` is given, one CSV row per Newton iteration is written to it:
/// step, iteration, mu, residual (exact law), step length kept, edges changing branch.
StripResult run_strip(const StripSettings& settings, std::FILE* trace = nullptr);

/// An element law of a strip run: force (N/m or N), its slope and its potential.
struct StripLaw {
  double force = 0.0;
  double slope = 0.0;
  double potential = 0.0;
};

/// The tension law after the return mapping with previous force `previous`. mu = 0 is
/// return_map exactly. mu > 0: the plateau is a logistic step in the compliance of width
/// mu max(previous, 1e-3 Fm), and a barrier -b/f (b = mu 1e-6 Fm) keeps the force positive.
StripLaw strip_tension_law(const TensileBand& band, double previous, double eps, double mu);
/// The bending law likewise (the plateau smoothed with width mu max(previous, HB); no
/// barrier: a moment at zero curvature would put a kink in the unsigned turning angle).
StripLaw strip_bending_law(const BendingBand& band, double previous, double kappa, double mu);
/// The tilted plateau's tension law (StripSettings::inner_stiffness):
/// clamp(previous + stiffness (eps - previous_strain), tU(eps), tL(eps)) for eps > 0, else 0,
/// with its potential (integral from 0). Built per call here; a run builds it once a step.
StripLaw strip_tilted_tension_law(const TensileBand& band, double previous,
                                  double previous_strain, double stiffness, double eps);

}  // namespace clothbench::kernels
