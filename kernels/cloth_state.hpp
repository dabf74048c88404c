// The simulation state arrays (MODEL.md section 1): positions and their history, the
// minimiser's vectors, and the element forces that carry the hysteresis history.
// Sized once for the finest mesh; indexed by slot (3 doubles per slot for vectors) or by
// element id (2*slot+d).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <vector>

#include "kernels/slot_pages.hpp"

namespace clothbench::kernels {

/// 3-vector view of slot s of an interleaved xyz array.
inline Eigen::Map<Eigen::Vector3d> vec3(std::vector<double>& a, std::int64_t s) {
  return Eigen::Map<Eigen::Vector3d>(a.data() + 3 * s);
}
inline Eigen::Map<const Eigen::Vector3d> vec3(const std::vector<double>& a, std::int64_t s) {
  return Eigen::Map<const Eigen::Vector3d>(a.data() + 3 * s);
}
/// The same for a view of an interleaved xyz array (NewtonSystem's PCG vectors).
inline Eigen::Map<Eigen::Vector3d> vec3(std::span<double> a, std::int64_t s) {
  return Eigen::Map<Eigen::Vector3d>(a.data() + 3 * s);
}
inline Eigen::Map<const Eigen::Vector3d> vec3(std::span<const double> a, std::int64_t s) {
  return Eigen::Map<const Eigen::Vector3d>(a.data() + 3 * s);
}

/// A scripted external force on one particle (N); the particle's slot carries kParticleForced.
struct ExternalForce {
  std::int64_t slot = 0;
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
};

/// Per-slot and per-element arrays of one cloth.
struct ClothState {
  // particles (3 doubles per slot)
  std::vector<double> position;      ///< x, the current iterate (m)
  std::vector<double> step_start;    ///< x^n, positions at the start of the step (m)
  std::vector<double> target;        ///< x~ = x^n + (1 - c)(x^n - x^(n-1)) (m)
  std::vector<double> gradient;      ///< d(objective)/dx at the current iterate
  /// Gradient at the start of the CG iteration; empty under Newton, which has no use for it
  /// (allocate's `cg_history`: 24 bytes a slot, 24 MB at the paper's 1001^2).
  std::vector<double> gradient_old;
  std::vector<double> direction;     ///< CG search direction
  std::vector<float> preconditioner; ///< 6 per slot: inverse 3x3 block (xx xy xz yy yz zz)
  // elements (per element id)
  std::vector<double> edge_force;     ///< t_e at the last completed step (N/m)
  std::vector<double> triple_moment;  ///< M_t at the last completed step (N)
  /// Per evaluation: w t / l (N/m^2 * m = N/m) per id; under Newton 3 a slot, the inner PCG's
  /// residual while a direction is solved (NewtonSystem).
  std::vector<double> edge_scratch;
  /// Per evaluation: 3 per id, w M (A, Bc, C); under Newton the inner PCG's search direction
  /// and product while a direction is solved (NewtonSystem).
  std::vector<double> triple_scratch;
  /// Per step: 2 per id, curvatures where the bending loading / unloading curve reaches M_t
  /// (the return mapping's breakpoints; an inverse of a non-power-law curve, so cached).
  std::vector<double> triple_breakpoints;
  /// Per step, the vector kernel's only (empty otherwise): 2 per id, what the potential off the
  /// loading curve adds to the curvature's terms, {plateau, unloading} (potential_elements.hpp
  /// bending_offloading); 32 MB at the paper's 1001^2.
  std::vector<double> triple_offloading;
  /// Per step, under the tilted tension plateau only (empty otherwise): kTiltedPieceDoubles
  /// (5) per edge id, the pieces of its law (tilted_plateau.hpp); 80 MB at the paper's 1001^2.
  std::vector<double> edge_plateau;
  /// External forces (sparse: a few particles at most; looked up only for forced slots).
  std::vector<ExternalForce> external_forces;

  /// Allocates every array for `slots` particles (zero-filled); gradient_old only with
  /// `cg_history` (the nonlinear CG minimiser's), triple_offloading only with `vector_kernel`,
  /// edge_scratch with 3 doubles a slot instead of 2 with `newton` (NewtonSystem), and
  /// edge_plateau only with `tilted_plateau`.
  void allocate(std::int64_t slots, bool cg_history = true, bool vector_kernel = false,
                bool newton = false, bool tilted_plateau = false) {
    const auto n = static_cast<std::size_t>(slots);
    for (auto* v : {&position, &step_start, &target, &gradient, &direction}) v->assign(3 * n, 0.0);
    gradient_old.assign(cg_history ? 3 * n : 0, 0.0);
    gradient_old.shrink_to_fit();
    preconditioner.assign(6 * n, 0.0f);
    edge_force.assign(2 * n, 0.0);
    triple_moment.assign(2 * n, 0.0);
    edge_scratch.assign((newton ? 3 : 2) * n, 0.0);
    triple_scratch.assign(6 * n, 0.0);
    triple_breakpoints.assign(4 * n, 0.0);
    triple_offloading.assign(vector_kernel ? 4 * n : 0, 0.0);
    triple_offloading.shrink_to_fit();
    edge_plateau.assign(tilted_plateau ? 10 * n : 0, 0.0);
    edge_plateau.shrink_to_fit();
  }
  /// Hands back the pages of unused slots (slot_pages.hpp) of the arrays no loop reads at an
  /// unused slot: x^n, x~, the gradients, the direction, the block-Jacobi blocks, the bending
  /// cache and the tilted plateau's pieces, the per-evaluation scratch (an AMRC event writes it only at the ids of active
  /// elements, AdaptiveMesh::begin_change), and the forces and moments (zero at every element
  /// that is not active, AdaptiveMesh::carry_forces, so the state digested over every slot is
  /// the same either way). Not position. Returns the bytes handed back.
  std::size_t release_unused(const SlotRuns& runs) {
    std::size_t b = release_slot_pages(preconditioner, 6, runs) +
                    release_slot_pages(edge_force, 2, runs) +
                    release_slot_pages(triple_moment, 2, runs) +
                    release_slot_pages(triple_offloading, 4, runs) + release_edge_scratch(runs) +
                    release_slot_pages(triple_scratch, 6, runs) +
                    release_slot_pages(triple_breakpoints, 4, runs) +
                    release_slot_pages(edge_plateau, 10, runs);
    for (auto* v : {&step_start, &target, &gradient, &gradient_old, &direction}) {
      b += release_slot_pages(*v, 3, runs);
    }
    return b;
  }
  /// edge_scratch's pages of slots unused both as 2 doubles a slot (the evaluation's) and,
  /// under Newton, as 3 (the PCG residual's, NewtonSystem).
  std::size_t release_edge_scratch(const SlotRuns& runs) {
    const auto slots = static_cast<std::int64_t>(position.size() / 3);
    if (static_cast<std::int64_t>(edge_scratch.size()) <= 2 * slots) {
      return release_slot_pages(edge_scratch, 2, runs);
    }
    return release_slot_pages(edge_scratch.data(), sizeof(double), 1,
                              shared_element_runs(runs, slots, 2, 3));
  }
  /// Bytes held by the arrays.
  [[nodiscard]] std::size_t memory_bytes() const {
    std::size_t b = preconditioner.capacity() * sizeof(float);
    for (const auto* v : {&position, &step_start, &target, &gradient, &gradient_old, &direction,
                          &edge_force, &triple_moment, &edge_scratch, &triple_scratch,
                          &triple_breakpoints, &triple_offloading, &edge_plateau}) {
      b += v->capacity() * sizeof(double);
    }
    return b;
  }
};

}  // namespace clothbench::kernels
