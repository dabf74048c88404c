// Handing back the pages of unused slots (kernels/slot_pages.hpp): which slots count as
// unused, which pages go back (whole pages inside a run only, never a page that also holds a
// slot in use), and an Active-List's capacity beyond its entries.
#include <gtest/gtest.h>

#if defined(__linux__)
#include <unistd.h>
#endif

#include <algorithm>
#include <cstdint>
#include <vector>

#include "kernels/cloth_mesh.hpp"
#include "kernels/simulation_config.hpp"
#include "kernels/slot_pages.hpp"

namespace clothbench {
namespace {

using kernels::SlotRuns;

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
