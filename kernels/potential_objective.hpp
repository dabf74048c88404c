// The `potential` formulation (MODEL.md 4B, the default): positions are the only unknowns,
// element forces follow by return mapping onto the KES bands, and one step minimises
// Phi(x) = sum m |x - x~|^2 / (2 dt^2) - sum (m g + f) . (x - x^n) + elastic potentials + contact
// (f: scripted external forces; loads are measured from x^n so that Phi stays small and its
// changes resolvable).
#pragma once

#include <atomic>
#include <memory>
#include <vector>

#include "kernels/line_preconditioner.hpp"
#include "kernels/multigrid_preconditioner.hpp"
#include "kernels/vcycle_preconditioner.hpp"
#include "kernels/newton_system.hpp"
#include "kernels/step_context.hpp"
#include "kernels/topology_key.hpp"
#include "kernels/step_objective.hpp"

namespace clothbench::kernels {

struct LocalTerms;

/// The active edges by the branch of their band's return mapping at the current positions
/// (MODEL.md 4B): slack (strain <= 0: no force), on the loading curve, on the plateau (the
/// previous force kept) or on the unloading curve; and how many changed branch since the
/// census before (PotentialObjective::edge_census).
struct EdgeCensus {
  std::int64_t slack = 0, loading = 0, plateau = 0, unloading = 0, changed = 0;
  EdgeCensus& operator+=(const EdgeCensus& o) {
    slack += o.slack;
    loading += o.loading;
    plateau += o.plateau;
    unloading += o.unloading;
    changed += o.changed;
    return *this;
  }
};

class PotentialObjective final : public StepObjective {
 public:
  explicit PotentialObjective(const StepContext& ctx);
  ~PotentialObjective() override;
  StepContext& context() override { return ctx_; }
  void begin_step(LoopRunner& run) override;
  void refresh_preconditioner(LoopRunner& run) override;
  /// Counts the active edges by branch and remembers each one's; with `compare`, also those
  /// whose branch differs from the last census (of this topology: a step's first census is
  /// taken without). Diagnostics of the Newton log (SolverConfig::log_iterations).
  EdgeCensus edge_census(LoopRunner& run, bool compare);
  void precondition(LoopRunner& run, Evaluation& e) override;
  Evaluation evaluate(LoopRunner& run) override;
  double update_direction(LoopRunner& run, double beta) override;
  void move(LoopRunner& run, double alpha) override;
  void end_step(LoopRunner& run) override;
  void prepare_history(LoopRunner& run) override;
  [[nodiscard]] std::size_t memory_bytes() const override {
    return (lines_ == nullptr ? 0 : lines_->memory_bytes() + line_z_.capacity() * sizeof(double)) +
           (newton_ == nullptr ? 0 : newton_->memory_bytes()) +
           (multigrid_ == nullptr ? 0 : multigrid_->memory_bytes());
  }
  std::size_t release_unused(const SlotRuns& runs) override {
    return newton_ == nullptr ? 0 : newton_->release_unused(runs);
  }
  void mesh_changed() override {
    if (newton_ != nullptr) newton_->hessian.forget_inactive(ctx_.mesh);
  }

  // --- Newton (StepMethod::newton; potential_newton.cpp) ---------------------------------
  /// Assembles the model Hessian and its preconditioner (block Jacobi, line solves on the
  /// model's blocks, or the multigrid over them) at the current positions;
  /// refresh_preconditioner calls it under Newton.
  /// `new_step`: the step's first assembly; `floor_along`: bending's floor along the turning
  /// vector too (ModelHessian::assemble).
  void assemble_newton(LoopRunner& run, bool new_step = false, bool floor_along = true);
  /// Solves H p = -g inexactly by linear PCG (g: the gradient of the last evaluate, H the
  /// model assembled last), stopping when the weighted residual norm
  /// sqrt(sum |r_i|^2 / (m_i |g|)^2) is <= forcing times that of g, or after max_iterations.
  /// p goes to state().direction; returns the solve's figures with slope = g . p.
  LinearSolveReport solve_newton_direction(LoopRunner& run, double forcing, int max_iterations);
  /// The model Hessian (null unless the method is Newton; tests).
  [[nodiscard]] ModelHessian* model_hessian() {
    return newton_ == nullptr ? nullptr : &newton_->hessian;
  }
  /// The line-solve preconditioner, or null when the scene uses block Jacobi (tests).
  [[nodiscard]] LinePreconditioner* line_preconditioner() { return lines_.get(); }
  /// The multigrid preconditioner, or null (tests).
  [[nodiscard]] MultigridPreconditioner* multigrid() { return multigrid_.get(); }
  /// The V-cycle preconditioner, or null (tests).
  [[nodiscard]] VcyclePreconditioner* vcycle() { return vcycle_.get(); }
  /// Whether the current step's solves use the V-cycle (block Jacobi until one needs it).
  [[nodiscard]] bool vcycle_in_use() const { return vcycle_on_.load(std::memory_order_relaxed); }
  /// Steps (sub-steps count) in which a solve needed the V-cycle.
  [[nodiscard]] std::int64_t vcycle_steps() const { return vcycle_steps_; }

  /// Colours the free particles for `smooth` (every thread calls it; one colours, greedy in
  /// slot order, so that no element touches two particles of one colour); again only when
  /// the active set or the pins changed (TopologyKey).
  void colour_for_smoothing(LoopRunner& run);
  /// Nonlinear block Gauss-Seidel (kernels/potential_smoothing.cpp): `sweeps` sweeps, colour by
  /// colour, in which a free particle whose normalised residual |g_i| / (m_i |g|) is at least
  /// `threshold` takes one Newton step on the terms of Phi that involve it, kept only if they
  /// decrease (so Phi does). The first sweep visits the particles whose residual at the last
  /// evaluation is large, later ones those a move touched. Every thread calls it; the caller
  /// evaluates afterwards. Returns the number of particles that moved.
  std::int64_t smooth(LoopRunner& run, int sweeps, double threshold);
  /// Each slot's smoothing colour (-1: not free) and the slots of every colour (tests).
  [[nodiscard]] const std::vector<std::int16_t>& smoothing_colours() const {
    return smoothing_colour_;
  }
  [[nodiscard]] std::size_t smoothing_colour_count() const { return smoothing_lists_.size(); }
  /// Per colour, the ghosts its sweep refreshes (those hanging on its slots).
  [[nodiscard]] const std::vector<std::vector<std::int64_t>>& smoothing_ghosts() const {
    return smoothing_ghosts_;
  }

 private:
  /// Phi restricted to the terms that involve particle s, with s moved to `xs`
  /// (the local cost the numeric gradient differentiates).
  /// `terms`: a memo of the element terms at the stored positions (only with xs equal to
  /// s's stored position), filled by local_gradient and diagonal_block.
  double local_energy(std::int64_t s, const Eigen::Vector3d& xs, LocalTerms* terms = nullptr) const;
  Eigen::Vector3d numeric_gradient(std::int64_t s) const;
  /// The gradient of Phi at particle s from the current positions (what evaluate computes
  /// for s, without the loops over every element).
  Eigen::Vector3d local_gradient(std::int64_t s, LocalTerms* terms = nullptr) const;
  /// The particle's own part of the gradient at xs: inertia, gravity and `contact` (evaluated
  /// at xs); the elements' part is gathered and a scripted force subtracted after it.
  Eigen::Vector3d own_gradient(std::int64_t s, const Eigen::Vector3d& xs,
                               const ContactPenalty& contact) const;
  /// 3x3 stiffness block of particle s (inertia, elements' tangent, contact with the
  /// obstacles in `mask`).
  Eigen::Matrix3d diagonal_block(std::int64_t s, ObstacleMask mask,
                                 LocalTerms* terms = nullptr) const;
  /// Tangent K_e of edge id (material slope along the edge, tension across it).
  Eigen::Matrix3d edge_tangent(std::int64_t id, LocalTerms* terms = nullptr) const;
  /// The edge and triple loops of evaluate() by the vector twin (ElementKernel::vector):
  /// each tile's elements in SIMD lanes, writing the same scratch slots and tile partials.
  void evaluate_elements_vector(LoopRunner& run);
  /// The particle loop of evaluate() by the vector twin (analytic gradient): per tile, the
  /// terms that stay scalar (contact with the obstacles `prepare` leaves in the tile's mask,
  /// scripted forces, ghost children), then the gather and the sums in SIMD lanes.
  template <class Prepare>
  void evaluate_particles_vector(LoopRunner& run, Prepare& prepare, LoopBytes bytes);

  StepContext ctx_;
  TilePartials<ScalarSum> edge_partials_;
  TilePartials<ScalarSum> triple_partials_;
  TilePartials<ScalarSum> scalar_partials_;
  TilePartials<EdgeCensus> census_partials_;
  std::vector<std::uint8_t> edge_branch_;  ///< per element id: the last census's branch
  TilePartials<GatherSums> gather_partials_;
  TilePartials<GatherSums> precondition_partials_;
  std::unique_ptr<LinePreconditioner> lines_;
  std::vector<double> line_z_;  ///< 3 per slot: P^-1 g at the current point (line solves)
  std::unique_ptr<NewtonSystem> newton_;
  std::unique_ptr<MultigridPreconditioner> multigrid_;  ///< Newton with preconditioner = multigrid
  std::unique_ptr<VcyclePreconditioner> vcycle_;        ///< Newton with preconditioner = v-cycle
  /// The V-cycle is in use for this step (SolverConfig::vcycle_after): cleared by begin_step,
  /// set by the solve that first needs it. Every thread stores the same value at the same
  /// point and reads it only after a barrier that follows every store.
  std::atomic<bool> vcycle_on_{false};
  std::int64_t vcycle_steps_ = 0;  ///< steps (and sub-steps) that built the V-cycle
  /// Nonlinear smoothing: each free slot's colour (-1 otherwise), the slots of each colour in
  /// slot order, and the sweep (1-based) in which a slot last moved (0: not in this call):
  /// 2 + 4 + 2 bytes a free slot (a footprint has a few dozen particles, so far fewer colours
  /// than int16; sweeps are at most the scene loader's 1,000).
  std::vector<std::int16_t> smoothing_colour_;
  std::vector<std::vector<std::int32_t>> smoothing_lists_;
  /// Per colour, the ghosts a move of its slots moves (hanging on them, directly or through
  /// other ghosts), each once, in slot order: all a colour's sweep has to refresh.
  std::vector<std::vector<std::int64_t>> smoothing_ghosts_;
  std::vector<std::uint16_t> smoothing_moved_;
  TopologyKey smoothing_topology_;  ///< the mesh the colouring was made for
};

}  // namespace clothbench::kernels
