// The process's allocator policy: large blocks are mapped on their own and go back to the
// system when freed, so a run's resident memory follows what the simulation holds.
//
// glibc's default raises its mmap threshold each time a mapped block is freed (up to 32 MiB).
// After the first V-cycle structure is freed, the next structures' buffers (a few MiB each)
// then come from the heap, which cannot give back a freed block below one still in use: on
// paper/box-1001 that kept 75 MiB resident after 30 steps that the simulation no longer held.
// A fixed threshold (kLargeBlockBytes) keeps every block of that size mapped.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

namespace clothbench::harness {

/// Blocks of this size or more are mapped on their own (mallopt M_MMAP_THRESHOLD). Smaller
/// ones stay on the heap: a vector of a few thousand doubles reallocated every iteration would
/// otherwise pay a mapping and its page faults each time. 64 KiB and 1 MiB gave the same peak
/// within 7 MiB on box-1001's first 30 steps (663 / 670 MiB, against 738 MiB without).
inline constexpr std::int64_t kLargeBlockBytes = std::int64_t{1} << 20;

/// What configure_allocator() found and did.
struct AllocatorPolicy {
  std::string library;  ///< "glibc 2.36", or "unknown" (another C library: nothing is set)
  /// The fixed mmap threshold in force (bytes), or -1 when the allocator keeps its own
  /// (another C library, or mallopt refused) or when MALLOC_MMAP_THRESHOLD_ is not a decimal
  /// byte count (source "environment": the user's, left alone, its value unknown).
  std::int64_t mmap_threshold_bytes = -1;
  /// Where the threshold came from: "clothbench" (kLargeBlockBytes), "environment"
  /// (MALLOC_MMAP_THRESHOLD_ set by the user, which glibc applies itself and clothbench
  /// leaves alone) or "allocator default" (another C library, or a sanitizer's allocator,
  /// which refuses mallopt and ignores the variable).
  std::string source;
};

/// Sets the policy once, at the start of main, before the simulation allocates; returns it.
/// Later calls return the first call's policy.
AllocatorPolicy configure_allocator();

/// The policy in force (what the first configure_allocator() call returned; "allocator
/// default" if it was never called).
AllocatorPolicy allocator_policy();

/// {library, mmap_threshold_bytes (null when the allocator's own), source}: stored with the
/// machine context.
nlohmann::json to_json(const AllocatorPolicy& policy);

}  // namespace clothbench::harness
