// The `potential` formulation (MODEL.md 4B, the default): positions are the only unknowns,
// element forces follow by return mapping onto the KES bands, and one step minimises
// Phi(x) = sum m |x - x~|^2 / (2 dt^2) - sum (m g + f) . (x - x^n) + elastic potentials + contact
// (f: scripted external forces; loads are measured from x^n so that Phi stays small and its
// changes resolvable).
#pragma once

#include <memory>
#include <vector>

#include "kernels/line_preconditioner.hpp"
#include "kernels/multigrid_preconditioner.hpp"
#include "kernels/newton_system.hpp"
#include "kernels/step_context.hpp"
#include "kernels/step_objective.hpp"

namespace clothbench::kernels {

class PotentialObjective final : public StepObjective {
 public:
  explicit PotentialObjective(const StepContext& ctx);
  ~PotentialObjective() override;
  StepContext& context() override { return ctx_; }
  void begin_step(LoopRunner& run) override;
  void refresh_preconditioner(LoopRunner& run) override;
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

  // --- Newton (StepMethod::newton; potential_newton.cpp) ---------------------------------
  /// Assembles the model Hessian and its preconditioner (block Jacobi, line solves on the
  /// model's blocks, or the multigrid over them) at the current positions;
  /// refresh_preconditioner calls it under Newton.
  void assemble_newton(LoopRunner& run);
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

 private:
  /// Phi restricted to the terms that involve particle s, with s moved to `xs`
  /// (the local cost the numeric gradient differentiates).
  double local_energy(std::int64_t s, const Eigen::Vector3d& xs) const;
  Eigen::Vector3d numeric_gradient(std::int64_t s) const;
  /// 3x3 stiffness block of particle s (inertia, elements' tangent, contact with the
  /// obstacles in `mask`).
  Eigen::Matrix3d diagonal_block(std::int64_t s, ObstacleMask mask) const;
  /// Tangent K_e of edge id (material slope along the edge, tension across it).
  Eigen::Matrix3d edge_tangent(std::int64_t id) const;
  /// The edge and triple loops of evaluate() by the vector twin (ElementKernel::vector):
  /// each tile's elements in SIMD lanes, writing the same scratch slots and tile partials.
  void evaluate_elements_vector(LoopRunner& run);

  StepContext ctx_;
  TilePartials<ScalarSum> edge_partials_;
  TilePartials<ScalarSum> triple_partials_;
  TilePartials<ScalarSum> scalar_partials_;
  TilePartials<GatherSums> gather_partials_;
  TilePartials<GatherSums> precondition_partials_;
  std::unique_ptr<LinePreconditioner> lines_;
  std::vector<double> line_z_;  ///< 3 per slot: P^-1 g at the current point (line solves)
  std::unique_ptr<NewtonSystem> newton_;
  std::unique_ptr<MultigridPreconditioner> multigrid_;  ///< Newton with preconditioner = multigrid
};

}  // namespace clothbench::kernels
