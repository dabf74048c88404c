// Line-solve preconditioner of the `potential` formulation (MODEL-NOTES.md, "Line solves"),
// an alternative to per-particle block Jacobi.
//
// A cloth's stiffness is strongly anisotropic: an edge in tension resists stretching along
// itself with the material's tangent and motion across itself only with its tension
// (K_e = w (slope / L) u u^T + w (t / l) (I - u u^T)). Block Jacobi moves information one grid
// line per CG iteration, so the stiff in-line coupling makes its iteration count grow with the
// mesh. Here, for each grid direction d, the modelled stiffness restricted to each grid line
// along d (the particles' block-Jacobi blocks on the diagonal, -K_e between neighbours on the
// line) is block-tridiagonal and is solved exactly by block elimination; the preconditioner
// is the mean of the two directions' solves:
//
//   z = (L_0^-1 g + L_1^-1 g) / 2.
//
// Each L_d is a principal block-diagonal part of the modelled stiffness (symmetric positive
// definite), so z is a valid CG preconditioner. A line is broken at pins and ghosts (they are
// not unknowns); on an AMRC mesh an inactive particle is skipped, because the active edge from
// the particle before it may end beyond it. Each line is eliminated by one thread in grid order,
// so the result has the same bits on every scheduler and thread count.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <vector>

#include "kernels/loop_runner.hpp"
#include "kernels/step_context.hpp"

namespace clothbench::kernels {

class LinePreconditioner {
 public:
  explicit LinePreconditioner(const ClothMesh& mesh);

  /// Per slot the block-Jacobi block D_s, per element id the edge tangent K_e; filled by the
  /// objective before `factor`.
  std::vector<double> diagonal_block;  ///< 6 per slot (xx xy xz yy yz zz); free slots only
  std::vector<double> edge_block;      ///< 6 per element id; active edges only

  /// Eliminates every line of both directions (with every refresh of the preconditioner).
  /// Every thread of the region calls it.
  void factor(LoopRunner& run, const StepContext& ctx);
  /// out = z for every free slot, 0 elsewhere. Every thread; ends after a barrier.
  void apply(LoopRunner& run, const StepContext& ctx, std::span<const double> g,
             std::span<double> out);

  [[nodiscard]] std::size_t memory_bytes() const;
  /// Bytes the preconditioner (with the objective's z) needs per slot (memory estimates).
  static constexpr std::size_t kBytesPerSlot = (6 + 12 + 12 + 6 + 3) * sizeof(double);

 private:
  /// Calls f(slot, linked, previous) for the free particles of grid line `line` along
  /// direction d, in grid order; `linked`: the active edge from `previous` (the free particle
  /// before it on the line, or -1) along d ends on `slot`.
  template <class F>
  void walk_line(const StepContext& ctx, int d, int line, F&& f) const;

  std::vector<double> pivot_inverse_;  ///< 2 x 6 per slot: inverse eliminated pivot per direction
  std::vector<double> line_value_;     ///< 2 x 3 per slot: each direction's solve
};

}  // namespace clothbench::kernels
