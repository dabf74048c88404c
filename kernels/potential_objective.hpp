// The `potential` formulation (MODEL.md 4B, the default): positions are the only unknowns,
// element forces follow by return mapping onto the KES bands, and one step minimises
// Phi(x) = sum m |x - x~|^2 / (2 dt^2) - sum (m g + f) . (x - x^n) + elastic potentials + contact
// (f: scripted external forces; loads are measured from x^n so that Phi stays small and its
// changes resolvable).
#pragma once

#include <vector>

#include "kernels/step_context.hpp"
#include "kernels/step_objective.hpp"

namespace clothbench::kernels {

class PotentialObjective final : public StepObjective {
 public:
  explicit PotentialObjective(const StepContext& ctx);
  void begin_step(LoopRunner& run) override;
  void refresh_preconditioner(LoopRunner& run) override;
  Evaluation evaluate(LoopRunner& run) override;
  double update_direction(LoopRunner& run, double beta) override;
  void move(LoopRunner& run, double alpha) override;
  void end_step(LoopRunner& run) override;
  void prepare_history(LoopRunner& run) override;

 private:
  /// Phi restricted to the terms that involve particle s, with s moved to `xs`
  /// (the local cost the numeric gradient differentiates).
  double local_energy(std::int64_t s, const Eigen::Vector3d& xs) const;
  Eigen::Vector3d numeric_gradient(std::int64_t s) const;
  /// 3x3 stiffness block of particle s (inertia, elements' tangent, contact with the
  /// obstacles in `mask`).
  Eigen::Matrix3d diagonal_block(std::int64_t s, ObstacleMask mask) const;

  StepContext ctx_;
  TilePartials<ScalarSum> edge_partials_;
  TilePartials<ScalarSum> triple_partials_;
  TilePartials<ScalarSum> scalar_partials_;
  TilePartials<GatherSums> gather_partials_;
};

}  // namespace clothbench::kernels
