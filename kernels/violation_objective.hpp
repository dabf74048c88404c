// The `violation` formulation (MODEL.md 4A, the paper's section 2 literally): the unknowns are
// the free particles' positions AND the element forces (edge tensions t_e, triple moments M_t,
// held in ClothState::edge_force / triple_moment as the CG iterate), and one step minimises
//   E = Cn En + Cs Es + Cb Eb + Cc Ec   (dimensionless)
// with Es = sum_e (v_e / s_ref)^2, Eb = sum_t (v_t / Mref)^2 (band violations),
// En = sum_i |r~_i|^2 / (m_i |g|)^2 (Newton residuals after the obstacle supports) and
// Ec = sum_i sum_obstacles (max(0, d - sdf) / d)^2. At end_step the forces are simply the
// accepted unknowns: the solver returns shape and force.
//
// Gradient loops per evaluation (each writes only its own slots, MODEL.md 7):
//   1 edges: w t / l into edge_scratch, band coefficients, Es partials;
//   2 triples: w M (A, Bc, C) into triple_scratch, band coefficients, Eb partials;
//   3 particles: residual (gather), supports, rho = dE/dr, own gradient terms, En/Ec partials;
//   4 edges: dE/dt and the edge's position contribution G_e;
//   5 triples: dE/dM and the position contributions (exact Hessian-vector product of theta
//     by dual numbers);
//   6 particles: gather dE/dx.
// The numeric gradient mode replaces 4-6 by central differences of each unknown's local cost.
#pragma once

#include <vector>

#include "kernels/step_context.hpp"
#include "kernels/step_objective.hpp"
#include "kernels/violation_elements.hpp"

namespace clothbench::kernels {

/// The violation formulation's own per-slot / per-element arrays (sized once, like ClothState).
struct ViolationState {
  std::vector<double> rho;  ///< 3 per slot: dE/dr at the residual (0 if not free)
  /// 2 per id: Cs 2 v v_t / s_ref^2 and Cs 2 v v_eps / (s_ref^2 L) (loop 1 -> loop 4)
  std::vector<double> edge_band;
  std::vector<double> edge_gradient;      ///< per id: dE/dt_e (m/N)
  std::vector<double> edge_gradient_old;  ///< per id: at the start of the CG iteration
  std::vector<double> edge_direction;     ///< per id: CG direction (N/m)
  std::vector<double> edge_inverse;       ///< per id: preconditioner P^-1 ((N/m)^2)
  std::vector<double> edge_position;      ///< 3 per id: G_e (b gets +G_e, a gets -G_e), 1/m
  /// 2 per id: Cb 2 v v_M / Mref^2 and Cb 2 v v_kappa / (Mref^2 Lbar) (loop 2 -> loop 5)
  std::vector<double> triple_band;
  std::vector<double> triple_gradient;      ///< per id: dE/dM_t (1/N)
  std::vector<double> triple_gradient_old;  ///< per id
  std::vector<double> triple_direction;     ///< per id (N)
  std::vector<double> triple_inverse;       ///< per id (N^2)
  std::vector<double> triple_position;      ///< 6 per id: contributions to a, then b (c = -(a+b))

  void allocate(std::int64_t slots) {
    const auto n = static_cast<std::size_t>(slots);
    rho.assign(3 * n, 0.0);
    for (auto* v : {&edge_gradient, &edge_gradient_old, &edge_direction, &edge_inverse,
                    &triple_gradient, &triple_gradient_old, &triple_direction, &triple_inverse}) {
      v->assign(2 * n, 0.0);
    }
    edge_band.assign(4 * n, 0.0);
    triple_band.assign(4 * n, 0.0);
    edge_position.assign(6 * n, 0.0);
    triple_position.assign(12 * n, 0.0);
  }
};

class ViolationObjective final : public StepObjective {
 public:
  /// Allocates the ViolationState for ctx.mesh (call outside a parallel region).
  explicit ViolationObjective(const StepContext& ctx);
  void begin_step(LoopRunner& run) override;
  StepContext& context() override { return ctx_; }
  void refresh_preconditioner(LoopRunner& run) override;
  Evaluation evaluate(LoopRunner& run) override;
  double update_direction(LoopRunner& run, double beta) override;
  void move(LoopRunner& run, double delta) override;
  void end_step(LoopRunner& run) override;
  /// No per-step constants: the band violation reads only the curves.
  void prepare_history(LoopRunner& run) override;

  /// Force gradients, directions and preconditioner (read by tests and diagnostics).
  [[nodiscard]] const ViolationState& violation_state() const { return vs_; }
  [[nodiscard]] const ViolationScales& scales() const { return scales_; }
  /// Components of E at the last evaluation (unweighted): En, Es, Eb, Ec.
  struct Components {
    double newton = 0.0, stretch = 0.0, bend = 0.0, contact = 0.0;
  };
  [[nodiscard]] const Components& components() const { return components_; }

 private:
  /// Loops 1 and 2 (element coefficients into the scratch arrays); partials when not null.
  void element_loops(LoopRunner& run, TilePartials<ScalarSum>* edge_partials,
                     TilePartials<ScalarSum>* triple_partials);
  /// Gauss-Newton 3x3 diagonal block of E at free particle s (supports not applied; contact
  /// with the obstacles in `mask`).
  Eigen::Matrix3d diagonal_block(std::int64_t s, ObstacleMask mask) const;

  StepContext ctx_;
  ViolationScales scales_;
  ViolationState vs_;
  Components components_;
  TilePartials<ScalarSum> edge_value_partials_, triple_value_partials_;
  struct ResidualSums {
    double newton = 0.0, contact = 0.0, residual_max = 0.0;
    std::int64_t free_particles = 0, contact_tested = 0, contact_skipped = 0;
    ResidualSums& operator+=(const ResidualSums& o);
  };
  struct CgSums {
    double slope = 0.0, grad_dot_z = 0.0, grad_old_dot_z = 0.0;
    CgSums& operator+=(const CgSums& o);
  };
  TilePartials<ResidualSums> residual_partials_;
  TilePartials<CgSums> particle_cg_partials_, edge_cg_partials_, triple_cg_partials_;
  TilePartials<ScalarSum> particle_dir_partials_, edge_dir_partials_, triple_dir_partials_;
};

}  // namespace clothbench::kernels
