// What the potential formulation's Newton method keeps between its loops (MODEL.md 5): the
// model Hessian and the vectors and per-tile sums of the inner linear PCG. The search
// direction itself is ClothState::direction, so that the line search moves along it.
#pragma once

#include <cstdint>
#include <vector>

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

struct NewtonSystem {
  explicit NewtonSystem(const ClothMesh& mesh)
      : hessian(mesh),
        residual(3 * static_cast<std::size_t>(mesh.slot_count()), 0.0),
        search(3 * static_cast<std::size_t>(mesh.slot_count()), 0.0),
        product(3 * static_cast<std::size_t>(mesh.slot_count()), 0.0),
        partials(mesh.tile_count()) {}
  ModelHessian hessian;
  std::vector<double> residual;  ///< r = -g - H p, 3 per slot
  std::vector<double> search;    ///< the PCG search direction, 3 per slot (ghosts: midpoints)
  std::vector<double> product;   ///< H search, then the preconditioned residual z
  TilePartials<PcgSums> partials;
  /// Hands back the pages of unused slots of the model and the PCG vectors (slot_pages.hpp).
  /// Returns the bytes.
  std::size_t release_unused(const SlotRuns& runs) {
    return hessian.release_unused(runs) + release_slot_pages(residual, 3, runs) +
           release_slot_pages(search, 3, runs) + release_slot_pages(product, 3, runs);
  }
  [[nodiscard]] std::size_t memory_bytes() const {
    return hessian.memory_bytes() +
           (residual.capacity() + search.capacity() + product.capacity()) * sizeof(double);
  }
  /// Bytes per slot (memory estimates).
  static constexpr std::size_t kBytesPerSlot = ModelHessian::kBytesPerSlot + 9 * sizeof(double);
};

}  // namespace clothbench::kernels
