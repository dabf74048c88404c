// The paper's Active-Lists scheme (MODEL.md section 7): the compacted list of active
// elements is split into P near-equal contiguous shares, one per thread, computed by
// hand (no `omp for`), exactly like static scheduling of the list.
#pragma once

#include <omp.h>

#include <cstdint>
#include <string>

namespace clothbench::schedulers {

/// Thread `thread` of `team_size` gets [begin, end): the first n % P threads get one
/// iteration more than the others. Shares are contiguous, ordered by thread number.
struct ContiguousShare {
  std::int64_t begin;
  std::int64_t end;
};

/// Share of thread `thread` (0-based) in a team of `team_size` over [0, n).
[[nodiscard]] inline ContiguousShare contiguous_share(std::int64_t n, int thread, int team_size) {
  const std::int64_t base = n / team_size;
  const std::int64_t extra = n % team_size;
  const std::int64_t begin = thread * base + (thread < extra ? thread : extra);
  return {begin, begin + base + (thread < extra ? 1 : 0)};
}

/// `active-lists`: one contiguous share per thread, then a barrier.
class ActiveListsPartitioner {
 public:
  /// Work-sharing loop (Partitioner contract); ends with a barrier.
  template <class Body>
  void loop(std::int64_t n, Body&& body) const {
    const ContiguousShare share = contiguous_share(n, omp_get_thread_num(), omp_get_num_threads());
    if (share.end > share.begin) body(share.begin, share.end);
#pragma omp barrier
  }
  [[nodiscard]] std::string name() const { return "active-lists"; }
};

}  // namespace clothbench::schedulers
