// Returning the memory of unused slots to the system. AMRC keeps the finest mesh's storage
// and flips slots between active and inactive in place (MODEL.md 6), so after coarsening most
// of a per-slot array belongs to slots no particle or ghost uses: at the paper's 1001^2 box, 3 %
// of the 1,002,001 slots are in use after its first events. The pages that hold only such slots
// are handed back (Linux madvise MADV_DONTNEED: the next touch maps a fresh zero page), and the
// arrays keep their size and addresses. Only arrays whose unused entries are never read while
// unused may be released: their values there are lost (they read as zero). Elsewhere (no
// madvise) release_slot_pages does nothing and returns 0.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "kernels/cloth_mesh.hpp"

namespace clothbench::kernels {

/// Maximal runs [first, last) of consecutive slots that are neither a particle nor a ghost
/// (is_node false), in slot order; runs of fewer than `shortest` slots are left out.
using SlotRuns = std::vector<std::pair<std::int64_t, std::int64_t>>;
SlotRuns unused_slot_runs(const ClothMesh& mesh, std::int64_t shortest = 1);

/// A bound on the bytes a slot of any array that Simulation hands back holds (the largest,
/// ClothState's triple_scratch, has 6 doubles: 48 bytes; see ClothState::release_unused).
constexpr std::size_t kLargestReleasedSlotBytes = 64;
/// The fewest slots of `slot_bytes` each that can hold a whole page (1 where pages are not
/// handed back): a shorter run hands back no page of an array of at most that many bytes a
/// slot. Leaving such runs out keeps the list short on a graded mesh, where most unused runs
/// are a slot or a few long (every second slot of every second row at the first coarsening of
/// the paper's box: about 250,000 runs, 4 MB, and 21 MB in shared_element_runs' copies).
std::int64_t shortest_releasable_run(std::size_t slot_bytes);

/// Hands back to the system the whole pages of `data` (an array of `per_slot` elements of
/// `element_bytes` each, per slot) that lie inside one of `runs`. Returns the bytes handed
/// back (the pages' sizes, whether or not they were resident).
std::size_t release_slot_pages(void* data, std::size_t element_bytes, std::size_t per_slot,
                               const SlotRuns& runs);

template <class T>
std::size_t release_slot_pages(std::vector<T>& values, std::size_t per_slot, const SlotRuns& runs) {
  return values.empty() ? 0 : release_slot_pages(values.data(), sizeof(T), per_slot, runs);
}

/// For an array of max(a, b) x `slots` elements that two uses read with `a` and with `b`
/// elements a slot (a scratch array that also holds another loop's vectors): the runs
/// [first, last) of element indices that neither use touches at a slot in use (element e
/// belongs to slot e / a in one use, e / b in the other; beyond a x slots the first use has
/// none). Release them with release_slot_pages(data, element_bytes, 1, ...).
SlotRuns shared_element_runs(const SlotRuns& runs, std::int64_t slots, std::int64_t a,
                             std::int64_t b);

/// Hands back the whole pages of `values`' capacity beyond its size (a vector whose capacity
/// is kept for the finest mesh, e.g. an Active-List, holds fewer entries on a coarser one).
/// Growing it again writes its new elements, so nothing is lost. Returns the bytes.
template <class T>
std::size_t release_capacity_tail(std::vector<T>& values) {
  if (values.capacity() == values.size()) return 0;
  const SlotRuns tail{{static_cast<std::int64_t>(values.size()),
                       static_cast<std::int64_t>(values.capacity())}};
  return release_slot_pages(values.data(), sizeof(T), 1, tail);
}

}  // namespace clothbench::kernels
