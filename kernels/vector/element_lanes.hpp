// The vector twin of the potential formulation's element loops (issue 16): plain-data inputs
// of one tile's edges and triples, and the per-instruction-set kernels that evaluate them in
// SIMD lanes. Free of Eigen and of the kernel's other headers on purpose: the kernels are
// compiled once per instruction set (element_lanes_<isa>.cpp, each with its own -m flags) and
// must share no inline function with the rest of the program (one definition per symbol).
// The scalar reference is potential_elements.hpp (edge_term, triple_term); same branches.
#pragma once

#include <cstdint>

namespace clothbench::kernels::vector {

/// TensileBand's parameters (kes_material.hpp): Fm (N/m), EMT (strain), exponents p, q.
struct TensileLanesBand {
  double fm, emt, p, q;
};

/// BendingBand's parameters (kes_material.hpp) with what its integrals need, per direction.
struct BendingLanesBand {
  double b, hb, kappa0, onset;
  double at_onset;  ///< 0.5 B on^2 - HB on + B kappa0 on (unloading_integral's constant)
};

/// Coefficients of ramp_integral's Taylor series, highest order first (k = 11 .. 2): the same
/// doubles BendingBand::ramp_integral computes in its loop.
struct RampSeries {
  double coefficient[10];
};

/// One evaluation's inputs and outputs of the edge loop (arrays of ClothMesh / ClothState).
struct EdgeLanesArgs {
  const double* position;        ///< xyz per slot
  const std::int32_t* next;      ///< per element id
  const float* rest;             ///< per element id, m
  const float* width;            ///< per element id, m
  const double* previous_force;  ///< per element id, N/m
  double* force_density;         ///< out, per element id: w t / l
  TensileLanesBand band[2];      ///< per direction
};

/// The same for the triple loop.
struct TripleLanesArgs {
  const double* position;
  const std::int32_t* prev;
  const std::int32_t* next;
  /// The edges' rest lengths and widths per element id (m): a triple's are the means of its
  /// two edges' (ClothMesh::triple_rest, triple_width).
  const float* edge_rest;
  const float* edge_width;
  const double* previous_moment;  ///< per element id, N
  const double* offloading;       ///< 2 per element id: bending_offloading's {plateau, unloading}
  double* coefficients;           ///< out, 3 per element id: w M (A, Bc, C)
  BendingLanesBand band[2];
  RampSeries ramp;
};

/// ParticleFlag bits (cloth_mesh.hpp) the particle kernel reads; checked equal there.
inline constexpr std::uint8_t kLanesActive = 1, kLanesPinned = 4;

/// One evaluation's inputs and outputs of the particle loop (the gather): arrays of ClothMesh
/// and ClothState, the scratch the element loops wrote, and the step's constants.
struct ParticleLanesArgs {
  const double* position;       ///< xyz per slot
  const double* target;         ///< x~, xyz per slot
  const double* step_start;     ///< x^n, xyz per slot
  const double* direction;      ///< xyz per slot
  const double* gradient_old;   ///< xyz per slot; null under Newton (no CG history)
  const float* preconditioner;  ///< 6 per slot: symmetric inverse block (xx xy xz yy yz zz)
  const double* mass;           ///< per slot, kg
  const std::uint8_t* flags;    ///< per slot: ParticleFlag bits (free = active, not pinned)
  const std::int32_t* next;     ///< per element id
  const std::int32_t* prev;     ///< per element id
  const std::uint8_t* edge_active;
  const std::uint8_t* triple_active;
  const double* edge_scratch;    ///< per element id: w t / l
  const double* triple_scratch;  ///< 3 per element id: w M (A, Bc, C)
  double* gradient;              ///< out, xyz per slot
  double dt_squared;             ///< s^2
  double gravity[3];             ///< m/s^2
  double gravity_reference;      ///< |g|, m/s^2
};

/// The reductions of one tile (GatherSums of step_objective.hpp without the contact counts).
struct ParticleLanesSums {
  double energy = 0.0, residual_sq = 0.0, residual_max = 0.0, slope = 0.0;
  double grad_dot_z = 0.0, grad_old_dot_z = 0.0;
};

/// The kernels of one instruction set. Each evaluates the elements `ids[0..count)` of one tile
/// in lane groups of `lanes` consecutive ids (the last group padded with copies of the last id,
/// whose results are dropped), writes each element's scratch slots, and returns the sum of
/// their energies (J) in id order within each group and group order within the tile.
struct ElementLanesKernels {
  const char* isa;  ///< "avx512f", "avx2+fma", "sse2"
  int lanes;        ///< doubles per vector
  double (*edges)(const EdgeLanesArgs& args, const std::int32_t* ids, std::int64_t count);
  double (*triples)(const TripleLanesArgs& args, const std::int32_t* ids, std::int64_t count);
  /// The particle loop over `slots[0..count)` (the active particles of one tile): writes each
  /// gradient (zero for a particle that is not free) and sums the free particles' terms in slot
  /// order. `extra` (or null: none): the terms that stay
  /// scalar, 4 per position, computed by the caller for the free particles: gradient xyz
  /// (contact penalty, minus the scripted force, plus half of what each ghost child gathers)
  /// and energy (contact, minus f . (x - x^n)).
  ParticleLanesSums (*particles)(const ParticleLanesArgs& args, const std::int32_t* slots,
                                 const double* extra, std::int64_t count);
};

/// The best kernels this CPU runs (chosen once, at first call, from CPUID).
const ElementLanesKernels& element_lanes_kernels();
/// The kernels of every instruction set this CPU supports, best first (for tests).
int supported_element_lanes_kernels(const ElementLanesKernels** out, int capacity);

}  // namespace clothbench::kernels::vector
