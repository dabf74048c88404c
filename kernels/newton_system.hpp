// What the potential formulation's Newton method keeps between its loops (MODEL.md 5): the
// model Hessian and the vectors and per-tile sums of the inner linear PCG. The search
// direction itself is ClothState::direction, so that the line search moves along it.
#pragma once

#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "kernels/cloth_state.hpp"
#include "kernels/loop_runner.hpp"
#include "kernels/model_hessian.hpp"
#include "kernels/slot_pages.hpp"

namespace clothbench::kernels {

/// Per-tile sums of the inner PCG's loops.
struct PcgSums {
  double rz = 0.0;        ///< r . z
  double weighted = 0.0;  ///< sum |r_i|^2 / (m_i |g|)^2
  double slope = 0.0;     ///< g . p
  PcgSums& operator+=(const PcgSums& o) {
    rz += o.rz;
    weighted += o.weighted;
    slope += o.slope;
    return *this;
  }
};

/// Outcome of one inexact Newton solve H p = -g.
struct LinearSolveReport {
  int iterations = 0;              ///< PCG iterations (products with H)
  double relative_residual = 1.0;  ///< weighted |r| / weighted |g| at the end
  double slope = 0.0;              ///< g . p (< 0 for a descent direction)
  bool converged = false;          ///< reached the forcing term
  bool positive = true;            ///< p . H p > 0 held on every search direction
};

/// The model and the inner PCG's vectors. The vectors live in the state's scratch, which is
/// dead while a direction is solved (every evaluation writes it before it reads it, the
/// model's assembly and H v do not read it, and nothing reads a PCG vector after the solve):
/// the residual in edge_scratch (3 doubles a slot when the state was allocated for Newton),
/// the search direction and the product in the first and second half of triple_scratch (6 a
/// slot). 64 bytes a slot, 61 MiB at the paper's 1001^2, that were never in use at the same
/// time as the scratch. A state allocated for nonlinear CG (a benchmark's or a test's second
/// objective) has 2 doubles a slot of edge_scratch: the residual then has its own array.
struct NewtonSystem {
  NewtonSystem(const ClothMesh& mesh, ClothState& state)
      : own_residual_(state.edge_scratch.size() < 3 * slots(mesh) ? 3 * slots(mesh) : 0, 0.0),
        hessian(mesh),
        residual(own_residual_.empty() ? view(mesh, state.edge_scratch, 0) : own_residual_),
        search(view(mesh, state.triple_scratch, 0)),
        product(view(mesh, state.triple_scratch, 1)),
        partials(mesh.tile_count()) {}

 private:
  std::vector<double> own_residual_;  ///< only when the state's edge_scratch is too short

 public:
  ModelHessian hessian;
  std::span<double> residual;  ///< r = -g - H p, 3 per slot
  std::span<double> search;    ///< the PCG search direction, 3 per slot (ghosts: midpoints)
  std::span<double> product;   ///< H search, then the preconditioned residual z
  TilePartials<PcgSums> partials;
  /// Hands back the pages of unused slots of the model (slot_pages.hpp; the vectors go back
  /// with the state's scratch). Returns the bytes.
  std::size_t release_unused(const SlotRuns& runs) {
    return hessian.release_unused(runs) + release_slot_pages(own_residual_, 3, runs);
  }
  [[nodiscard]] std::size_t memory_bytes() const {
    return hessian.memory_bytes() + own_residual_.capacity() * sizeof(double);
  }
  /// Bytes per slot (memory estimates): the model, and edge_scratch's third double a slot.
  static constexpr std::size_t kBytesPerSlot = ModelHessian::kBytesPerSlot + sizeof(double);

 private:
  static std::size_t slots(const ClothMesh& mesh) {
    return static_cast<std::size_t>(mesh.slot_count());
  }
  /// Part `part` (3 doubles a slot each) of a state array.
  static std::span<double> view(const ClothMesh& mesh, std::vector<double>& array, int part) {
    const std::size_t n = 3 * slots(mesh), begin = static_cast<std::size_t>(part) * n;
    if (array.size() < begin + n) {
      throw std::logic_error("NewtonSystem: a scratch array of the state is shorter than " +
                             std::to_string(begin + n) + " doubles (ClothState::allocate)");
    }
    return std::span<double>(array).subspan(begin, n);
  }
};

}  // namespace clothbench::kernels
