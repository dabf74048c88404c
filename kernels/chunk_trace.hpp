// The per-chunk trace of a run's parallel loops, kept in memory (issue 17, "Per-chunk
// traces"): every chunk a thread took, every loop instance and where its loop is written.
// The LoopRunner records into it; harness/trace writes it to a file and plots it (the kernel
// does no file I/O). Recording never allocates inside a loop: each thread makes room for the
// loop's largest possible chunk count when it enters the loop (trace_buffers below).
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "kernels/loop_bytes.hpp"

namespace clothbench::kernels {

/// Where a parallel loop is written: the function and line of its LoopRunner call, captured
/// by the default argument (`__builtin_FUNCTION`/`__builtin_LINE`, which GCC and Clang 14
/// provide; std::source_location needs Clang 15 with libstdc++). `function` points to a
/// string literal for the life of the program. `bytes`: the loop's LoopBytes, set by the
/// LoopRunner from its call's argument (the trace records it per loop instance).
struct LoopSite {
  const char* function;
  int line;
  LoopBytes bytes{};
  // NOLINTNEXTLINE(google-explicit-constructor): default-constructed at the caller's line
  constexpr LoopSite(const char* f = __builtin_FUNCTION(), int l = __builtin_LINE())
      : function(f), line(l) {}
};

/// A loop site as the trace stores it: the call site and the element kind (-1: for_index).
struct TraceSite {
  const char* function = "";
  int line = 0;
  int kind = -1;  ///< ElementKind as an int; -1 for for_index loops
};

/// One chunk a thread took: the scheduler's range [begin, end) of the loop's iteration space
/// (blocks, positions in the loop kind's Active-List, or for_index indices), the elements its
/// body visited (live elements; over the lists, entries after widening to whole tiles, so 0
/// for a range holding no tile start), the executing thread, and its start and end in ns
/// since the trace's origin (steady clock). 40 bytes; the trace file's record as is.
struct ChunkRecord {
  std::uint32_t instance;  ///< loop instance (LoopRecord::instance)
  std::int32_t thread;     ///< omp_get_thread_num() of the thread that ran it
  std::int32_t begin;
  std::int32_t end;
  std::int32_t elements;
  std::int32_t reserved;  ///< 0
  std::int64_t start_ns;
  std::int64_t end_ns;
};

/// One parallel loop instance (recorded by thread 0; every thread runs every loop): its step
/// (1-based), the solver iteration it ran in (CG or Newton iterations completed in the step
/// when it started, counted anew in each sub-step), its site (index into sites()), the size n
/// of its iteration space, its span: first thread's entry to last thread's exit (the exit
/// follows the loop's closing barrier), and the unavoidable bytes per element its call
/// declares (LoopBytes::per_element; kBytesNotRecorded in a trace of format 1). 48 bytes;
/// the trace file's record as is.
struct LoopRecord {
  std::uint32_t instance;
  std::int32_t step;
  std::int32_t iteration;
  std::int32_t site;
  std::int64_t n;
  std::int64_t entry_ns;
  std::int64_t exit_ns;
  double bytes_per_element;
};
/// LoopRecord::bytes_per_element of a loop whose trace predates the figure (format 1).
inline constexpr double kBytesNotRecorded = -1.0;
static_assert(sizeof(ChunkRecord) == 40 && std::is_trivially_copyable_v<ChunkRecord>);
static_assert(sizeof(LoopRecord) == 48 && std::is_trivially_copyable_v<LoopRecord>);

/// The trace of one run: per-thread chunk buffers and loop spans, and thread 0's loop records.
/// Set up outside any parallel region (start), then passed to Simulation::step, which tells it
/// the step (begin_step) before its parallel region.
class ChunkTrace {
 public:
  using Clock = std::chrono::steady_clock;

  /// Per-thread storage, on its own cache lines.
  struct alignas(64) PerThread {
    std::vector<ChunkRecord> chunks;
    std::vector<std::int64_t> entry_ns;  ///< per loop instance, this thread's entry
    std::vector<std::int64_t> exit_ns;   ///< per loop instance, this thread's exit
    std::int64_t growths = 0;            ///< buffer enlargements (at loop entry, never inside)
  };

  /// Clears the trace for a team of `threads`, reserves `chunks_per_thread` records per
  /// thread, and takes the origin of the time axis (now).
  void start(int threads, std::size_t chunks_per_thread) {
    threads_.assign(static_cast<std::size_t>(threads), PerThread{});
    for (PerThread& t : threads_) t.chunks.reserve(chunks_per_thread);
    loops_.clear();
    loops_.reserve(4096);
    sites_.clear();
    sites_.reserve(256);
    origin_ = Clock::now();
    step_ = 0;
  }
  /// Called before a step's parallel region: the step number of its loops.
  void begin_step(int step) {
    step_ = step;
    instance_base_ = static_cast<std::uint32_t>(loops_.size());
  }

  [[nodiscard]] std::int64_t ns(Clock::time_point t) const {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(t - origin_).count();
  }
  [[nodiscard]] int step() const { return step_; }
  [[nodiscard]] std::uint32_t instance_base() const { return instance_base_; }
  [[nodiscard]] int thread_count() const { return static_cast<int>(threads_.size()); }
  [[nodiscard]] PerThread& thread(int t) { return threads_[static_cast<std::size_t>(t)]; }
  [[nodiscard]] const PerThread& thread(int t) const {
    return threads_[static_cast<std::size_t>(t)];
  }
  [[nodiscard]] const std::vector<TraceSite>& sites() const { return sites_; }
  /// The loop records with entry_ns/exit_ns widened to all threads' spans.
  [[nodiscard]] std::vector<LoopRecord> loops() const;
  [[nodiscard]] std::int64_t chunk_count() const {
    std::int64_t c = 0;
    for (const PerThread& t : threads_) c += static_cast<std::int64_t>(t.chunks.size());
    return c;
  }

  /// Makes room in thread `t`'s buffers for `max_chunks` more chunks and one more loop
  /// (called at loop entry, so that no record inside the loop allocates).
  void make_room(int t, std::int64_t max_chunks) {
    PerThread& mine = thread(t);
    const std::size_t need = mine.chunks.size() + static_cast<std::size_t>(max_chunks);
    if (need > mine.chunks.capacity()) {
      mine.chunks.reserve(std::max(need, 2 * mine.chunks.capacity()));
      ++mine.growths;
    }
    if (mine.entry_ns.size() == mine.entry_ns.capacity()) {
      const std::size_t more = std::max<std::size_t>(4096, 2 * mine.entry_ns.capacity());
      mine.entry_ns.reserve(more);
      mine.exit_ns.reserve(more);
    }
  }
  /// Thread 0 at loop entry: the loop's record (span completed by end_loop of every thread).
  void add_loop(const LoopSite& site, int kind, std::uint32_t instance, int iteration,
                std::int64_t n, std::int64_t entry_ns) {
    loops_.push_back(LoopRecord{instance, step_, iteration, site_index(site, kind), n, entry_ns,
                                entry_ns, site.bytes.per_element()});
  }
  /// Every thread at loop exit: its span of the loop.
  void end_loop(int t, std::int64_t entry_ns, std::int64_t exit_ns) {
    PerThread& mine = thread(t);
    mine.entry_ns.push_back(entry_ns);
    mine.exit_ns.push_back(exit_ns);
  }
  /// Records one chunk in thread `t`'s buffer (room made by make_room).
  void add_chunk(int t, const ChunkRecord& record) { thread(t).chunks.push_back(record); }

  /// Seconds one traced chunk costs beyond the untraced loop on this machine (two clock reads
  /// and one record), measured over `records` records into a scratch trace.
  static double measure_record_seconds(int records);

 private:
  std::int32_t site_index(const LoopSite& site, int kind);

  std::vector<PerThread> threads_;
  std::vector<LoopRecord> loops_;  // thread 0 only
  std::vector<TraceSite> sites_;   // thread 0 only
  Clock::time_point origin_{};
  int step_ = 0;
  std::uint32_t instance_base_ = 0;
};

}  // namespace clothbench::kernels
