#include "kernels/slot_pages.hpp"

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

#include <algorithm>
#include <cstdint>

namespace clothbench::kernels {

SlotRuns unused_slot_runs(const ClothMesh& mesh, std::int64_t shortest) {
  SlotRuns runs;
  const std::int64_t slots = mesh.slot_count();
  std::int64_t first = -1;
  for (std::int64_t s = 0; s < slots; ++s) {
    const bool unused = !is_node(mesh.flags[static_cast<std::size_t>(s)]);
    if (unused && first < 0) first = s;
    if (!unused && first >= 0) {
      if (s - first >= shortest) runs.emplace_back(first, s);
      first = -1;
    }
  }
  if (first >= 0 && slots - first >= shortest) runs.emplace_back(first, slots);
  return runs;
}

std::int64_t shortest_releasable_run(std::size_t slot_bytes) {
#if defined(__linux__) && defined(MADV_DONTNEED)
  static const auto page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  return static_cast<std::int64_t>(
      std::max<std::size_t>(1, page / std::max<std::size_t>(1, slot_bytes)));
#else
  (void)slot_bytes;
  return 1;
#endif
}

std::size_t release_slot_pages(void* data, std::size_t element_bytes, std::size_t per_slot,
                               const SlotRuns& runs) {
#if defined(__linux__) && defined(MADV_DONTNEED)
  static const auto page = static_cast<std::uintptr_t>(sysconf(_SC_PAGESIZE));
  const auto base = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t slot_bytes = element_bytes * per_slot;
  std::size_t released = 0;
  for (const auto& [first, last] : runs) {
    // The whole pages inside the run's bytes: the first page boundary at or after its start,
    // the last at or before its end.
    const std::uintptr_t begin =
        (base + static_cast<std::uintptr_t>(first) * slot_bytes + page - 1) / page * page;
    const std::uintptr_t end =
        (base + static_cast<std::uintptr_t>(last) * slot_bytes) / page * page;
    if (end <= begin) continue;
    // A refused call leaves the pages as they were: the memory stays, the values too.
    if (madvise(reinterpret_cast<void*>(begin), end - begin, MADV_DONTNEED) == 0) {
      released += end - begin;
    }
  }
  return released;
#else
  (void)data;
  (void)element_bytes;
  (void)per_slot;
  (void)runs;
  return 0;
#endif
}

SlotRuns shared_element_runs(const SlotRuns& runs, std::int64_t slots, std::int64_t a,
                             std::int64_t b) {
  const std::int64_t end = std::max(a, b) * slots;
  // Each use's element runs, with the elements past its own a x slots as one more run.
  auto element_runs = [&](std::int64_t per_slot) {
    SlotRuns out;
    for (const auto& [first, last] : runs) {
      if (!out.empty() && out.back().second == per_slot * first) {
        out.back().second = per_slot * last;
      } else {
        out.emplace_back(per_slot * first, per_slot * last);
      }
    }
    if (per_slot * slots < end) {
      if (!out.empty() && out.back().second == per_slot * slots) {
        out.back().second = end;
      } else {
        out.emplace_back(per_slot * slots, end);
      }
    }
    return out;
  };
  const SlotRuns one = element_runs(a), two = element_runs(b);
  // Both lists are sorted and disjoint: merge them, keeping the overlaps.
  SlotRuns shared;
  std::size_t i = 0, j = 0;
  while (i < one.size() && j < two.size()) {
    const std::int64_t first = std::max(one[i].first, two[j].first);
    const std::int64_t last = std::min(one[i].second, two[j].second);
    if (first < last) shared.emplace_back(first, last);
    if (one[i].second < two[j].second) {
      ++i;
    } else {
      ++j;
    }
  }
  return shared;
}

}  // namespace clothbench::kernels
