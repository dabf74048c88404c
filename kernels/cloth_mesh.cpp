// Blocked storage layout and reference geometry of the cloth mesh (see cloth_mesh.hpp).
#include "kernels/cloth_mesh.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <stdexcept>

namespace clothbench::kernels {

ClothMesh::ClothMesh(const ClothConfig& cloth, double areal_density)
    : size_i_(cloth.particles_i),
      size_j_(cloth.particles_j),
      block_size_(cloth.block_size),
      spacing_{cloth.size_i / (cloth.particles_i - 1), cloth.size_j / (cloth.particles_j - 1)},
      areal_density_(areal_density) {
  if (size_i_ < 2 || size_j_ < 2 || block_size_ < 1) {
    throw std::invalid_argument("ClothMesh: need at least 2 x 2 particles and a block size >= 1");
  }
  const std::int64_t n = static_cast<std::int64_t>(size_i_) * size_j_;
  if (n > INT32_MAX / 2) throw std::invalid_argument("ClothMesh: too many particles");

  // Inside each block row, the rows coarsest first (row_order); slot() and grid_of() read it.
  row_place_.resize(static_cast<std::size_t>(size_i_));
  row_at_.resize(static_cast<std::size_t>(size_i_));
  for (int i0 = 0; i0 < size_i_; i0 += block_size_) {
    const std::vector<int> order = row_order(i0, std::min(size_i_, i0 + block_size_));
    for (std::size_t r = 0; r < order.size(); ++r) {
      row_at_[static_cast<std::size_t>(i0) + r] = order[r];
      row_place_[static_cast<std::size_t>(order[r])] = static_cast<std::int32_t>(r);
    }
  }

  // Blocks in row-major block order; inside a block, particles row by row in that order (one
  // tile per row).
  const int blocks_i = (size_i_ + block_size_ - 1) / block_size_;
  const int blocks_j = (size_j_ + block_size_ - 1) / block_size_;
  std::int64_t next_slot = 0;
  block_tile_begin.push_back(0);
  for (int bi = 0; bi < blocks_i; ++bi) {
    for (int bj = 0; bj < blocks_j; ++bj) {
      const int i0 = bi * block_size_, i1 = std::min(size_i_, i0 + block_size_);
      const int j0 = bj * block_size_, j1 = std::min(size_j_, j0 + block_size_);
      for (int i = i0; i < i1; ++i) {  // the block's rows in storage order
        tile_slot_begin.push_back(next_slot);
        next_slot += j1 - j0;  // slot(i, j) = the tile's first slot + j - j0
      }
      block_tile_begin.push_back(static_cast<std::int64_t>(tile_slot_begin.size()));
    }
  }
  tile_slot_begin.push_back(next_slot);

  flags.assign(static_cast<std::size_t>(n), kParticleActive);
  mass.assign(static_cast<std::size_t>(n), 0.0);
  next.assign(static_cast<std::size_t>(2 * n), -1);
  prev.assign(static_cast<std::size_t>(2 * n), -1);
  edge_active.assign(static_cast<std::size_t>(2 * n), 0);
  triple_active.assign(static_cast<std::size_t>(2 * n), 0);
  edge_rest.assign(static_cast<std::size_t>(2 * n), 0.0f);
  edge_width.assign(static_cast<std::size_t>(2 * n), 0.0f);

  // Uniform finest mesh: every grid neighbour is a node.
  for (int i = 0; i < size_i_; ++i) {
    for (int j = 0; j < size_j_; ++j) {
      const std::int64_t s = slot(i, j);
      if (i + 1 < size_i_) next[element_id(s, 0)] = slot(i + 1, j);
      if (i > 0) prev[element_id(s, 0)] = slot(i - 1, j);
      if (j + 1 < size_j_) next[element_id(s, 1)] = slot(i, j + 1);
      if (j > 0) prev[element_id(s, 1)] = slot(i, j - 1);
    }
  }
  for (const auto& [pi, pj] : cloth.pinned) flags[slot(pi, pj)] |= kParticlePinned;
  update_reference_geometry();
}

std::vector<int> ClothMesh::row_order(int i0, int i1) {
  // The power of two dividing i: its trailing zero bits (row 0 is on every lattice).
  const auto coarseness = [](int i) {
    return i == 0 ? 32 : std::countr_zero(static_cast<unsigned>(i));
  };
  std::vector<int> rows;
  for (int i = i0; i < i1; ++i) rows.push_back(i);
  std::stable_sort(rows.begin(), rows.end(),
                   [&](int a, int b) { return coarseness(a) > coarseness(b); });
  return rows;
}

void ClothMesh::update_reference_geometry() {
  // Widths and masses from the cells around each node: a node's perpendicular extent is half
  // the distance to the previous plus half the distance to the next node on the crossing line.
  const std::int64_t n = slot_count();
  for (std::int64_t s = 0; s < n; ++s) {
    const bool node = (flags[s] & (kParticleActive | kParticleGhost)) != 0;
    const bool active = (flags[s] & kParticleActive) != 0;
    if (!node) {
      mass[s] = 0.0;
      for (int d = 0; d < 2; ++d) {
        edge_active[element_id(s, d)] = 0;
        triple_active[element_id(s, d)] = 0;
      }
      continue;
    }
    // Grid distances to the next and previous node along each direction (0 where there is
    // none), each slot's coordinates computed once, and the extent along d of the area the
    // node stands for (m).
    const auto [i, j] = grid_of(s);
    const int own[2] = {i, j};
    auto along = [&](std::int64_t t, int d) {
      const auto [ti, tj] = grid_of(t);
      return d == 0 ? ti : tj;
    };
    int next_span[2] = {0, 0};
    double extent[2] = {0.0, 0.0};
    for (int d = 0; d < 2; ++d) {
      const std::int64_t id = element_id(s, d);
      if (next[id] >= 0) {
        next_span[d] = along(next[id], d) - own[d];
        extent[d] += 0.5 * next_span[d] * spacing_[d];
      }
      if (prev[id] >= 0) {
        const int prev_span = own[d] - along(prev[id], d);
        extent[d] += 0.5 * prev_span * spacing_[d];
      }
    }
    mass[s] = active ? areal_density_ * extent[0] * extent[1] : 0.0;
    for (int d = 0; d < 2; ++d) {
      const std::int64_t id = element_id(s, d);
      const int other = 1 - d;
      const bool has_next = next[id] >= 0;
      edge_active[id] = has_next ? 1 : 0;
      if (has_next) {
        edge_rest[id] = static_cast<float>(next_span[d] * spacing_[d]);
        edge_width[id] = static_cast<float>(extent[other]);
      }
      const bool has_triple = active && next[id] >= 0 && prev[id] >= 0;
      triple_active[id] = has_triple ? 1 : 0;
    }
  }
}

double ClothMesh::total_mass() const {
  // Neumaier-compensated: a plain sum of 10^6 masses drifts by ~1e-12 relative, which would
  // hide a real mass error of that size.
  double total = 0.0, compensation = 0.0;
  for (double m : mass) {
    const double t = total + m;
    compensation += std::abs(total) >= std::abs(m) ? (total - t) + m : (m - t) + total;
    total = t;
  }
  return total + compensation;
}

}  // namespace clothbench::kernels
