// Two-level preconditioner of Newton's inner linear PCG (MODEL-NOTES.md, "Multigrid"): the
// line solves on the cloth's own mesh plus an exact solve of the Galerkin coarse operator
// P^T H P on the grid of every other line.
//
// Coarse grid. A free particle whose grid coordinates are both on a coarse line (even, or the
// last line of the grid) is a coarse node. Every other free particle follows the coarse nodes
// by the bilinear rule between the coarse lines around it, the rule the AMRC warm start and the
// ghost midpoints use: a particle between two coarse lines takes half of each, one in the
// middle of a coarse cell a quarter of each corner. On an AMRC mesh a free particle off the
// coarse lines lies in a leaf of the finest level, so the corners it needs are nodes of the
// mesh; a corner that is a ghost is expanded into its parents (half each), a pinned corner
// contributes nothing (its correction is zero), and a particle whose corners are not all nodes
// is kept as a coarse node itself (P keeps full column rank whatever the mesh).
//
// One application to a residual r is additive:
//   z = L^-1 r + P A_c^-1 P^T r
// with L^-1 the line solves (kernels/line_preconditioner.hpp). Both terms are symmetric and
// positive (semi-)definite, so z is a valid CG preconditioner whatever the state. A
// multiplicative V(1,1) cycle (smooth, coarse correction, smooth) took 7-8 PCG iterations
// instead of 13-15 on the stretched-sheet model, but with the line solves as smoother it stopped
// being positive definite on crumpled states in contact, even at a smoothing weight of 0.5
// (tests/kernels/unit_multigrid.cpp), and it needs two products with H per application. The
// coarse operator is rebuilt with every model: keeping a step's first one for the step's later
// Newton iterations cost 16 times the PCG iterations on a 65^2 drape (MODEL-NOTES.md).
//
// The line solves, the restriction's rows and the prolongation's particles go through the
// LoopRunner and write only their own entries, so the result has the same bits on every
// scheduler and thread count. The coarse operator's assembly and factorisation (once per Newton
// iteration) and its solve (once per application) run on one thread: the sequential part of
// the solver.
#pragma once

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <cstdint>
#include <span>
#include <vector>

#include "kernels/line_preconditioner.hpp"
#include "kernels/loop_runner.hpp"
#include "kernels/model_hessian.hpp"
#include "kernels/step_context.hpp"

namespace clothbench::kernels {

class MultigridPreconditioner {
 public:
  /// Builds the prolongation for the current active set, the fine matrix of the assembled
  /// model, the coarse operator P^T H P and its factorisation (one thread; the others wait).
  /// Every thread calls it.
  void factor(LoopRunner& run, const StepContext& ctx, const ModelHessian& hessian);
  /// out = B r on the free particles (0 elsewhere) for r zero off the free particles, with
  /// the line solves factorised last. Every thread calls it; ends after a barrier.
  void apply(LoopRunner& run, const StepContext& ctx, LinePreconditioner& lines,
             std::span<const double> r, std::span<double> out);

  /// The prolongation (3 rows per slot, 3 columns per coarse node; tests).
  [[nodiscard]] const Eigen::SparseMatrix<double, Eigen::RowMajor>& prolongation() const {
    return prolongation_;
  }
  /// The coarse operator of the last factor (tests).
  [[nodiscard]] const Eigen::SparseMatrix<double>& coarse_operator() const { return coarse_; }
  [[nodiscard]] std::int64_t coarse_nodes() const { return coarse_nodes_; }
  /// Factorisations of the coarse operator, and those that failed (B is then L^-1 alone).
  [[nodiscard]] std::int64_t factorisations() const { return factorisations_; }
  [[nodiscard]] std::int64_t coarse_failures() const { return coarse_failures_; }

  [[nodiscard]] std::size_t memory_bytes() const;
  /// Bytes per slot (memory estimates): the prolongation and restriction (at most 4 weights
  /// a row), the coarse operator and its factor (a quarter of the slots, about 27 x 2 + 60
  /// entries a coarse row with their indices).
  static constexpr std::size_t kBytesPerSlot =
      2 * 3 * 4 * (sizeof(double) + sizeof(int)) +
      (3 * (27 * 2 + 60) * (sizeof(double) + sizeof(int))) / 4;

 private:
  /// Sequential: the coarse nodes and P for the current active set.
  void build_prolongation(const StepContext& ctx);

  Eigen::SparseMatrix<double, Eigen::RowMajor> prolongation_;  ///< 3 slots x 3 coarse
  Eigen::SparseMatrix<double, Eigen::RowMajor> restriction_;   ///< P^T
  Eigen::SparseMatrix<double> coarse_;                         ///< P^T H P
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> direct_;
  bool coarse_ready_ = false;
  std::int64_t coarse_nodes_ = 0;
  std::int64_t factorisations_ = 0;
  std::int64_t coarse_failures_ = 0;
  Eigen::VectorXd coarse_r_, coarse_x_;
};

}  // namespace clothbench::kernels
