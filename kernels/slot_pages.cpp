#include "kernels/slot_pages.hpp"

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>
#endif

#include <cstdint>

namespace clothbench::kernels {

SlotRuns unused_slot_runs(const ClothMesh& mesh) {
  SlotRuns runs;
  const std::int64_t slots = mesh.slot_count();
  std::int64_t first = -1;
  for (std::int64_t s = 0; s < slots; ++s) {
    const bool unused = !is_node(mesh.flags[static_cast<std::size_t>(s)]);
    if (unused && first < 0) first = s;
    if (!unused && first >= 0) {
      runs.emplace_back(first, s);
      first = -1;
    }
  }
  if (first >= 0) runs.emplace_back(first, slots);
  return runs;
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

}  // namespace clothbench::kernels
