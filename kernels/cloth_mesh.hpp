// Blocked structure-of-arrays storage of the cloth's particles, edges and triples
// (MODEL.md sections 1 and 7, paper section 4.1 and Fig. 7).
//
// The finest I x J grid is cut into B x B particle blocks; each block's particles are stored
// together, row by row, the rows of a block coarsest first: the rows on the lattice of the
// largest power of two dividing their grid index come first (i = 0 mod 2^k before 2^(k-1)),
// ties in grid order. So a coarse AMRC region's particles (every 2^L-th row) share a few
// pages at the start of each block instead of touching most of them, and the pages of the
// rows between them can go back to the system (slot_pages.hpp). A particle's storage index is
// its *slot*. Every slot owns two edge
// slots and two triple slots, one per grid direction d (0 = along i / warp, 1 = along j / weft):
//   edge   2*slot+d : from the particle to the next node along direction d;
//   triple 2*slot+d : centred on the particle, from the previous to the next node along d.
// All storage is allocated once for the finest mesh; AMRC only flips flags and rewrites the
// neighbour indices, rest lengths and widths in place (paper section 3.2).
//
// Reductions are summed per *tile* (one row of one block, at most B consecutive slots) and the
// tile partials combined in tile order, so every scheduler and thread count gives the same bits.
#pragma once

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "kernels/simulation_config.hpp"

namespace clothbench::kernels {

/// Particle state bits.
enum ParticleFlag : std::uint8_t {
  kParticleActive = 1,  ///< simulated (an unknown unless pinned)
  kParticleGhost = 2,   ///< on a fine/coarse boundary: midpoint of its coarse edge, not simulated
  kParticlePinned = 4,  ///< active but held fixed
  kGhostAlongI = 8,     ///< a ghost on a coarse edge along i: its parents are prev/next along d = 0
  kGhostAlongJ = 16,    ///< a ghost on a coarse edge along j: its parents are prev/next along d = 1
  kParticleForced = 32,  ///< carries a scripted external force (ClothState::external_forces)
};

/// Grid direction along which ghost `flags` hangs (its parents are prev/next along it), or -1.
constexpr int ghost_direction(std::uint8_t flags) {
  return (flags & kGhostAlongI) != 0 ? 0 : (flags & kGhostAlongJ) != 0 ? 1 : -1;
}
/// True for particles and ghosts: the nodes edges and triples may join.
constexpr bool is_node(std::uint8_t flags) {
  return (flags & (kParticleActive | kParticleGhost)) != 0;
}

/// Index of the edge or triple of direction `d` owned by slot `slot`.
constexpr std::int64_t element_id(std::int64_t slot, int d) { return 2 * slot + d; }
constexpr std::int64_t element_slot(std::int64_t id) { return id / 2; }
constexpr int element_direction(std::int64_t id) { return static_cast<int>(id % 2); }

/// The cloth's topology and reference geometry. Sizes never change after construction.
class ClothMesh {
 public:
  /// Builds the finest uniform mesh of `cloth` with areal density `areal_density` (kg/m^2).
  ClothMesh(const ClothConfig& cloth, double areal_density);

  // --- grid and blocked layout -------------------------------------------------------
  [[nodiscard]] int size_i() const { return size_i_; }
  [[nodiscard]] int size_j() const { return size_j_; }
  [[nodiscard]] int block_size() const { return block_size_; }
  [[nodiscard]] std::int64_t slot_count() const { return static_cast<std::int64_t>(flags.size()); }
  [[nodiscard]] std::int64_t block_count() const {
    return static_cast<std::int64_t>(block_tile_begin.size()) - 1;
  }
  [[nodiscard]] std::int64_t tile_count() const {
    return static_cast<std::int64_t>(tile_slot_begin.size()) - 1;
  }
  /// Storage slot of grid point (i, j), from the blocked layout: the full block rows before
  /// i's, the full blocks before j's in that block row, then row by row inside the block in
  /// the block's row order (coarsest rows first, row_order()).
  [[nodiscard]] std::int32_t slot(int i, int j) const {
    const std::int64_t b = block_size_, i0 = i / block_size_ * b, j0 = j / block_size_ * b;
    const std::int64_t rows = std::min<std::int64_t>(size_i_ - i0, b);
    const std::int64_t width = std::min<std::int64_t>(size_j_ - j0, b);
    return static_cast<std::int32_t>(i0 * size_j_ + j0 * rows +
                                     row_place_[static_cast<std::size_t>(i)] * width + (j - j0));
  }
  /// The grid rows of a block row in storage order: the rows [i0, i1) sorted by the largest
  /// power of two dividing each index (0 counts as divisible by every one), largest first, ties
  /// in grid order. E.g. rows 0..9: 0 8 4 2 6 1 3 5 7 9.
  static std::vector<int> row_order(int i0, int i1);
  /// Rest spacing of the finest grid along direction d (m).
  [[nodiscard]] double spacing(int d) const { return spacing_[d]; }
  /// Rest position of grid point (i, j) within the sheet, in sheet coordinates (m).
  [[nodiscard]] double rest_coordinate(int d, int index) const { return index * spacing_[d]; }

  /// Grid coordinates (i, j) of a slot: slot()'s inverse, computed rather than stored (8 bytes
  /// a slot, 7.6 MiB at 1001^2, for a map the AMRC and V-cycle set-up read a few times a step).
  [[nodiscard]] std::pair<int, int> grid_of(std::int64_t s) const {
    const std::int64_t b = block_size_, row_slots = b * size_j_;
    const std::int64_t i0 = s / row_slots * b;
    const std::int64_t rows = std::min<std::int64_t>(size_i_ - i0, b);
    const std::int64_t in_row = s - i0 * size_j_;
    const std::int64_t j0 = in_row / (rows * b) * b;
    const std::int64_t width = std::min<std::int64_t>(size_j_ - j0, b);
    const std::int64_t in_block = in_row - j0 * rows;
    return {row_at_[static_cast<std::size_t>(i0 + in_block / width)],
            static_cast<int>(j0 + in_block % width)};
  }
  /// Calls f(s) for every slot block by block as slot() orders the blocks, but inside each
  /// block row by row in grid order (the layout's order before rows were stored coarsest
  /// first): a sequence in which a slot's grid neighbours along both directions stay close,
  /// which numberings of the particles (the V-cycle's level 0) want for their line sweeps.
  template <class F>
  void for_each_slot_in_grid_rows(F&& f) const {
    const std::int64_t b = block_size_;
    for (std::int64_t i0 = 0; i0 < size_i_; i0 += b) {
      const std::int64_t rows = std::min<std::int64_t>(size_i_ - i0, b);
      for (std::int64_t j0 = 0; j0 < size_j_; j0 += b) {
        const std::int64_t width = std::min<std::int64_t>(size_j_ - j0, b);
        const std::int64_t base = i0 * size_j_ + j0 * rows;
        for (std::int64_t i = i0; i < i0 + rows; ++i) {
          const std::int64_t row = base + row_place_[static_cast<std::size_t>(i)] * width;
          for (std::int64_t j = 0; j < width; ++j) f(row + j);
        }
      }
    }
  }
  [[nodiscard]] int grid_i(std::int64_t s) const { return grid_of(s).first; }
  [[nodiscard]] int grid_j(std::int64_t s) const { return grid_of(s).second; }

  /// Total mass of all active particles (kg). Equals density * W * H.
  [[nodiscard]] double total_mass() const;
  [[nodiscard]] double areal_density() const { return areal_density_; }

  /// Recomputes masses, widths and rest lengths of the active elements from the current
  /// active set and neighbour indices (used after AMRC changes them).
  void update_reference_geometry();

  /// Ghost particles in the current active set (0 on a uniform mesh: ghost loops are skipped).
  [[nodiscard]] std::int64_t ghost_count() const { return ghost_count_; }
  void set_ghost_count(std::int64_t n) { ghost_count_ = n; }

  // --- storage (public arrays: the kernels index them directly in hot loops) --------------
  std::vector<std::int64_t> tile_slot_begin;   ///< tiles+1: first slot of each tile
  std::vector<std::int64_t> block_tile_begin;  ///< blocks+1: first tile of each block
  std::vector<std::uint8_t> flags;             ///< per slot: ParticleFlag bits
  std::vector<double> mass;                    ///< per slot, kg (0 for ghosts and inactive)
  std::vector<std::int32_t> next;              ///< per element id: next node along d, or -1
  std::vector<std::int32_t> prev;              ///< per element id: previous node along d, or -1
  std::vector<std::uint8_t> edge_active;       ///< per element id: edge (slot -> next) exists
  std::vector<std::uint8_t> triple_active;     ///< per element id: triple (prev, slot, next) exists
  std::vector<float> edge_rest;                ///< rest length L_e, m
  std::vector<float> edge_width;               ///< width w_e of the strip the edge stands for, m

  /// Rest spacing Lbar_t of the active triple at `id` (m): the mean of its two edges' rest
  /// lengths, formed in float. Computed where it is read rather than stored (8 bytes a slot,
  /// 8 MB at 1001^2): on the uniform mesh it is the node spacing, and on a graded one half of
  /// each edge, the extent along the line that the centre stands for.
  [[nodiscard]] float triple_rest(std::int64_t id) const {
    return 0.5f * (edge_rest[element_id(prev[id], element_direction(id))] + edge_rest[id]);
  }
  /// Width w_t of the active triple at `id` (m): the mean of its two edges' widths.
  [[nodiscard]] float triple_width(std::int64_t id) const {
    return 0.5f * (edge_width[element_id(prev[id], element_direction(id))] + edge_width[id]);
  }

 private:
  int size_i_;
  int size_j_;
  int block_size_;
  /// Per grid row i: its place among its block row's rows in storage order; per block row
  /// start i0 and place r, the grid row stored there (row_at_[i0 + r]).
  std::vector<std::int32_t> row_place_, row_at_;
  double spacing_[2];
  double areal_density_;
  std::int64_t ghost_count_ = 0;
};

}  // namespace clothbench::kernels
