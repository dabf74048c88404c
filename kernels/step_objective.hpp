// The minimisation problem of one implicit step, as seen by the CG minimiser
// (MODEL.md sections 4-5). Two implementations: the `potential` and the `violation`
// formulation. Every member is called by every thread of the step's parallel region and
// returns the same value on every thread.
#pragma once

#include <omp.h>

#include <algorithm>
#include <cstdint>

#include "kernels/loop_runner.hpp"
#include "kernels/slot_pages.hpp"
#include "kernels/step_context.hpp"

namespace clothbench::kernels {

/// Scalars of one evaluation of the objective at the current unknowns.
struct Evaluation {
  double value = 0.0;           ///< objective minimised (Phi, or E for violation), J or 1
  double slope = 0.0;           ///< gradient . direction
  double grad_dot_z = 0.0;      ///< g . P^-1 g
  double grad_old_dot_z = 0.0;  ///< g_old . P^-1 g (Polak-Ribiere)
  double cost = 0.0;            ///< reported cost E (En for potential)
  double residual_sq = 0.0;     ///< En = sum |r_i|^2 / (m_i |g|)^2 over free particles
  double residual_max = 0.0;    ///< max |r_i| / (m_i |g|)
  std::int64_t free_particles = 0;  ///< particles that are unknowns
  /// Narrow-phase contact work of this evaluation's residual loop, in particle-obstacle pairs:
  /// tested (signed distances evaluated) and ruled out by the broad phase.
  std::int64_t contact_tested = 0;
  std::int64_t contact_skipped = 0;
};

/// Contact work summed over every evaluation of a simulation (pairs, as in Evaluation).
struct ContactWork {
  std::int64_t tested = 0;
  std::int64_t skipped = 0;
  std::int64_t evaluations = 0;
};

/// Per-tile sums of the particle gather loop.
struct GatherSums {
  double energy = 0.0;
  double residual_sq = 0.0;
  double residual_max = 0.0;
  double slope = 0.0;
  double grad_dot_z = 0.0;
  double grad_old_dot_z = 0.0;
  std::int64_t free_particles = 0;
  std::int64_t contact_tested = 0;
  std::int64_t contact_skipped = 0;
  GatherSums& operator+=(const GatherSums& o) {
    energy += o.energy;
    residual_sq += o.residual_sq;
    residual_max = std::max(residual_max, o.residual_max);
    slope += o.slope;
    grad_dot_z += o.grad_dot_z;
    grad_old_dot_z += o.grad_old_dot_z;
    free_particles += o.free_particles;
    contact_tested += o.contact_tested;
    contact_skipped += o.contact_skipped;
    return *this;
  }
};

/// One step's minimisation problem.
class StepObjective {
 public:
  virtual ~StepObjective() = default;
  /// Sets the initial guess of the step and builds the preconditioner.
  virtual void begin_step(LoopRunner& run) = 0;
  /// Rebuilds the preconditioner at the current unknowns.
  virtual void refresh_preconditioner(LoopRunner& run) = 0;
  /// For preconditioners that are not per particle (line solves): computes P^-1 g at the
  /// current point, whose gradient `e` was evaluated there, and replaces e's g . P^-1 g and
  /// g_old . P^-1 g. The minimiser calls it on every point it moves from and after every
  /// refresh. Block Jacobi computes both inside `evaluate`: nothing to do.
  virtual void precondition(LoopRunner& /*run*/, Evaluation& /*e*/) {}
  /// Value, gradient (stored) and the CG scalars at the current unknowns.
  virtual Evaluation evaluate(LoopRunner& run) = 0;
  /// direction = -P^-1 g + beta direction; gradient_old = g. Returns the new direction . g.
  virtual double update_direction(LoopRunner& run, double beta) = 0;
  /// unknowns += delta * direction (the minimiser keeps track of the step length).
  virtual void move(LoopRunner& run, double delta) = 0;
  /// Derives per-step constants from the element forces of the last completed step
  /// (the bending band's breakpoints). Called by begin_step and before stand-alone evaluations.
  virtual void prepare_history(LoopRunner& run) = 0;
  /// Stores the step's forces (the hysteresis state) and advances the position history.
  virtual void end_step(LoopRunner& run) = 0;

  /// Sets the length of the (sub-)step that begin_step, evaluate and end_step work with (s):
  /// the scene's step, or a fraction of it after a rejected step was halved. Every thread of
  /// the region calls it with the same value (one thread writes; the barrier publishes it).
  /// The configuration is never written during a step.
  void set_step_length(double dt) {
#pragma omp single
    context().step_length = dt;
  }
  [[nodiscard]] double step_length() { return context().dt(); }
  /// The references and the step length the objective works with.
  [[nodiscard]] virtual StepContext& context() = 0;

  /// Bytes the objective holds beyond ClothState (the model, the preconditioners' arrays),
  /// except a V-cycle's, which Simulation::memory_parts counts as a part of its own.
  [[nodiscard]] virtual std::size_t memory_bytes() const { return 0; }
  /// Hands back the pages of unused slots of the objective's own arrays (slot_pages.hpp)
  /// after an AMRC event; returns the bytes.
  virtual std::size_t release_unused(const SlotRuns& /*runs*/) { return 0; }
  /// After an AMRC event that changed the mesh, whether or not pages are handed back: what
  /// the objective keeps from step to step per element forgets the elements now inactive.
  virtual void mesh_changed() {}

  /// Contact work of every evaluation so far (written by thread 0 of each evaluation).
  [[nodiscard]] const ContactWork& contact_work() const { return contact_work_; }

 protected:
  /// Adds one evaluation's counts; called by every thread, counted once.
  void count_contact_work(const Evaluation& e) {
    if (omp_get_thread_num() != 0) return;
    contact_work_.tested += e.contact_tested;
    contact_work_.skipped += e.contact_skipped;
    ++contact_work_.evaluations;
  }

 private:
  ContactWork contact_work_;
};

}  // namespace clothbench::kernels
