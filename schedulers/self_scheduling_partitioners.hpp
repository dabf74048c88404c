// Self-scheduling techniques from the dynamic loop scheduling (DLS) literature, each
// implemented with one shared atomic counter:
//   fac2:k  factoring (Hummel, Schonberg & Flynn 1992), batches of P chunks of size
//           max(k, ceil(R / (2P))), R = iterations left when the batch starts;
//   tss:k   trapezoid self-scheduling (Tzen & Ni 1993): first chunk n / (2P), last k,
//           sizes decreasing linearly;
//   gss:k   guided self-scheduling (Polychronopoulos & Kuck 1987): max(k, ceil(R / P)).
//
// Reset between consecutive calls (a thread may enter call j+1 while another is still
// leaving call j): each thread, after its last (failing) grab, increments
// `finished_threads`; the thread that brings it to the team size resets both counters
// and only then reaches the closing barrier. Every grab of call j happens before that
// reset, and every grab of call j+1 happens after the barrier, hence after the reset.
// One barrier per call, like `omp for`; no heap allocation per call.
#pragma once

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <string>

#include "schedulers/text.hpp"

namespace clothbench::schedulers {

/// The shared state of one self-scheduled loop: the next work item (a chunk index or an
/// iteration, depending on the technique) and how many threads have run out of work.
/// Not copyable; one instance serves one team at a time.
class SelfSchedulingCounters {
 public:
  /// Takes `count` work items; returns the first one taken.
  std::int64_t take(std::int64_t count) {
    return next_.fetch_add(count, std::memory_order_relaxed);
  }
  /// The shared next-item counter, for compare-and-swap techniques (gss).
  std::atomic<std::int64_t>& next() { return next_; }
  /// Called once per thread after its last grab; the last of `team_size` threads resets.
  void finish(int team_size) {
    if (finished_threads_.fetch_add(1, std::memory_order_acq_rel) + 1 == team_size) {
      next_.store(0, std::memory_order_relaxed);
      finished_threads_.store(0, std::memory_order_release);
    }
  }

 private:
  alignas(64) std::atomic<std::int64_t> next_{0};
  alignas(64) std::atomic<int> finished_threads_{0};
};

/// fac2:k without threads: bounds [begin, end) of chunk `chunk` (0-based, in grab order) of
/// [0, n) for a team of `team_size` with smallest chunk `minimum` (>= 1); false once [0, n) is
/// exhausted. Batches of team_size chunks of max(minimum, ceil(R / (2P))), R = iterations left
/// when the batch starts. The partitioner and the schedule predictor (harness/predict) share it.
[[nodiscard]] inline bool factoring2_chunk(std::int64_t chunk, std::int64_t n, int team_size,
                                           std::int64_t minimum, std::int64_t& begin,
                                           std::int64_t& end) {
  std::int64_t batch_start = 0;
  while (batch_start < n) {
    const std::int64_t remaining = n - batch_start;
    const std::int64_t size = std::max(minimum, (remaining + 2 * team_size - 1) / (2 * team_size));
    if (chunk < team_size) {
      begin = batch_start + chunk * size;
      end = std::min(n, begin + size);
      return begin < n;
    }
    chunk -= team_size;
    batch_start += team_size * size;
  }
  return false;
}

/// tss:k without threads: the chunk sizes of trapezoid self-scheduling over [0, n) for a team
/// of `team_size`, last chunk `last` (>= 1). Tzen & Ni: f = n / (2P), l = k,
/// N = ceil(2n / (f + l)) chunks, step d = (f - l) / (N - 1) rounded down (so the chunks never
/// fall short of n; the tail is clipped). Shared with the schedule predictor.
struct TrapezoidChunks {
  std::int64_t first = 0;
  std::int64_t last = 1;
  std::int64_t step = 0;
  std::int64_t linear_chunks = 0;  ///< chunks 0..linear_chunks-1 shrink by step; later: last

  TrapezoidChunks(std::int64_t n, int team_size, std::int64_t last_chunk) : last(last_chunk) {
    first = std::max(last, (n + 2 * team_size - 1) / (2 * team_size));
    const std::int64_t chunks =
        std::max<std::int64_t>(1, (2 * n + first + last - 1) / (first + last));
    step = chunks > 1 ? (first - last) / (chunks - 1) : 0;
    linear_chunks = step > 0 ? (first - last) / step + 1 : n + 1;
  }
  /// Bounds of chunk `chunk` (grab order) within [0, n); false once [0, n) is exhausted.
  [[nodiscard]] bool bounds(std::int64_t chunk, std::int64_t n, std::int64_t& begin,
                            std::int64_t& end) const {
    const std::int64_t linear = std::min(chunk, linear_chunks);
    begin = linear * first - step * (linear * (linear - 1) / 2) + (chunk - linear) * last;
    if (begin >= n) return false;
    const std::int64_t size = chunk < linear_chunks ? first - chunk * step : last;
    end = std::min(n, begin + size);
    return true;
  }
};

/// gss:k without threads: the size of the next chunk when `remaining` iterations are left,
/// max(minimum, ceil(remaining / P)) (before clipping to what is left). Shared with the
/// schedule predictor.
[[nodiscard]] inline std::int64_t guided_self_scheduling_size(std::int64_t remaining, int team_size,
                                                              std::int64_t minimum) {
  return std::max(minimum, (remaining + team_size - 1) / team_size);
}

/// Factoring with the fixed factor 2 (`fac2:k`); k = smallest chunk.
class Factoring2Partitioner {
 public:
  explicit Factoring2Partitioner(std::int64_t minimum_chunk)
      : minimum_(std::max<std::int64_t>(minimum_chunk, 1)) {}

  /// Work-sharing loop (Partitioner contract); ends with a barrier.
  template <class Body>
  void loop(std::int64_t n, Body&& body) {
    const int team_size = omp_get_num_threads();
    for (;;) {
      std::int64_t begin = 0;
      std::int64_t end = 0;
      if (!factoring2_chunk(counters_.take(1), n, team_size, minimum_, begin, end)) break;
      body(begin, end);
    }
    counters_.finish(team_size);
#pragma omp barrier
  }
  [[nodiscard]] std::string name() const { return concat("fac2:", minimum_); }

 private:
  std::int64_t minimum_;
  SelfSchedulingCounters counters_;
};

/// Trapezoid self-scheduling (`tss:k`); k = last (smallest) chunk.
class TrapezoidPartitioner {
 public:
  explicit TrapezoidPartitioner(std::int64_t last_chunk)
      : last_(std::max<std::int64_t>(last_chunk, 1)) {}

  /// Work-sharing loop (Partitioner contract); ends with a barrier.
  template <class Body>
  void loop(std::int64_t n, Body&& body) {
    const int team_size = omp_get_num_threads();
    const TrapezoidChunks plan(n, team_size, last_);
    for (;;) {
      std::int64_t begin = 0;
      std::int64_t end = 0;
      if (!plan.bounds(counters_.take(1), n, begin, end)) break;
      body(begin, end);
    }
    counters_.finish(team_size);
#pragma omp barrier
  }
  [[nodiscard]] std::string name() const { return concat("tss:", last_); }

 private:
  std::int64_t last_;
  SelfSchedulingCounters counters_;
};

/// Guided self-scheduling (`gss:k`); k = smallest chunk. A compare-and-swap on the next
/// iteration, since each chunk's size depends on what is left.
class GuidedSelfSchedulingPartitioner {
 public:
  explicit GuidedSelfSchedulingPartitioner(std::int64_t minimum_chunk)
      : minimum_(std::max<std::int64_t>(minimum_chunk, 1)) {}

  /// Work-sharing loop (Partitioner contract); ends with a barrier.
  template <class Body>
  void loop(std::int64_t n, Body&& body) {
    const int team_size = omp_get_num_threads();
    std::atomic<std::int64_t>& next = counters_.next();
    std::int64_t begin = next.load(std::memory_order_relaxed);
    while (begin < n) {
      const std::int64_t size = guided_self_scheduling_size(n - begin, team_size, minimum_);
      const std::int64_t end = std::min(n, begin + size);
      if (next.compare_exchange_weak(begin, end, std::memory_order_relaxed)) {
        body(begin, end);
        begin = next.load(std::memory_order_relaxed);
      }
    }
    counters_.finish(team_size);
#pragma omp barrier
  }
  [[nodiscard]] std::string name() const { return concat("gss:", minimum_); }

 private:
  std::int64_t minimum_;
  SelfSchedulingCounters counters_;
};

}  // namespace clothbench::schedulers
