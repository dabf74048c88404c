// Active-Lists: compacted index arrays of the active particles, edges, triples and ghosts
// (paper section 4.3, Figs. 10-11). Rebuilt after every AMRC event by a parallel
// prefix-sum compaction; entries stay in storage order, grouped by tile, so that reductions
// over a list give the same bits as reductions over blocks.
#pragma once

#include <cstdint>
#include <vector>

#include "kernels/cloth_mesh.hpp"
#include "kernels/slot_pages.hpp"

namespace clothbench::kernels {

/// The kinds of element a parallel loop can run over.
enum class ElementKind { particles, edges, triples, ghosts };

/// One compacted list: element ids in storage order, and where each tile's entries start.
struct ElementList {
  std::vector<std::int32_t> entries;      ///< particle slots or element ids (2*slot+d)
  std::vector<std::int64_t> tile_begin;   ///< tiles+1: first entry of each tile
  [[nodiscard]] std::int64_t size() const { return static_cast<std::int64_t>(entries.size()); }
};

/// How a list rebuild is carried out (the paper built the three lists sequentially).
enum class ListBuild { parallel_prefix_sum, sequential };

/// The four lists of one mesh state.
struct ActiveLists {
  ElementList particles;  ///< active (simulated) particles, pinned included
  ElementList edges;
  ElementList triples;
  ElementList ghosts;

  [[nodiscard]] const ElementList& of(ElementKind kind) const;
  /// Rebuilds all lists from the mesh flags. Call from outside a parallel region; uses
  /// OpenMP internally when `build` is parallel_prefix_sum.
  void rebuild(const ClothMesh& mesh, ListBuild build = ListBuild::parallel_prefix_sum);
  /// Hands back the pages of every list's capacity beyond its entries (slot_pages.hpp): the
  /// lists keep the finest mesh's capacity, so a coarse mesh's lists would keep the pages
  /// the finest one touched. Returns the bytes.
  std::size_t release_capacity_tails();
  /// Bytes held by the lists.
  [[nodiscard]] std::size_t memory_bytes() const;
};

/// True when slot/element `id` of `kind` is live in `mesh` (the test the block loops apply).
inline bool element_is_live(const ClothMesh& mesh, ElementKind kind, std::int64_t id) {
  switch (kind) {
    case ElementKind::particles:
      return (mesh.flags[id] & kParticleActive) != 0;
    case ElementKind::edges:
      return mesh.edge_active[id] != 0;
    case ElementKind::triples:
      return mesh.triple_active[id] != 0;
    case ElementKind::ghosts:
      return (mesh.flags[id] & kParticleGhost) != 0;
  }
  return false;
}

/// Number of element ids a slot owns for `kind` (1 for particle kinds, 2 for edges/triples).
constexpr int ids_per_slot(ElementKind kind) {
  return kind == ElementKind::edges || kind == ElementKind::triples ? 2 : 1;
}

}  // namespace clothbench::kernels
