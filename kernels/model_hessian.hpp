// The model Hessian H of the potential formulation's step (MODEL.md section 5, Newton): a
// symmetric positive definite stand-in for the second derivative of Phi, applied without a
// matrix. Its terms, assembled at the current positions:
//   inertia      m / dt^2 I per free particle;
//   contact      k n n^T per particle within the contact distance of an obstacle;
//   edges        K_e = alpha u u^T + beta (I - u u^T) between the two ends, alpha = w t' / L
//                (the band's slope on the current branch), beta = w max(t, 0) / l: exact for
//                an edge in tension, positive semi-definite always;
//   triples      Gauss-Newton bending c J^T J between the three particles, J = d kappa / dx of
//                the turning vector kappa = e2/|e2| - e1/|e1| (|kappa| = 2 sin(theta/2)), and
//                c = w M' / Lbar with M' the band's slope on the branch the return mapping takes
//                (0 on the plateau; at a straight triple with a previous moment the loading
//                slope at zero curvature): positive semi-definite always, well defined at a
//                straight triple where theta's own gradient is not, and the moment's own curvature
//                term w M d2theta (indefinite) left out.
// Within a step the axial and bending stiffnesses also look beyond the current point: where
// the band has a kink (the ends of the hysteresis plateau, the onset of tension) the tangent
// is blind to the wall the next step runs into, so each becomes
//   max(tangent, secant from here to x + p, kStiffnessMemory x what the previous assembly gave),
// with p the last Newton direction (the full step the model asked for) and the secant taken
// on the same return mapping. Both only add positive stiffness, so H stays SPD; as the steps
// shrink the secant tends to the tangent and the memory decays away. A step's first
// assembly does not reach (p then belongs to the previous step) but does remember. On the
// box drape this halves Newton's iterations (kernels/MODEL-NOTES.md, "The model reaches
// along its last step").
// Bending's coefficient c is also at least the secant from zero curvature M / kappa (capped at
// the slope at zero): on the plateau a triple's energy grows like M |kappa|. That floor is
// exact across the turning vector (bending the triple another way lengthens |kappa|
// quadratically) but too stiff along it, where the energy is linear: the lagged-diffusivity
// model, which keeps a step that crosses the band's kinks short but converges only linearly
// once none does. So the term is C = c (I - k k^T) + c_along k k^T with k = kappa / |kappa|
// (blocks J^T C J): c_along = c (isotropic) while the line search cuts Newton's steps, and after
// an iteration that took the full step c_along is the tangent, the reach and the memory without
// the floor, at most c (assemble's `floor_along`, newton_minimiser.cpp; kernels/MODEL-NOTES.md,
// "Bending along the turning vector").
// Ghosts enter by the chain rule, as in the gradient: a vector is extended to every ghost by
// the midpoint rule, and what a ghost receives goes half to each parent (ghost_nodes.hpp).
//
// apply() is three loops (ghosts of the vector, triples, particle gather) through the
// LoopRunner, each writing only its own slots, with per-tile sums: the product has the same
// bits on every scheduler and thread count.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cstdint>
#include <functional>
#include <span>
#include <utility>
#include <vector>

#include "kernels/loop_runner.hpp"
#include "kernels/slot_pages.hpp"
#include "kernels/step_context.hpp"

namespace clothbench::kernels {

/// Unknown index of every slot: 0, 1, ... for the free particles in the order of
/// ClothMesh::for_each_slot_in_grid_rows (block by block, rows in grid order), -1 for every
/// other slot (pinned, inactive, ghost). `count` receives the number of unknowns.
std::vector<std::int64_t> free_unknowns(const StepContext& ctx, std::int64_t* count);

class ModelHessian {
 public:
  /// What a particle loop over the model reads per element id of its slot (loop_bytes.hpp):
  /// next, prev, both element flags, the edge's alpha and beta, the triple's two coefficients
  /// (floats).
  static constexpr double kElementRead = 2 * bytes::kIndex + 2 * bytes::kFlag + 4 * bytes::kFloat;
  /// What sum_row reads of its particle: the mass and contact index, the position, its slot's
  /// elements.
  static constexpr double kRowRead =
      bytes::kDouble + bytes::kIndex + bytes::kVector3 + bytes::kIdsPerSlot * kElementRead;

  explicit ModelHessian(const ClothMesh& mesh);

  /// Assembles H at the current positions for step length ctx.dt() (edges, triples, then
  /// particles). `diagonal(s, block)` is called once for every active particle with its full
  /// 3x3 diagonal block (inertia, contact, every edge and triple touching it; zero for a
  /// pinned particle), for the preconditioners. Every thread of the region calls it.
  /// `new_step`: the first assembly of a (sub-)step; later ones reach along the last Newton
  /// direction (ctx.state.direction, whose ghost entries they overwrite with midpoints) and
  /// remember the previous assembly's stiffness. `diagonal_written`: the bytes `diagonal`
  /// writes per particle (its loop's LoopBytes, loop_bytes.hpp). `floor_along`: bending keeps
  /// the floor M / kappa along the turning vector as well (isotropic; see the top of this file).
  template <class Diagonal>
  void assemble(LoopRunner& run, const StepContext& ctx, Diagonal&& diagonal, bool new_step = true,
                double diagonal_written = 0.0, bool floor_along = true);

  /// y = H v on the free particles (0 elsewhere); returns v . y. v must be zero on every
  /// active particle that is not free; its ghost entries are overwritten (midpoints). Needs no
  /// work space (v and y may be views into the state's triple_scratch, NewtonSystem). Every
  /// thread of the region calls it.
  double apply(LoopRunner& run, const StepContext& ctx, std::span<double> v, std::span<double> y);

  /// The assembled model as an explicit sparse matrix over the unknowns (3 rows and columns
  /// per free particle, unknown k at rows 3k..3k+2; `unknown_of_slot` from free_unknowns).
  /// Ghosts enter as in apply(): a ghost follows its parents with weight 1/2 each, and what it
  /// receives goes half to each. Sequential; for the multigrid's Galerkin coarse operators and
  /// for tests (matrix() * v equals apply(v)).
  [[nodiscard]] Eigen::SparseMatrix<double> matrix(const StepContext& ctx,
                                                   const std::vector<std::int64_t>& unknown_of_slot,
                                                   std::int64_t unknowns) const;

  /// Called with (row unknown, column unknown, 3x3 block row-major) for every block of the
  /// model before duplicates are summed.
  using BlockVisitor = std::function<void(std::int64_t, std::int64_t, const double*)>;
  /// The blocks matrix() sums, in the same order (inertia and contact per particle, then edge
  /// and triple blocks by element id), each node expanded to its unknowns. `structure`: every
  /// block of every active edge (also one of zero length) and of every triple with bending
  /// stiffness (bends()), each as a zero block: the pattern of every model on this mesh whose
  /// triples with bending stiffness are these, element by element - the reference the
  /// V-cycle's pattern by rows (row_pattern) is tested against. Sequential.
  void for_each_unknown_block(const StepContext& ctx,
                              const std::vector<std::int64_t>& unknown_of_slot,
                              const BlockVisitor& visit, bool structure = false) const;

  /// Drops the stiffness the next assembly would remember (kStiffnessMemory): it then starts
  /// from the tangent and the secant alone. Sequential; outside a parallel region.
  void forget() {
    std::fill(edge_.begin(), edge_.end(), 0.0f);
    std::fill(bending_.begin(), bending_.end(), 0.0f);
    std::fill(bending_along_.begin(), bending_along_.end(), 0.0f);
  }

  /// Row of free particle s of matrix(), summed on its own: its inertia and contact, then for
  /// s and every ghost hanging on it (recursively, at half the weight) the blocks of every
  /// element touching that node, each column expanded to its unknowns. `cols` (count, sorted)
  /// must hold every column of the row; `values` receives 9 entries a column, row-major.
  /// The sums run in an order of their own (not matrix()'s), the same at every thread count:
  /// the V-cycle's level 0 by rows in parallel.
  void sum_row(const StepContext& ctx, const std::vector<std::int64_t>& unknown_of_slot,
               std::int64_t s, const std::int64_t* cols, std::int64_t count, double* values) const;

  /// The columns of free particle s's row in every model on this mesh whose triples with
  /// bending stiffness are this one's: for_each_unknown_block's `structure` pattern by rows
  /// (every active edge at s or at a ghost hanging on it, recursively, and every such triple
  /// with bending stiffness, each node expanded to its unknowns), sorted and distinct,
  /// appended to `cols`; returns how many. The same traversal as sum_row, whose `cols` it
  /// makes; one row per call, so the V-cycle's level 0 pattern is made by rows in parallel.
  std::int64_t row_pattern(const StepContext& ctx, const std::vector<std::int64_t>& unknown_of_slot,
                           std::int64_t s, std::vector<std::int64_t>& cols) const;

  /// Whether triple id has bending stiffness in the assembled model (adds blocks besides its
  /// edges'; the V-cycle's structure depends on which triples do).
  [[nodiscard]] bool bends(std::int64_t id) const { return bending_[id] > 0.0; }
  /// Element ids bends() answers for.
  [[nodiscard]] std::int64_t element_ids() const {
    return static_cast<std::int64_t>(bending_.size());
  }

  /// Bending coefficient c of triple id as assembled (w dM/dkappa / rest, or what the secants
  /// and the memory made of it; across the turning vector; tests).
  [[nodiscard]] double bending_stiffness(std::int64_t id) const { return bending_[id]; }
  /// The same along the turning vector (c_along <= c; equal where the floor was kept along it).
  [[nodiscard]] double bending_along(std::int64_t id) const { return bending_along_[id]; }

  /// Edge tangent K_e of active edge id as assembled (the line solves' couplings).
  [[nodiscard]] Eigen::Matrix3d edge_block(const StepContext& ctx, std::int64_t id) const;

  /// Drops the stiffness memory of every element that is not active on `mesh` (writing only
  /// where it is not zero already): an element an AMRC event takes away starts from the
  /// tangent and the secant alone when a later event brings it back, not from what it was
  /// given on an earlier mesh; and frees the contact blocks of every tile left without
  /// particles. Called after every event that changed the mesh. Sequential in its caller's
  /// view (its own parallel loops); outside a parallel region.
  void forget_inactive(const ClothMesh& mesh);
  /// Hands back the pages of unused slots of the model's arrays (slot_pages.hpp): the contact
  /// indices are written for every active particle before they are read, and an unused slot's
  /// elements are inactive, whose memory forget_inactive keeps at zero. Returns the bytes.
  std::size_t release_unused(const SlotRuns& runs) {
    return release_slot_pages(contact_of_, 1, runs) + release_slot_pages(edge_, 4, runs) +
           release_slot_pages(bending_, 2, runs) + release_slot_pages(bending_along_, 2, runs);
  }
  [[nodiscard]] std::size_t memory_bytes() const;
  /// Bytes per slot (memory estimates): the elements' coefficients, the contact index, and a
  /// contact block for every particle at most.
  static constexpr std::size_t kBytesPerSlot =
      (4 + 2 + 2) * sizeof(double) + sizeof(std::int32_t) + 6 * sizeof(double);

  /// The diagonal block of free particle s that is its own, as assembled for ctx.dt():
  /// m / dt^2 I, plus the contact stiffness k n n^T where the particle is within the contact
  /// distance of an obstacle (then both as one stored block).
  [[nodiscard]] Eigen::Matrix3d particle_block(const StepContext& ctx, std::int64_t s) const {
    const std::int32_t c = contact_of_[s];
    if (c < 0) return particle_inertia(ctx, s);
    return contact_block(tile_contact_[tile_of(ctx.mesh, s)], c);
  }
  /// Particles with a contact block in the model as last assembled (tests, figures).
  [[nodiscard]] std::int64_t contact_blocks() const;
  /// An element's axial or bending stiffness keeps at least this share of what the previous
  /// assembly gave it (0.2-0.5 measured alike; 0.9 makes slack regions too stiff to move).
  static constexpr double kStiffnessMemory = 0.3;
  /// A reach changes a strain or a turning angle (rad) by more than this, or it is rounding
  /// (a translation of the cloth) and its secant, a quotient of two roundings, is not taken.
  static constexpr double kReachChange = 1e-12;

 private:
  /// Every thread; per particle: store the contact block if any, call diagonal(s, full block).
  template <class Diagonal>
  void assemble_particles(LoopRunner& run, const StepContext& ctx, Diagonal& diagonal, bool reach,
                          double diagonal_written);
  /// Edge and triple coefficients at the current positions (two loops).
  void assemble_elements(LoopRunner& run, const StepContext& ctx, bool new_step, bool floor_along);
  /// The full diagonal block of particle s without inertia and contact: edges and triples.
  [[nodiscard]] Eigen::Matrix3d element_diagonal(const StepContext& ctx, std::int64_t s) const;
  /// Triple id's block between its nodes of Jacobians jr and jq: jr^T C jq (J symmetric),
  /// C = c (I - k k^T) + c_along k k^T for the unit turning vector k (isotropic without one).
  [[nodiscard]] Eigen::Matrix3d bending_block(std::int64_t id, const Eigen::Matrix3d& jr,
                                              const Eigen::Matrix3d& jq,
                                              const Eigen::Vector3d* k) const {
    const double c = bending_[id];
    Eigen::Matrix3d block = c * jr * jq;
    const double anisotropy = static_cast<double>(bending_along_[id]) - c;
    if (k != nullptr && anisotropy != 0.0) {
      block += anisotropy * (jr * *k) * (jq * *k).transpose();
    }
    return block;
  }

  static Eigen::Matrix3d particle_inertia(const StepContext& ctx, std::int64_t s) {
    const double dt = ctx.dt();
    return Eigen::Matrix3d::Identity() * (ctx.mesh.mass[s] / (dt * dt));
  }
  /// Block c of a tile's contact blocks (6 values each: xx xy xz yy yz zz).
  static Eigen::Matrix3d contact_block(const std::vector<double>& blocks, std::int32_t c) {
    const double* p = blocks.data() + 6 * static_cast<std::size_t>(c);
    Eigen::Matrix3d m;
    m << p[0], p[1], p[2], p[1], p[3], p[4], p[2], p[4], p[5];
    return m;
  }
  static std::int64_t tile_of(const ClothMesh& mesh, std::int64_t s) {
    return std::upper_bound(mesh.tile_slot_begin.begin(), mesh.tile_slot_begin.end(), s) -
           mesh.tile_slot_begin.begin() - 1;
  }

  /// The particles' own blocks are m / dt^2 I, computed where used, except for a particle in
  /// contact: per slot the index of its block (inertia and contact together) among its tile's
  /// contact blocks, -1 without contact. A tile's blocks are written by the one thread that
  /// runs the tile (LoopRunner never splits a tile), so the assembly needs no lock, and only
  /// the particles near an obstacle cost the 48 bytes of a block (4 bytes a slot otherwise).
  std::vector<std::int32_t> contact_of_;
  std::vector<std::vector<double>> tile_contact_;  ///< per tile: 6 per contact block
  /// The elements' stiffness coefficients, each computed in double and stored once rounded
  /// to float (12 instead of 24 bytes an element id; every reader, apply() and the matrix
  /// alike, reads the same rounded value, so the model stays one symmetric operator).
  std::vector<float> edge_;           ///< 2 per element id: alpha, beta
  std::vector<float> bending_;        ///< 1 per element id: c, across the turning vector
  std::vector<float> bending_along_;  ///< 1 per element id: c_along, along it
  TilePartials<ScalarSum> dot_partials_;
};

template <class Diagonal>
void ModelHessian::assemble(LoopRunner& run, const StepContext& ctx, Diagonal&& diagonal,
                            bool new_step, double diagonal_written, bool floor_along) {
  assemble_elements(run, ctx, new_step, floor_along);
  assemble_particles(run, ctx, diagonal, !new_step, diagonal_written);
}

template <class Diagonal>
void ModelHessian::assemble_particles(LoopRunner& run, const StepContext& ctx, Diagonal& diagonal,
                                      bool reach, double diagonal_written) {
  const ClothState& st = ctx.state;
  // Flags, x, mass, p when reaching, the slot's elements read; the contact index (and the
  // block of a particle in contact) and what `diagonal` stores written.
  const LoopBytes particle_bytes{.read = bytes::kFlag + bytes::kVector3 + bytes::kDouble +
                                         (reach ? bytes::kVector3 : 0.0) +
                                         bytes::kIdsPerSlot * kElementRead,
                                 .written = bytes::kIndex + diagonal_written};
  run.for_each_prepared(
      ElementKind::particles, particle_bytes,
      [&](std::int64_t tile) {
        std::vector<double>& blocks = tile_contact_[static_cast<std::size_t>(tile)];
        blocks.clear();
        // Reaching, the box covers x and x + p.
        const ObstacleMask mask =
            ctx.broad_phase()
                ? ctx.tile_contacts(tile, st.position, reach ? &st.direction : nullptr).mask
                : kEveryObstacle;
        return std::pair<ObstacleMask, std::vector<double>*>(mask, &blocks);
      },
      [&](std::int64_t s, const std::pair<ObstacleMask, std::vector<double>*>& tile) {
        contact_of_[s] = -1;
        if (!ctx.is_free(s)) {
          diagonal(s, Eigen::Matrix3d::Zero());
          return;
        }
        const Eigen::Vector3d x = vec3(st.position, s);
        const Eigen::Vector3d to = reach ? Eigen::Vector3d(x + vec3(st.direction, s)) : x;
        const Eigen::Matrix3d contact =
            contact_penalty(ctx, s, x, tile.first, reach ? &to : nullptr).stiffness;
        Eigen::Matrix3d own = particle_inertia(ctx, s);  // the expression apply() uses
        if ((contact.array() != 0.0).any()) {
          own += contact;
          std::vector<double>& blocks = *tile.second;
          contact_of_[s] = static_cast<std::int32_t>(blocks.size() / 6);
          blocks.insert(blocks.end(),
                        {own(0, 0), own(0, 1), own(0, 2), own(1, 1), own(1, 2), own(2, 2)});
        }
        diagonal(s, Eigen::Matrix3d(own + element_diagonal(ctx, s)));
      });
}

}  // namespace clothbench::kernels
