// The topology of a cloth mesh as far as the solver's set-ups depend on it: its extent, every
// particle's flags (active, pinned, ghost and its direction) and the active edges and
// triples, which fix the neighbour indices. A set-up made for one topology (the smoothing
// colouring, the V-cycle's hierarchy) is kept while its key still matches the mesh: between
// AMRC events and scripted events a step, or a Newton iteration, reuses it.
//
// The key keeps a 64-bit digest of each chunk of kChunkSlots slots (the slots' flag bytes and
// their element ids' two active bytes), not a copy of those bytes: 8 bytes a chunk instead of
// 5 a slot (20.5 kB a chunk; 4.8 MiB per key at the paper's 1001^2). A changed byte goes
// unnoticed only if its chunk's digest collides, about 2^-64 a comparison.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "kernels/cloth_mesh.hpp"

namespace clothbench::kernels {

/// A 64-bit digest of `size` bytes continuing `seed`: four interleaved multiply-rotate lanes
/// over 32-byte stripes (so the loop is not one long chain of multiplications), the tail word
/// by word, then a full avalanche. Not cryptographic; deterministic on every platform.
inline std::uint64_t digest_bytes(const std::uint8_t* data, std::size_t size, std::uint64_t seed) {
  constexpr std::uint64_t k1 = 0x9E3779B185EBCA87ULL, k2 = 0xC2B2AE3D27D4EB4FULL,
                          k3 = 0x165667B19E3779F9ULL;
  const auto rotl = [](std::uint64_t v, int r) { return (v << r) | (v >> (64 - r)); };
  const auto round = [&](std::uint64_t acc, std::uint64_t word) {
    return rotl(acc + word * k2, 31) * k1;
  };
  const auto word_at = [&](std::size_t at, std::size_t n) {
    std::uint64_t w = 0;
    std::memcpy(&w, data + at, n);
    return w;
  };
  std::uint64_t lane[4] = {seed + k1 + k2, seed + k2, seed, seed - k1};
  std::size_t at = 0;
  for (; at + 32 <= size; at += 32) {
    for (int l = 0; l < 4; ++l)
      lane[l] = round(lane[l], word_at(at + 8 * static_cast<std::size_t>(l), 8));
  }
  std::uint64_t h = rotl(lane[0], 1) + rotl(lane[1], 7) + rotl(lane[2], 12) + rotl(lane[3], 18);
  for (const std::uint64_t v : lane) h = (h ^ round(0, v)) * k1 + k3;
  for (; at < size; at += 8) {
    const std::size_t n = size - at < 8 ? size - at : 8;
    h = rotl(h ^ round(0, word_at(at, n)), 27) * k1 + k3;
  }
  h ^= static_cast<std::uint64_t>(size);
  h ^= h >> 33;
  h *= k2;
  h ^= h >> 29;
  h *= k3;
  h ^= h >> 32;
  return h;
}

class TopologyKey {
 public:
  /// Slots a digest covers; matches_slots compares whole chunks.
  static constexpr std::int64_t kChunkSlots = 4096;
  /// Mesh bytes a comparison reads per slot (memory traffic of the checks): a flag byte and
  /// two element ids of one byte each for edges and for triples.
  static constexpr std::size_t kMeshBytesPerSlot = 5;

  /// The digest of chunk `chunk` of `mesh`'s topology.
  [[nodiscard]] static std::uint64_t chunk_digest(const ClothMesh& mesh, std::int64_t chunk) {
    const std::int64_t begin = chunk * kChunkSlots;
    const std::int64_t end = std::min(mesh.slot_count(), begin + kChunkSlots);
    const auto n = static_cast<std::size_t>(end - begin);
    const auto b = static_cast<std::size_t>(begin);
    std::uint64_t h = digest_bytes(mesh.flags.data() + b, n, static_cast<std::uint64_t>(chunk));
    h = digest_bytes(mesh.edge_active.data() + 2 * b, 2 * n, h);
    return digest_bytes(mesh.triple_active.data() + 2 * b, 2 * n, h);
  }
  /// Chunks of a mesh of `slots` slots.
  [[nodiscard]] static std::int64_t chunks(std::int64_t slots) {
    return (slots + kChunkSlots - 1) / kChunkSlots;
  }

  /// True when `mesh` has the topology last taken (never before the first take()).
  [[nodiscard]] bool matches(const ClothMesh& mesh) const {
    return same_extent(mesh) && matches_slots(mesh, 0, mesh.slot_count());
  }
  /// True when a topology was taken from a mesh of `mesh`'s extent (matches_slots may then
  /// compare its slots).
  [[nodiscard]] bool same_extent(const ClothMesh& mesh) const {
    return taken_ && size_i_ == mesh.size_i() && size_j_ == mesh.size_j() &&
           slots_ == mesh.slot_count() &&
           mesh.edge_active.size() == 2 * static_cast<std::size_t>(slots_) &&
           mesh.triple_active.size() == 2 * static_cast<std::size_t>(slots_);
  }
  /// With same_extent(mesh): whether slots [begin, end) and their element ids have the flags
  /// and active elements last taken (a part of matches(), for checks split over threads).
  /// `begin` is a chunk's first slot and `end` one past a chunk's last (or the mesh's end).
  [[nodiscard]] bool matches_slots(const ClothMesh& mesh, std::int64_t begin,
                                   std::int64_t end) const {
    for (std::int64_t c = begin / kChunkSlots; c * kChunkSlots < end; ++c) {
      if (chunk_digest(mesh, c) != digests_[static_cast<std::size_t>(c)]) return false;
    }
    return true;
  }
  void take(const ClothMesh& mesh) {
    taken_ = true;
    size_i_ = mesh.size_i();
    size_j_ = mesh.size_j();
    slots_ = mesh.slot_count();
    digests_.resize(static_cast<std::size_t>(chunks(slots_)));
    for (std::int64_t c = 0; c < chunks(slots_); ++c) {
      digests_[static_cast<std::size_t>(c)] = chunk_digest(mesh, c);
    }
  }
  /// Forgets the topology: the next matches() is false.
  void clear() { taken_ = false; }
  [[nodiscard]] std::size_t memory_bytes() const {
    return digests_.capacity() * sizeof(std::uint64_t);
  }

 private:
  bool taken_ = false;
  int size_i_ = 0, size_j_ = 0;
  std::int64_t slots_ = 0;
  std::vector<std::uint64_t> digests_;
};

}  // namespace clothbench::kernels
