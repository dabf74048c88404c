// The blocked slot layout (kernels/cloth_mesh.hpp: slot(i, j) and its inverse grid_of(s),
// both computed, not stored), the topology key's chunk digests (kernels/topology_key.hpp),
// and handing back the pages of unused slots
// (kernels/slot_pages.hpp): which slots count as unused, which pages go back (whole pages
// inside a run only, never a page that also holds a slot in use), and an Active-List's
// capacity beyond its entries.
#include <gtest/gtest.h>

#if defined(__linux__)
#include <unistd.h>
#endif

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "kernels/cloth_mesh.hpp"
#include "kernels/simulation_config.hpp"
#include "kernels/slot_pages.hpp"
#include "kernels/topology_key.hpp"

namespace clothbench {
namespace {

using kernels::SlotRuns;

TEST(SlotLayout, SlotAndGridCoordinatesAreInverseAndEveryTileIsOneRowOfOneBlock) {
  // Blocks that divide the grid, that do not (short last block row and column), one block
  // larger than the grid, one-particle blocks, and the paper's 1001^2 in 50 x 50 blocks.
  const int cases[][3] = {{7, 11, 3}, {12, 8, 4}, {5, 5, 10},
                          {4, 6, 1},  {13, 2, 5}, {1001, 1001, 50}};
  for (const auto& [ni, nj, block] : cases) {
    SCOPED_TRACE(testing::Message() << ni << " x " << nj << ", block " << block);
    kernels::ClothConfig cloth;
    cloth.particles_i = ni;
    cloth.particles_j = nj;
    cloth.block_size = block;
    const kernels::ClothMesh mesh(cloth, 0.1);
    const std::int64_t n = mesh.slot_count();
    ASSERT_EQ(n, static_cast<std::int64_t>(ni) * nj);
    std::vector<char> seen(static_cast<std::size_t>(n), 0);
    int failures = 0;
    for (int i = 0; i < ni && failures < 5; ++i) {
      for (int j = 0; j < nj && failures < 5; ++j) {
        const std::int64_t s = mesh.slot(i, j);
        const bool inside = s >= 0 && s < n;
        EXPECT_TRUE(inside) << "(" << i << ", " << j << ") -> " << s;
        if (!inside) {
          ++failures;
          continue;
        }
        EXPECT_EQ(seen[static_cast<std::size_t>(s)], 0) << "slot " << s << " taken twice";
        seen[static_cast<std::size_t>(s)] = 1;
        const auto [gi, gj] = mesh.grid_of(s);
        if (gi != i || gj != j) {
          ADD_FAILURE() << "(" << i << ", " << j << ") -> slot " << s << " -> (" << gi << ", " << gj
                        << ")";
          ++failures;
        }
      }
    }
    // Blocks in row-major block order; each tile is one row of one block, its slots consecutive
    // from the tile's first, left to right; a block's tiles hold its rows coarsest first: the
    // power of two dividing the row index never grows from one tile to the next, and rows of
    // the same power follow in grid order.
    const int blocks_j = (nj + block - 1) / block;
    ASSERT_EQ(mesh.block_count(), static_cast<std::int64_t>((ni + block - 1) / block) * blocks_j);
    const auto power = [](int i) { return i == 0 ? 1 << 30 : i & -i; };
    for (std::int64_t b = 0; b < mesh.block_count(); ++b) {
      const int i0 = static_cast<int>(b / blocks_j) * block,
                j0 = static_cast<int>(b % blocks_j) * block;
      const int width = std::min(nj - j0, block);
      ASSERT_EQ(mesh.block_tile_begin[b + 1] - mesh.block_tile_begin[b], std::min(ni - i0, block));
      std::vector<char> row_seen(static_cast<std::size_t>(block), 0);
      int before = -1;
      for (std::int64_t t = mesh.block_tile_begin[b]; t < mesh.block_tile_begin[b + 1]; ++t) {
        const int i = mesh.grid_of(mesh.tile_slot_begin[t]).first;
        ASSERT_TRUE(i >= i0 && i < i0 + block) << "tile " << t << " holds row " << i;
        ASSERT_EQ(row_seen[static_cast<std::size_t>(i - i0)], 0) << "row " << i << " twice";
        row_seen[static_cast<std::size_t>(i - i0)] = 1;
        if (before >= 0) {
          ASSERT_TRUE(power(before) > power(i) || (power(before) == power(i) && before < i))
              << "row " << i << " stored after row " << before;
        }
        before = i;
        ASSERT_EQ(mesh.tile_slot_begin[t + 1] - mesh.tile_slot_begin[t], width) << "tile " << t;
        for (int k = 0; k < width; ++k) {
          ASSERT_EQ(mesh.slot(i, j0 + k), mesh.tile_slot_begin[t] + k)
              << "tile " << t << ", column " << k;
        }
      }
    }
  }
}

TEST(SlotLayout, RowOrderPutsEachCoarseLatticeFirst) {
  EXPECT_EQ(kernels::ClothMesh::row_order(0, 10), (std::vector<int>{0, 8, 4, 2, 6, 1, 3, 5, 7, 9}));
  EXPECT_EQ(kernels::ClothMesh::row_order(50, 60),
            (std::vector<int>{56, 52, 50, 54, 58, 51, 53, 55, 57, 59}));
  EXPECT_EQ(kernels::ClothMesh::row_order(3, 4), (std::vector<int>{3}));
  // The paper's 1001^2 in 50 x 50 blocks: the rows of an AMRC level-3 region (every 8th) are
  // the first 6 or 7 tiles of every block, so they share the first pages of its arrays.
  kernels::ClothConfig cloth;
  cloth.particles_i = cloth.particles_j = 1001;
  cloth.block_size = 50;
  const kernels::ClothMesh mesh(cloth, 0.1);
  for (int i0 = 0; i0 < 1001; i0 += 50) {
    const int coarse = (std::min(1001, i0 + 50) + 7) / 8 - (i0 + 7) / 8;
    for (int i = i0; i < std::min(1001, i0 + 50); ++i) {
      const std::int64_t place = (mesh.slot(i, 0) - std::int64_t{i0} * 1001) / 50;
      EXPECT_EQ(place < coarse, i % 8 == 0) << "row " << i << " at place " << place;
    }
  }
}

TEST(SlotLayout, GridRowOrderVisitsEverySlotOnceBlockByBlockWithRowsInGridOrder) {
  // The V-cycle numbers its level 0 in this order: every slot once, the blocks in slot()'s
  // order, and inside a block (i, j) row-major in grid order, not in the rows' storage order.
  const int cases[][3] = {{7, 11, 3}, {12, 8, 4}, {5, 5, 10}, {4, 6, 1}, {13, 2, 5}, {101, 67, 50}};
  for (const auto& [ni, nj, block] : cases) {
    SCOPED_TRACE(testing::Message() << ni << " x " << nj << ", block " << block);
    kernels::ClothConfig cloth;
    cloth.particles_i = ni;
    cloth.particles_j = nj;
    cloth.block_size = block;
    const kernels::ClothMesh mesh(cloth, 0.1);
    std::vector<std::pair<int, int>> expected;
    for (int i0 = 0; i0 < ni; i0 += block) {
      for (int j0 = 0; j0 < nj; j0 += block) {
        for (int i = i0; i < std::min(ni, i0 + block); ++i) {
          for (int j = j0; j < std::min(nj, j0 + block); ++j) expected.emplace_back(i, j);
        }
      }
    }
    std::vector<std::pair<int, int>> visited;
    mesh.for_each_slot_in_grid_rows([&](std::int64_t s) { visited.push_back(mesh.grid_of(s)); });
    EXPECT_EQ(visited, expected);
  }
}

TEST(TopologyKey, AChangedFlagOrActiveByteFailsItsChunkAndOnlyItsChunk) {
  kernels::ClothConfig cloth;
  cloth.particles_i = 67;
  cloth.particles_j = 131;  // 8,777 slots: two whole chunks of 4,096 and a partial one
  cloth.block_size = 10;
  kernels::ClothMesh mesh(cloth, 0.1);
  for (std::int64_t s = 0; s < mesh.slot_count(); s += 3) mesh.flags[s] = kernels::kParticleGhost;
  kernels::TopologyKey key;
  EXPECT_FALSE(key.matches(mesh));  // nothing taken yet
  key.take(mesh);
  ASSERT_TRUE(key.matches(mesh));
  const std::int64_t chunk = kernels::TopologyKey::kChunkSlots;
  const std::int64_t chunks = kernels::TopologyKey::chunks(mesh.slot_count());
  ASSERT_EQ(chunks, 3);
  const std::int64_t slots[] = {0, chunk - 1, chunk, 2 * chunk + 17, mesh.slot_count() - 1};
  for (const std::int64_t s : slots) {
    for (int array = 0; array < 3; ++array) {
      for (int d = 0; d < (array == 0 ? 1 : 2); ++d) {
        std::uint8_t& byte = array == 0   ? mesh.flags[static_cast<std::size_t>(s)]
                             : array == 1 ? mesh.edge_active[static_cast<std::size_t>(2 * s + d)]
                                          : mesh.triple_active[static_cast<std::size_t>(2 * s + d)];
        const std::uint8_t kept = byte;
        byte ^= 1;
        SCOPED_TRACE(testing::Message() << "slot " << s << ", array " << array << ", d " << d);
        EXPECT_FALSE(key.matches(mesh));
        for (std::int64_t c = 0; c < chunks; ++c) {
          EXPECT_EQ(
              key.matches_slots(mesh, c * chunk, std::min(mesh.slot_count(), (c + 1) * chunk)),
              c != s / chunk)
              << "chunk " << c;
        }
        byte = kept;
        EXPECT_TRUE(key.matches(mesh));
      }
    }
  }
  // Two bytes swapped inside one chunk change its digest too (positions count, not a sum).
  std::swap(mesh.flags[2], mesh.flags[3]);
  EXPECT_FALSE(key.matches(mesh));
  std::swap(mesh.flags[2], mesh.flags[3]);
  key.clear();
  EXPECT_FALSE(key.matches(mesh));
  // Another extent never matches.
  key.take(mesh);
  cloth.particles_j = 130;
  EXPECT_FALSE(key.matches(kernels::ClothMesh(cloth, 0.1)));
}

TEST(TopologyKey, EverySingleBitFlipOfABufferGivesADifferentDigest) {
  std::vector<std::uint8_t> bytes(20 * 1024 + 5, 0);
  for (std::size_t k = 0; k < bytes.size(); k += 7) bytes[k] = static_cast<std::uint8_t>(k % 5);
  std::vector<std::uint64_t> seen{kernels::digest_bytes(bytes.data(), bytes.size(), 3)};
  for (std::size_t k = 0; k < bytes.size(); k += 97) {
    for (int bit = 0; bit < 8; bit += 3) {
      bytes[k] ^= static_cast<std::uint8_t>(1u << bit);
      seen.push_back(kernels::digest_bytes(bytes.data(), bytes.size(), 3));
      bytes[k] ^= static_cast<std::uint8_t>(1u << bit);
    }
  }
  const std::size_t count = seen.size();
  std::sort(seen.begin(), seen.end());
  EXPECT_EQ(std::unique(seen.begin(), seen.end()) - seen.begin(),
            static_cast<std::ptrdiff_t>(count));
  // The seed and the length count as well.
  EXPECT_NE(kernels::digest_bytes(bytes.data(), bytes.size(), 3),
            kernels::digest_bytes(bytes.data(), bytes.size(), 4));
  EXPECT_NE(kernels::digest_bytes(bytes.data(), 64, 3), kernels::digest_bytes(bytes.data(), 65, 3));
}

TEST(SlotPages, UnusedRunsAreTheMaximalRunsOfSlotsNeitherParticleNorGhost) {
  kernels::ClothConfig cloth;
  cloth.particles_i = 2;
  cloth.particles_j = 5;
  kernels::ClothMesh mesh(cloth, 0.1);
  const std::uint8_t active = kernels::kParticleActive;
  const std::uint8_t ghost = kernels::kParticleGhost;
  const std::uint8_t pinned = kernels::kParticleActive | kernels::kParticlePinned;
  // 0 1 2 3 4 5 6 7 8 9: unused at 0-1, 4, 7-9.
  mesh.flags = {0, 0, active, ghost, 0, pinned, active, 0, 0, 0};
  EXPECT_EQ(kernels::unused_slot_runs(mesh), (SlotRuns{{0, 2}, {4, 5}, {7, 10}}));
  mesh.flags = {active, ghost};
  EXPECT_TRUE(kernels::unused_slot_runs(mesh).empty());
  mesh.flags.assign(5, 0);
  EXPECT_EQ(kernels::unused_slot_runs(mesh), (SlotRuns{{0, 5}}));
  // Runs shorter than `shortest` are left out, the rest kept whole.
  mesh.flags = {0, 0, active, ghost, 0, pinned, active, 0, 0, 0};
  EXPECT_EQ(kernels::unused_slot_runs(mesh, 2), (SlotRuns{{0, 2}, {7, 10}}));
  EXPECT_EQ(kernels::unused_slot_runs(mesh, 3), (SlotRuns{{7, 10}}));
  EXPECT_TRUE(kernels::unused_slot_runs(mesh, 4).empty());
}

TEST(SlotPages, ARunShorterThanTheShortestReleasableHandsBackNoPage) {
  // Wherever it starts, a run one slot shorter than shortest_releasable_run(B) holds no whole
  // page of an array of B bytes a slot, nor of one with fewer bytes a slot; a run of that many
  // slots can (released pages are whole pages inside the run).
  for (const std::size_t slot_bytes :
       {std::size_t{8}, std::size_t{48}, kernels::kLargestReleasedSlotBytes}) {
    const std::int64_t shortest = kernels::shortest_releasable_run(slot_bytes);
    ASSERT_GE(shortest, 1);
#if defined(__linux__)
    const auto page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
    EXPECT_LE(static_cast<std::size_t>(shortest) * slot_bytes, page) << slot_bytes;
    EXPECT_GT(static_cast<std::size_t>(shortest + 1) * slot_bytes, page) << slot_bytes;
    const std::size_t doubles = slot_bytes / sizeof(double);
    std::vector<double> values(doubles * static_cast<std::size_t>(8 * shortest), 1.0);
    for (std::int64_t first = 0; first < 4 * shortest; first += 7) {
      const SlotRuns runs{{first, first + shortest - 1}};
      EXPECT_EQ(kernels::release_slot_pages(values, doubles, runs), 0u) << first;
      EXPECT_EQ(kernels::release_slot_pages(values, 1, runs), 0u) << first;
    }
    for (const double v : values) ASSERT_EQ(v, 1.0);
#endif
  }
}

TEST(SlotPages, SharedElementRunsHoldExactlyTheElementsNeitherUseTouchesAtASlotInUse) {
  // An array of max(a, b) x slots elements read with a elements a slot by one use and b by the
  // other (NewtonSystem's residual in edge_scratch: 2 and 3). Every set of unused runs of a
  // 12-slot mesh, by brute force.
  constexpr std::int64_t kSlots = 12;
  for (const auto& [a, b] : {std::pair<std::int64_t, std::int64_t>{2, 3}, {3, 2}, {6, 3}, {2, 2}}) {
    for (std::uint32_t mask = 0; mask < (1u << kSlots); mask += 7) {
      SlotRuns runs;
      for (std::int64_t s = 0; s < kSlots; ++s) {
        if ((mask >> s & 1u) == 0) continue;  // in use
        if (!runs.empty() && runs.back().second == s) {
          ++runs.back().second;
        } else {
          runs.emplace_back(s, s + 1);
        }
      }
      auto unused = [&](std::int64_t slot) { return slot >= kSlots || (mask >> slot & 1u) != 0; };
      const std::int64_t end = std::max(a, b) * kSlots;
      std::vector<char> expected(static_cast<std::size_t>(end)), got(expected.size());
      for (std::int64_t e = 0; e < end; ++e) expected[e] = unused(e / a) && unused(e / b);
      const SlotRuns shared = kernels::shared_element_runs(runs, kSlots, a, b);
      for (std::size_t k = 0; k < shared.size(); ++k) {
        ASSERT_LT(shared[k].first, shared[k].second);
        if (k > 0) {
          ASSERT_LT(shared[k - 1].second, shared[k].first) << "runs touch or overlap";
        }
        for (std::int64_t e = shared[k].first; e < shared[k].second; ++e) got[e] = 1;
      }
      ASSERT_EQ(got, expected) << "a " << a << ", b " << b << ", unused mask " << mask;
    }
  }
}

TEST(SlotPages, OnlyWholePagesInsideARunGoBackAndReadZero) {
#if defined(__linux__)
  const auto page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  constexpr std::size_t kPerSlot = 3;  // an xyz array of doubles: 24 bytes a slot
  constexpr std::int64_t kSlots = 20000;
  std::vector<double> values(kPerSlot * kSlots);
  for (std::size_t k = 0; k < values.size(); ++k) values[k] = 1.0 + static_cast<double>(k);
  // Runs that start and end inside pages, one shorter than a page, one at the array's end.
  const SlotRuns runs{{100, 1500}, {2000, 2100}, {5003, 9001}, {15000, kSlots}};
  const std::size_t released = kernels::release_slot_pages(values, kPerSlot, runs);

  const auto base = reinterpret_cast<std::uintptr_t>(values.data());
  const std::uintptr_t slot_bytes = kPerSlot * sizeof(double);
  std::size_t expected = 0;
  for (const auto& [first, last] : runs) {
    const std::uintptr_t begin = (base + first * slot_bytes + page - 1) / page * page;
    const std::uintptr_t end = (base + last * slot_bytes) / page * page;
    if (end > begin) expected += end - begin;
  }
  EXPECT_EQ(released, expected);
  EXPECT_GT(released, 0u);

  // Every value in a released page reads zero; every other value is kept, in particular every
  // slot outside the runs, including those sharing a page with a run.
  std::size_t zeros = 0;
  for (std::int64_t s = 0; s < kSlots; ++s) {
    const bool in_run = std::any_of(runs.begin(), runs.end(),
                                    [s](const auto& r) { return s >= r.first && s < r.second; });
    for (std::size_t d = 0; d < kPerSlot; ++d) {
      const std::size_t k = kPerSlot * static_cast<std::size_t>(s) + d;
      const std::uintptr_t at = base + k * sizeof(double);
      const bool page_released = std::any_of(runs.begin(), runs.end(), [&](const auto& r) {
        const std::uintptr_t begin = (base + r.first * slot_bytes + page - 1) / page * page;
        const std::uintptr_t end = (base + r.second * slot_bytes) / page * page;
        return at >= begin && at < end;
      });
      if (page_released) {
        ASSERT_TRUE(in_run) << "slot " << s << " is in use but its page went back";
        ASSERT_EQ(values[k], 0.0) << "slot " << s;
        ++zeros;
      } else {
        ASSERT_EQ(values[k], 1.0 + static_cast<double>(k)) << "slot " << s << " lost its value";
      }
    }
  }
  EXPECT_EQ(zeros * sizeof(double), released);

  // The array keeps its size and address and can be written again where pages went back.
  const double* data = values.data();
  values[kPerSlot * 6000] = 42.0;
  EXPECT_EQ(values.data(), data);
  EXPECT_EQ(values[kPerSlot * 6000], 42.0);
  EXPECT_EQ(values.size(), kPerSlot * kSlots);
#else
  // Without madvise nothing goes back and every value stays.
  std::vector<double> values(3000, 1.0);
  EXPECT_EQ(kernels::release_slot_pages(values, 3, SlotRuns{{0, 1000}}), 0u);
  EXPECT_TRUE(std::all_of(values.begin(), values.end(), [](double v) { return v == 1.0; }));
#endif
}

TEST(SlotPages, ListCapacityBeyondTheEntriesGoesBackAndGrowsAgain) {
  // What an Active-List keeps of the finest mesh's capacity on a coarse mesh goes back to the
  // system; the entries stay, and the vector grows again into fresh zeros.
  std::vector<std::int32_t> entries;
  entries.reserve(1 << 20);
  entries.assign(1 << 20, 7);
  entries.resize(1000);
  const std::size_t released = kernels::release_capacity_tail(entries);
#if defined(__linux__)
  EXPECT_GE(released, (std::size_t{1} << 22) - 2 * 4096 - 4000);
#endif
  EXPECT_LE(released, (std::size_t{1} << 22) - 4000);
  EXPECT_TRUE(std::all_of(entries.begin(), entries.end(), [](std::int32_t v) { return v == 7; }));
  const std::int32_t* data = entries.data();
  entries.resize(1 << 20);
  EXPECT_EQ(entries.data(), data) << "the list did not move";
  EXPECT_EQ(std::count(entries.begin(), entries.end(), 7), 1000);
  EXPECT_EQ(std::count(entries.begin(), entries.end(), 0), (1 << 20) - 1000);
  entries.resize(entries.capacity());
  EXPECT_EQ(kernels::release_capacity_tail(entries), 0u) << "no capacity beyond the entries";
}

}  // namespace
}  // namespace clothbench
