// The allocator policy (allocator.hpp).
#include "harness/machine/allocator.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <climits>
#include <cstdlib>
#include <mutex>

#if defined(__GLIBC__)
#include <gnu/libc-version.h>
#include <malloc.h>
#endif

namespace clothbench::harness {
namespace {

std::mutex policy_mutex;
bool configured = false;
AllocatorPolicy policy_in_force{
#if defined(__GLIBC__)
    fmt::format("glibc {}", gnu_get_libc_version()),
#else
    "unknown",
#endif
    -1, "allocator default"};

/// MALLOC_MMAP_THRESHOLD_: -2 if unset or empty, -1 if set but not a decimal byte count
/// (glibc has made of it what it makes; clothbench leaves it alone all the same), else the value.
std::int64_t environment_threshold() {
  const char* text = std::getenv("MALLOC_MMAP_THRESHOLD_");
  if (text == nullptr || *text == '\0') return -2;
  char* end = nullptr;
  errno = 0;
  const long long value = std::strtoll(text, &end, 10);
  if (errno != 0 || *end != '\0' || value < 0) return -1;
  return value;
}

}  // namespace

AllocatorPolicy configure_allocator() {
  const std::lock_guard<std::mutex> lock(policy_mutex);
  if (configured) return policy_in_force;
  configured = true;
#if defined(__GLIBC__)
  if (const std::int64_t user = environment_threshold(); user == -1) {
    policy_in_force.source = "environment";  // a form clothbench does not read: value unknown
  } else if (user >= 0) {
    // glibc has read it already. Setting it again changes nothing and says whether it took: a
    // sanitizer's allocator, which replaces glibc's, refuses every mallopt.
    if (user <= INT_MAX && mallopt(M_MMAP_THRESHOLD, static_cast<int>(user)) == 1) {
      policy_in_force.mmap_threshold_bytes = user;
      policy_in_force.source = "environment";
    }
  } else if (mallopt(M_MMAP_THRESHOLD, static_cast<int>(kLargeBlockBytes)) == 1) {
    policy_in_force.mmap_threshold_bytes = kLargeBlockBytes;
    policy_in_force.source = "clothbench";
  }
#endif
  return policy_in_force;
}

AllocatorPolicy allocator_policy() {
  const std::lock_guard<std::mutex> lock(policy_mutex);
  return policy_in_force;
}

nlohmann::json to_json(const AllocatorPolicy& policy) {
  return {{"library", policy.library},
          {"mmap_threshold_bytes", policy.mmap_threshold_bytes < 0
                                       ? nlohmann::json(nullptr)
                                       : nlohmann::json(policy.mmap_threshold_bytes)},
          {"source", policy.source}};
}

}  // namespace clothbench::harness
