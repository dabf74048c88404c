// Active-list compaction (see active_lists.hpp).
#include "kernels/active_lists.hpp"

namespace clothbench::kernels {

const ElementList& ActiveLists::of(ElementKind kind) const {
  switch (kind) {
    case ElementKind::particles:
      return particles;
    case ElementKind::edges:
      return edges;
    case ElementKind::triples:
      return triples;
    case ElementKind::ghosts:
      return ghosts;
  }
  return particles;
}

namespace {

constexpr ElementKind kKinds[4] = {ElementKind::particles, ElementKind::edges, ElementKind::triples,
                                   ElementKind::ghosts};

}  // namespace

void ActiveLists::rebuild(const ClothMesh& mesh, ListBuild build) {
  // All four lists in one sweep over the tiles: count per tile and kind, an exclusive scan
  // over the tile counts (tiles are ~I * blocks_j, a few ten thousand at most), then fill.
  // The flags are read once per pass for every kind.
  ElementList* lists[4] = {&particles, &edges, &triples, &ghosts};
  const std::int64_t tiles = mesh.tile_count();
  for (int k = 0; k < 4; ++k) {
    lists[k]->tile_begin.assign(static_cast<std::size_t>(tiles + 1), 0);
    // Capacity for every element of the finest mesh, taken once: later rebuilds never move
    // a list (untouched capacity costs address space, not resident memory).
    lists[k]->entries.reserve(static_cast<std::size_t>(ids_per_slot(kKinds[k]) * mesh.slot_count()));
  }
  auto count_tile = [&](std::int64_t t) {
    std::int64_t count[4] = {0, 0, 0, 0};
    for (std::int64_t s = mesh.tile_slot_begin[t]; s < mesh.tile_slot_begin[t + 1]; ++s) {
      const std::uint8_t f = mesh.flags[s];
      count[0] += (f & kParticleActive) ? 1 : 0;
      count[1] += mesh.edge_active[2 * s] + mesh.edge_active[2 * s + 1];
      count[2] += mesh.triple_active[2 * s] + mesh.triple_active[2 * s + 1];
      count[3] += (f & kParticleGhost) ? 1 : 0;
    }
    for (int k = 0; k < 4; ++k) lists[k]->tile_begin[t + 1] = count[k];
  };
  auto scan = [&] {
    for (ElementList* list : lists) {
      for (std::int64_t t = 0; t < tiles; ++t) list->tile_begin[t + 1] += list->tile_begin[t];
      list->entries.resize(static_cast<std::size_t>(list->tile_begin[tiles]));
    }
  };
  auto fill_tile = [&](std::int64_t t) {
    std::int64_t q[4];
    for (int k = 0; k < 4; ++k) q[k] = lists[k]->tile_begin[t];
    std::int32_t* out[4] = {particles.entries.data(), edges.entries.data(), triples.entries.data(),
                            ghosts.entries.data()};
    for (std::int64_t s = mesh.tile_slot_begin[t]; s < mesh.tile_slot_begin[t + 1]; ++s) {
      const std::uint8_t f = mesh.flags[s];
      const auto slot = static_cast<std::int32_t>(s);
      if (f & kParticleActive) out[0][q[0]++] = slot;
      if (f & kParticleGhost) out[3][q[3]++] = slot;
      for (int d = 0; d < 2; ++d) {
        if (mesh.edge_active[2 * s + d]) out[1][q[1]++] = 2 * slot + d;
      }
      for (int d = 0; d < 2; ++d) {
        if (mesh.triple_active[2 * s + d]) out[2][q[2]++] = 2 * slot + d;
      }
    }
  };
  if (build == ListBuild::parallel_prefix_sum) {
#pragma omp parallel
    {
#pragma omp for schedule(static)
      for (std::int64_t t = 0; t < tiles; ++t) count_tile(t);
#pragma omp single
      scan();
#pragma omp for schedule(static)
      for (std::int64_t t = 0; t < tiles; ++t) fill_tile(t);
    }
  } else {
    for (std::int64_t t = 0; t < tiles; ++t) count_tile(t);
    scan();
    for (std::int64_t t = 0; t < tiles; ++t) fill_tile(t);
  }
}

std::size_t ActiveLists::release_capacity_tails() {
  std::size_t bytes = 0;
  for (ElementList* l : {&particles, &edges, &triples, &ghosts}) {
    bytes += release_capacity_tail(l->entries);
  }
  return bytes;
}

std::size_t ActiveLists::memory_bytes() const {
  std::size_t bytes = 0;
  for (const ElementList* l : {&particles, &edges, &triples, &ghosts}) {
    bytes += l->entries.capacity() * sizeof(std::int32_t) +
             l->tile_begin.capacity() * sizeof(std::int64_t);
  }
  return bytes;
}

}  // namespace clothbench::kernels
