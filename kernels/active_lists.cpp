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

/// Compacts the live ids of one kind. Counting and filling are per tile; the exclusive scan
/// over tile counts is sequential (tiles are ~I * blocks_j, a few ten thousand at most).
void build_list(const ClothMesh& mesh, ElementKind kind, ListBuild build, ElementList& list) {
  const std::int64_t tiles = mesh.tile_count();
  const int per_slot = ids_per_slot(kind);
  list.tile_begin.assign(static_cast<std::size_t>(tiles + 1), 0);
  // Capacity for every element of the finest mesh, taken once: later rebuilds never move the
  // list (untouched capacity costs address space, not resident memory).
  list.entries.reserve(static_cast<std::size_t>(per_slot * mesh.slot_count()));
  auto count_tile = [&](std::int64_t t) {
    std::int64_t count = 0;
    for (std::int64_t s = mesh.tile_slot_begin[t]; s < mesh.tile_slot_begin[t + 1]; ++s) {
      for (int d = 0; d < per_slot; ++d) {
        count += element_is_live(mesh, kind, per_slot * s + d) ? 1 : 0;
      }
    }
    list.tile_begin[t + 1] = count;
  };
  auto fill_tile = [&](std::int64_t t) {
    std::int64_t q = list.tile_begin[t];
    for (std::int64_t s = mesh.tile_slot_begin[t]; s < mesh.tile_slot_begin[t + 1]; ++s) {
      for (int d = 0; d < per_slot; ++d) {
        const std::int64_t id = per_slot * s + d;
        if (element_is_live(mesh, kind, id)) list.entries[q++] = static_cast<std::int32_t>(id);
      }
    }
  };
  if (build == ListBuild::parallel_prefix_sum) {
#pragma omp parallel for schedule(static)
    for (std::int64_t t = 0; t < tiles; ++t) count_tile(t);
  } else {
    for (std::int64_t t = 0; t < tiles; ++t) count_tile(t);
  }
  for (std::int64_t t = 0; t < tiles; ++t) list.tile_begin[t + 1] += list.tile_begin[t];
  list.entries.resize(static_cast<std::size_t>(list.tile_begin[tiles]));
  if (build == ListBuild::parallel_prefix_sum) {
#pragma omp parallel for schedule(static)
    for (std::int64_t t = 0; t < tiles; ++t) fill_tile(t);
  } else {
    for (std::int64_t t = 0; t < tiles; ++t) fill_tile(t);
  }
}

}  // namespace

void ActiveLists::rebuild(const ClothMesh& mesh, ListBuild build) {
  build_list(mesh, ElementKind::particles, build, particles);
  build_list(mesh, ElementKind::edges, build, edges);
  build_list(mesh, ElementKind::triples, build, triples);
  build_list(mesh, ElementKind::ghosts, build, ghosts);
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
