// Adaptive mesh refinement and coarsening (MODEL.md section 6, paper sections 3-3.2).
//
// Levels 0..L over a (2^L n + 1)-particle grid: level k keeps every 2^k-th grid line. The
// active mesh is the set of leaves of a 2:1-balanced quadtree whose roots are the level-L
// cells; the tree is stored as the leaf level of every finest cell (one byte per cell), so
// "which leaf holds this point" is one load. From the tree the mesh derives, for every slot:
//   - active particle: a corner of every leaf it touches;
//   - ghost: a corner of some leaf but the midpoint of a side of a coarser neighbour
//     (position = midpoint of that side, forces half to each end; ghost_nodes.hpp);
//   - inactive otherwise (inside a leaf or inside a side shared by two coarse leaves);
//   - edges: consecutive nodes along a grid line that is a side of the leaves on both sides;
//   - triples: centred on an active particle with a node on both sides along the line.
// Nothing is allocated or moved: an event rewrites flags, neighbour indices, rest lengths,
// widths and masses in place (paper section 3.2), and carries positions and forces across.
#pragma once

#include <cstdint>
#include <vector>

#include "kernels/cloth_mesh.hpp"
#include "kernels/cloth_state.hpp"
#include "kernels/simulation_config.hpp"

namespace clothbench::kernels {

/// A cell of level k at cell coordinates (ci, cj): finest cells [ci 2^k, (ci+1) 2^k) x ...
struct TreeCell {
  int level = 0;
  int ci = 0;
  int cj = 0;
  friend bool operator==(const TreeCell&, const TreeCell&) = default;
};

/// What one AMRC event did and what it cost.
struct AmrcEvent {
  int step = 0;                         ///< the step after which the event ran
  std::int64_t refined = 0;             ///< leaves split (balance refinements included)
  std::int64_t coarsened = 0;           ///< groups of four leaves merged
  std::int64_t particles = 0, edges = 0, triples = 0, ghosts = 0;  ///< active after the event
  double criterion_seconds = 0.0;       ///< evaluating the bending measure and marking cells
  double update_seconds = 0.0;          ///< tree changes, mesh rewrite, warm starts
  double list_seconds = 0.0;            ///< Active-Lists rebuild (0 when no list is in use)
  /// Bytes of the unused slots' pages handed back to the system after the event
  /// (Simulation::release_unused_pages; 0 when it is off or the event changed nothing).
  std::size_t released_bytes = 0;
  [[nodiscard]] bool changed() const { return refined + coarsened > 0; }
};

/// The quadtree of one cloth and the operations that keep the mesh in step with it.
class AdaptiveMesh {
 public:
  /// Starts with every leaf at level 0 (the finest mesh). `levels` = L >= 1; the mesh's
  /// particle counts must be 2^L n + 1.
  AdaptiveMesh(const ClothMesh& mesh, int levels);

  [[nodiscard]] int levels() const { return levels_; }
  /// Level of the leaf holding finest cell (fi, fj).
  [[nodiscard]] int leaf_level(int fi, int fj) const {
    return leaf_[static_cast<std::size_t>(fi) * cells_j_ + fj];
  }
  [[nodiscard]] bool is_leaf(const TreeCell& c) const;
  [[nodiscard]] int cells_i() const { return cells_i_; }
  [[nodiscard]] int cells_j() const { return cells_j_; }

  /// Splits leaf c (level >= 1) into four, refining neighbours as needed to keep 2:1
  /// balance. Returns the number of leaves split (0 if c is not a splittable leaf).
  std::int64_t refine(const TreeCell& c);
  /// Merges the four children of c (level >= 1) if all are leaves, the merge keeps 2:1
  /// balance and no pinned or forced particle would stop being active. Returns true if merged.
  bool coarsen(const TreeCell& c, const ClothMesh& mesh);
  /// Splits the leaves around grid point (i, j) until it is a corner of every leaf it touches
  /// (an active particle once the mesh is rewritten). Returns the number of leaves split.
  std::int64_t refine_to_particle(int i, int j);

  /// True if every two edge-adjacent leaves differ by at most one level.
  [[nodiscard]] bool balanced() const;

  /// Rewrites the mesh from the tree: flags, neighbours, rest lengths, widths, masses, ghost
  /// count. Positions are not touched.
  void write_mesh(ClothMesh& mesh) const;

  /// One AMRC event after step `step`: evaluates the criterion on the current state, refines
  /// and coarsens, rewrites the mesh and carries the unknowns across (new particles start on
  /// the interpolated surface with interpolated velocity; edge and triple forces are combined
  /// or inherited per unit width). Uses the state's per-evaluation scratch arrays as work
  /// space. Returns the event's figures (list_seconds is left to the caller).
  AmrcEvent run_event(int step, const AmrcConfig& config, ClothMesh& mesh, ClothState& state);

  /// The two halves of an event, for hand-driven edits: begin_change() records the old tree
  /// and the old forces (before any refine/coarsen), finish_change() rewrites the mesh and
  /// carries positions and forces across.
  void begin_change(const ClothMesh& mesh, ClothState& state);
  void finish_change(ClothMesh& mesh, ClothState& state);

  /// Interpolates every inactive slot of `values` (xyz per slot) from the leaf holding it
  /// (bilinear in the leaf's corners): the cloth's surface sampled at every finest grid point.
  void interpolate_inactive(const ClothMesh& mesh, std::vector<double>& values) const;

  /// The leaves, coarse to fine (for pictures and tests).
  [[nodiscard]] std::vector<TreeCell> leaves() const;

  /// Bytes held by the tree and the event's marks.
  [[nodiscard]] std::size_t memory_bytes() const {
    return leaf_.capacity() + old_leaf_.capacity() + carried_.capacity();
  }

 private:
  void set_cell(const TreeCell& c, int level);
  /// Largest turning angle of the active triples centred on each slot (into `angle`, at 4 x the
  /// slot: the triple_breakpoints layout of two ids a slot and two breakpoints an id).
  void node_angles(const ClothMesh& mesh, const ClothState& state, std::vector<double>& angle) const;
  /// Bilinear value of `values` at grid point (i, j) inside the leaf holding it, using the
  /// tree in `leaf` and the mesh's current flags and neighbours for ghost corners.
  [[nodiscard]] Eigen::Vector3d interpolate(const ClothMesh& mesh, const std::vector<std::uint8_t>& leaf,
                                            const std::vector<double>& values, int i, int j) const;
  void carry_forces(const ClothMesh& mesh, ClothState& state) const;

  int levels_;
  int cells_i_, cells_j_;  // finest cells along i and j
  std::vector<std::uint8_t> leaf_;      // leaf level per finest cell
  std::vector<std::uint8_t> old_leaf_;  // the tree before the current event
  /// Per element id, during an event: which of the old forces begin_change() recorded there
  /// (kCarriedEdge, kCarriedTriple). The values themselves are in the state's edge_scratch and
  /// triple_scratch, written only where marked: the scratch arrays' pages at unused slots are
  /// never touched by an event, so they can stay with the system (ClothState::release_unused).
  std::vector<std::uint8_t> carried_;
};

}  // namespace clothbench::kernels
