// The plain-data arguments of the vector element kernels (vector/element_lanes.hpp) for one
// evaluation: pointers into the mesh and state, and the bands of the fabric. Kept apart from
// element_lanes.hpp, which must not include Eigen or the kernel's headers.
#pragma once

#include "kernels/cloth_mesh.hpp"
#include "kernels/cloth_state.hpp"
#include "kernels/kes_material.hpp"
#include "kernels/vector/element_lanes.hpp"

namespace clothbench::kernels::vector {

/// Edge loop arguments: reads positions and previous tensions, writes state.edge_scratch.
inline EdgeLanesArgs edge_lanes_args(const ClothMesh& mesh, ClothState& state,
                                     const FabricMaterial& material) {
  EdgeLanesArgs args{state.position.data(),  mesh.next.data(),       mesh.edge_rest.data(),
                     mesh.edge_width.data(), state.edge_force.data(), state.edge_scratch.data(),
                     {}};
  for (int d = 0; d < 2; ++d) {
    const TensileBand& t = material.tensile[d];
    args.band[d] = {t.fm, t.emt, t.p, t.q};
  }
  return args;
}

/// Triple loop arguments: reads positions, previous moments and the step's off-loading
/// constants (state.triple_offloading, which the vector kernel's state holds), writes
/// state.triple_scratch.
inline TripleLanesArgs triple_lanes_args(const ClothMesh& mesh, ClothState& state,
                                         const FabricMaterial& material) {
  TripleLanesArgs args{state.position.data(),           mesh.prev.data(),
                       mesh.next.data(),                mesh.edge_rest.data(),
                       mesh.edge_width.data(),          state.triple_moment.data(),
                       state.triple_offloading.data(),  state.triple_scratch.data(),
                       {},                              {}};
  for (int d = 0; d < 2; ++d) {
    const BendingBand& b = material.bending[d];
    const double on = b.unloading_onset;
    // BendingBand::unloading_integral's constant, in its operation order.
    args.band[d] = {b.b, b.hb, b.kappa0, on, 0.5 * b.b * on * on - b.hb * on + b.b * b.kappa0 * on};
  }
  // BendingBand::ramp_integral's series coefficients, computed by its own loop.
  double factorial = 39916800.0;  // 11!
  for (int k = 11; k >= 2; --k) {
    args.ramp.coefficient[11 - k] = ((k % 2 == 0) ? 1.0 : -1.0) / factorial;
    factorial /= k;
  }
  return args;
}

static_assert(kLanesActive == kParticleActive && kLanesPinned == kParticlePinned);

/// Particle loop arguments: reads positions, the CG vectors, the preconditioner and the
/// element loops' scratch; writes state.gradient. `dt`: the sub-step's length (s);
/// `gravity_reference`: the residual's weight scale (StepContext::gravity_reference, m/s^2).
inline ParticleLanesArgs particle_lanes_args(const ClothMesh& mesh, ClothState& state,
                                             const Eigen::Vector3d& gravity,
                                             double gravity_reference, double dt) {
  ParticleLanesArgs args{state.position.data(),
                         state.target.data(),
                         state.step_start.data(),
                         state.direction.data(),
                         state.gradient_old.empty() ? nullptr : state.gradient_old.data(),
                         state.preconditioner.data(),
                         mesh.mass.data(),
                         mesh.flags.data(),
                         mesh.next.data(),
                         mesh.prev.data(),
                         mesh.edge_active.data(),
                         mesh.triple_active.data(),
                         state.edge_scratch.data(),
                         state.triple_scratch.data(),
                         state.gradient.data(),
                         dt * dt,
                         {gravity.x(), gravity.y(), gravity.z()},
                         gravity_reference};
  return args;
}

}  // namespace clothbench::kernels::vector
