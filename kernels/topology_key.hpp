// The topology of a cloth mesh as far as the solver's set-ups depend on it: its extent, every
// particle's flags (active, pinned, ghost and its direction) and the active edges and
// triples, which fix the neighbour indices. A set-up made for one topology (the smoothing
// colouring, the V-cycle's hierarchy) is kept while its key still matches the mesh: between
// AMRC events and scripted events a step, or a Newton iteration, reuses it.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "kernels/cloth_mesh.hpp"

namespace clothbench::kernels {

class TopologyKey {
 public:
  /// True when `mesh` has the topology last taken (never before the first take()).
  [[nodiscard]] bool matches(const ClothMesh& mesh) const {
    return same_extent(mesh) && matches_slots(mesh, 0, mesh.slot_count());
  }
  /// True when a topology was taken from a mesh of `mesh`'s extent (matches_slots may then
  /// compare its slots).
  [[nodiscard]] bool same_extent(const ClothMesh& mesh) const {
    return taken_ && size_i_ == mesh.size_i() && size_j_ == mesh.size_j() &&
           flags_.size() == mesh.flags.size() && edges_.size() == mesh.edge_active.size() &&
           triples_.size() == mesh.triple_active.size();
  }
  /// With same_extent(mesh): whether slots [begin, end) and their element ids have the flags
  /// and active elements last taken (a part of matches(), for checks split over threads).
  [[nodiscard]] bool matches_slots(const ClothMesh& mesh, std::int64_t begin,
                                   std::int64_t end) const {
    const auto range = [&](const std::vector<std::uint8_t>& key,
                           const std::vector<std::uint8_t>& now, std::int64_t per_slot) {
      return std::equal(key.begin() + per_slot * begin, key.begin() + per_slot * end,
                        now.begin() + per_slot * begin);
    };
    return range(flags_, mesh.flags, 1) && range(edges_, mesh.edge_active, 2) &&
           range(triples_, mesh.triple_active, 2);
  }
  void take(const ClothMesh& mesh) {
    taken_ = true;
    size_i_ = mesh.size_i();
    size_j_ = mesh.size_j();
    flags_ = mesh.flags;
    edges_ = mesh.edge_active;
    triples_ = mesh.triple_active;
  }
  /// Forgets the topology: the next matches() is false.
  void clear() { taken_ = false; }
  [[nodiscard]] std::size_t memory_bytes() const {
    return flags_.capacity() + edges_.capacity() + triples_.capacity();
  }
  /// Bytes per slot (memory estimates): a flag byte and two element ids of one byte each
  /// for edges and for triples.
  static constexpr std::size_t kBytesPerSlot = 5;

 private:
  bool taken_ = false;
  int size_i_ = 0, size_j_ = 0;
  std::vector<std::uint8_t> flags_, edges_, triples_;
};

}  // namespace clothbench::kernels
