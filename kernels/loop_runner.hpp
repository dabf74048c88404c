// Runs one element loop of a simulation step through the chosen scheduler, with per-tile
// partial sums for deterministic reductions and optional per-thread work timing
// (MODEL.md section 7), and the per-chunk trace when one is given (chunk_trace.hpp).
//
// Every member is called by every thread of the step's parallel region (or by one thread
// outside any region). Results of `reduce` are identical on all threads and for every
// scheduler and thread count: partials are per tile and combined in tile order.
#pragma once

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <utility>
#include <vector>

#include "kernels/active_lists.hpp"
#include "kernels/chunk_trace.hpp"
#include "kernels/cloth_mesh.hpp"
#include "schedulers/loop_driver.hpp"

namespace clothbench::kernels {

/// How much of the loop timing is recorded.
enum class Instrumentation {
  off,     ///< nothing per loop
  loops,   ///< per thread: time from loop entry to the end of its last chunk
  chunks,  ///< per thread: summed duration of every chunk body
};

/// Seconds from a monotonic clock.
inline double monotonic_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

/// Per-thread timing of the parallel loops of a run (seconds).
struct LoopTimes {
  /// The clock the loops are timed by (monotonic seconds). Tests that check the accounting
  /// against known answers give a clock of their own, so no assertion depends on real time.
  /// A traced loop times its chunks by the trace's clock (one clock pair serves both), so a
  /// clock of one's own is for untraced loops only.
  double (*clock)() = monotonic_seconds;
  struct alignas(64) PerThread {
    double work = 0.0;            ///< time inside loop bodies (see Instrumentation)
    std::int64_t chunks = 0;      ///< chunks executed
    double loop_work[2] = {0, 0}; ///< this loop's work, double-buffered by loop parity
    // The loop in progress, written only by this thread while it runs chunks (under taskloop
    // those may be ranges of a loop another thread started) and consumed by it after the loop.
    double pending_work = 0.0;      ///< summed chunk durations
    double pending_last_end = 0.0;  ///< end of the last chunk (monotonic seconds), 0 if none
    std::int64_t pending_chunks = 0;
  };
  std::vector<PerThread> threads;  ///< one per thread of the team
  double loop_wall = 0.0;          ///< summed wall time of all loops (thread 0, entry to exit)
  std::int64_t loops = 0;          ///< loop executions
  double busiest_sum = 0.0;        ///< sum over loop executions of the busiest thread's work
  double mean_sum = 0.0;           ///< sum over loop executions of the mean thread work
  void resize(int thread_count) { threads.assign(static_cast<std::size_t>(thread_count), {}); }
};

/// Per-tile partial sums of one reduction, double-buffered: a loop writes one buffer while a
/// slower thread may still be summing the other from the previous loop on the same array
/// (consecutive loops are separated by a barrier only at their end). Which buffer is current
/// is tracked per thread by its LoopRunner; every thread of a team runs the same sequence of
/// loops, so they all agree.
template <class Acc>
class TilePartials {
 public:
  TilePartials() = default;
  explicit TilePartials(std::int64_t tiles) { resize(tiles); }
  void resize(std::int64_t tiles) {
    for (auto& b : buffers_) b.assign(static_cast<std::size_t>(tiles), Acc{});
  }
  [[nodiscard]] Acc* buffer(int parity) { return buffers_[parity].data(); }
  /// Sum over tiles, in tile order, of one buffer.
  [[nodiscard]] Acc sum(int parity) const {
    Acc total{};
    for (const Acc& a : buffers_[parity]) total += a;
    return total;
  }
  /// Sum, in tile order, of the tiles that have list entries (tile_begin of an ElementList).
  [[nodiscard]] Acc sum(int parity, const std::vector<std::int64_t>& tile_begin) const {
    Acc total{};
    const std::vector<Acc>& buffer = buffers_[parity];
    for (std::size_t t = 0; t < buffer.size(); ++t) {
      if (tile_begin[t + 1] > tile_begin[t]) total += buffer[t];
    }
    return total;
  }

 private:
  std::vector<Acc> buffers_[2];
};

/// No reduction: the accumulator of loops that only write element slots.
struct NoReduction {};

/// The tile context of loops without per-tile set-up.
struct NoTileContext {};

/// No per-tile set-up (the plain for_each).
struct NoPrepare {
  template <class Acc>
  NoTileContext operator()(std::int64_t /*tile*/, Acc& /*acc*/) const {
    return {};
  }
};

/// The per-step view of mesh, lists, driver and timers. One object per thread.
class LoopRunner {
 public:
  /// `lists` may be null only for a driver over blocks; throws std::logic_error for an
  /// @active driver without lists. `trace`, when not null, receives every loop and chunk
  /// (its begin_step called before the parallel region).
  LoopRunner(schedulers::LoopDriver& driver, const ClothMesh& mesh, const ActiveLists* lists,
             Instrumentation instrumentation, LoopTimes* times, ChunkTrace* trace = nullptr)
      : driver_(driver), mesh_(mesh), lists_(lists), instrumentation_(instrumentation),
        times_(times), trace_(trace) {
    // Over blocks an @active driver would give the same bits (only the work differs), so no
    // result check would notice the missing lists: refuse it instead of falling back.
    if (driver.space() == schedulers::IterationSpace::active && lists == nullptr) {
      throw std::logic_error("LoopRunner: " + driver.name() +
                             " runs over the Active-Lists, but none were given");
    }
  }

  /// Calls body(id, acc) for every live element of `kind`; acc is a fresh Acc per tile and is
  /// stored as that tile's partial when `partials` is not null (sized mesh.tile_count()).
  /// Every loop call declares `bytes`, the unavoidable bytes per element of its body
  /// (loop_bytes.hpp), before the body, and takes its caller's LoopSite by default (the
  /// trace's loop name).
  template <class Acc, class Body>
  void for_each(ElementKind kind, TilePartials<Acc>* partials, LoopBytes bytes, Body&& body,
                LoopSite site = {}) {
    site.bytes = bytes;
    NoPrepare none;
    run_loop<Acc>(kind, partials == nullptr ? nullptr : partials->buffer(flip(partials, kind)),
                  none, [&](std::int64_t id, Acc& acc, NoTileContext) { body(id, acc); }, site);
  }

  /// Same with no reduction.
  template <class Body>
  void for_each(ElementKind kind, LoopBytes bytes, Body&& body, LoopSite site = {}) {
    site.bytes = bytes;
    NoPrepare none;
    run_loop<NoReduction>(kind, nullptr, none,
                          [&](std::int64_t id, NoReduction&, NoTileContext) { body(id); }, site);
  }

  /// As for_each with per-tile set-up (e.g. the contact broad phase): before the elements of
  /// tile t, context = prepare(t, acc) (acc: the tile's fresh accumulator), then
  /// body(id, acc, context) for each. The context is the only safe home of per-tile state: a
  /// tile may run on another thread than the caller's (taskloop), so never the caller's
  /// locals. Over blocks every tile is prepared, over lists every tile with entries.
  template <class Acc, class Prepare, class Body>
  void for_each_prepared(ElementKind kind, TilePartials<Acc>* partials, LoopBytes bytes,
                         Prepare&& prepare, Body&& body, LoopSite site = {}) {
    site.bytes = bytes;
    run_loop<Acc>(kind, partials == nullptr ? nullptr : partials->buffer(flip(partials, kind)),
                  prepare, body, site);
  }

  /// Same with no reduction: context = prepare(tile), body(id, context).
  template <class Prepare, class Body>
  void for_each_prepared(ElementKind kind, LoopBytes bytes, Prepare&& prepare, Body&& body,
                         LoopSite site = {}) {
    site.bytes = bytes;
    auto tile_start = [&](std::int64_t tile, NoReduction&) { return prepare(tile); };
    run_loop<NoReduction>(
        kind, nullptr, tile_start,
        [&](std::int64_t id, NoReduction&, const auto& context) { body(id, context); }, site);
  }

  /// Calls tile_body(tile, ids, count, acc) once per tile that has live elements of `kind`, with
  /// the tile's live element ids in storage order (exactly the ids for_each visits, grouped by
  /// tile: a tile is never split between calls, whatever the scheduler or thread count).
  /// acc is a fresh Acc per tile, stored as that tile's partial when `partials` is not null.
  /// For kernels that batch a tile's elements into vector lanes (kernels/vector/element_lanes.hpp):
  /// lane groups formed from `ids` are fixed per tile, so results do not depend on the split.
  template <class Acc, class TileBody>
  void for_each_tile(ElementKind kind, TilePartials<Acc>* partials, LoopBytes bytes,
                     TileBody&& tile_body, LoopSite site = {}) {
    site.bytes = bytes;
    Acc* out = partials == nullptr ? nullptr : partials->buffer(flip(partials, kind));
    const int kind_code = static_cast<int>(kind);
    if (driver_.space() == schedulers::IterationSpace::blocks) {
      const int per_slot = ids_per_slot(kind);
      timed_loop(mesh_.block_count(), kind_code, site,
                 [&](std::int64_t b0, std::int64_t b1, auto& timed_call) {
                   timed_call([&] {
                     // Per executing thread: a tile runs start to end inside one task.
                     thread_local std::vector<std::int32_t> ids;
                     std::int64_t live = 0;
                     for (std::int64_t t = mesh_.block_tile_begin[b0];
                          t < mesh_.block_tile_begin[b1]; ++t) {
                       ids.clear();
                       for (std::int64_t s = mesh_.tile_slot_begin[t];
                            s < mesh_.tile_slot_begin[t + 1]; ++s) {
                         for (int d = 0; d < per_slot; ++d) {
                           const std::int64_t id = per_slot * s + d;
                           if (element_is_live(mesh_, kind, id)) {
                             ids.push_back(static_cast<std::int32_t>(id));
                           }
                         }
                       }
                       Acc acc{};
                       if (!ids.empty()) {
                         tile_body(t, ids.data(), static_cast<std::int64_t>(ids.size()), acc);
                       }
                       if (out != nullptr) out[t] = acc;
                       live += static_cast<std::int64_t>(ids.size());
                     }
                     return live;
                   });
                 });
      return;
    }
    const ElementList& list = lists_->of(kind);
    list_tiles(list, kind_code, site, [&](std::int64_t t, std::int64_t first, std::int64_t end) {
      Acc acc{};
      tile_body(t, list.entries.data() + first, end - first, acc);
      if (out != nullptr) out[t] = acc;
    });
  }

  /// Calls body(k) for every k in [0, n): work over something other than mesh elements (the
  /// line-solve preconditioner's grid lines). Timed like the element loops (it is parallel
  /// work, not sequential overhead); ends with the driver's barrier. `bytes` per index.
  template <class Body>
  void for_index(std::int64_t n, LoopBytes bytes, Body&& body, LoopSite site = {}) {
    site.bytes = bytes;
    timed_loop(n, -1, site, [&](std::int64_t b, std::int64_t e, auto& timed_call) {
      timed_call([&] {
        for (std::int64_t k = b; k < e; ++k) body(k);
        return e - b;
      });
    });
  }

  /// Sums tile partials in tile order with Acc::operator+=; every thread gets the same value.
  /// Over the Active-Lists, tiles without an entry of the loop's kind are skipped: nothing
  /// wrote their partial (it may hold a value from before an AMRC event). Over blocks every
  /// tile's partial is written, and an empty tile's is zero, so both give the same bits.
  template <class Acc>
  [[nodiscard]] Acc reduce(const TilePartials<Acc>& partials) const {
    const Use* use = find(&partials);
    const int parity = use == nullptr ? 0 : use->parity;
    if (use == nullptr || driver_.space() != schedulers::IterationSpace::active) {
      return partials.sum(parity);
    }
    return partials.sum(parity, lists_->of(use->kind).tile_begin);
  }

  /// The solver iteration the following loops belong to (for the trace; 0 at step start).
  void set_iteration(int iteration) { iteration_ = iteration; }

  [[nodiscard]] const ClothMesh& mesh() const { return mesh_; }
  [[nodiscard]] schedulers::IterationSpace space() const { return driver_.space(); }

 private:
  /// Which buffer of a partials array is current on this thread, and the kind of its loop.
  struct Use {
    const void* array;
    int parity;
    ElementKind kind;
  };
  [[nodiscard]] const Use* find(const void* partials) const {
    for (const Use& u : uses_) {
      if (u.array == partials) return &u;
    }
    return nullptr;
  }
  /// Flips and returns this thread's parity of a partials array (0 after the first flip).
  int flip(const void* partials, ElementKind kind) {
    for (Use& u : uses_) {
      if (u.array == partials) {
        u.kind = kind;
        return u.parity ^= 1;
      }
    }
    uses_.push_back(Use{partials, 0, kind});
    return 0;
  }
  template <class Acc, class Prepare, class Body>
  void run_loop(ElementKind kind, Acc* partials, Prepare& prepare, Body&& body,
                const LoopSite& site);
  /// driver_.for_range(n) with the loop timing: ranges(begin, end, timed_call) runs one
  /// scheduler range and hands its work to timed_call(work), which times it, counts a chunk
  /// and records it in the trace; work() returns the number of elements it visited.
  /// `kind`: ElementKind as an int, -1 for for_index (the trace's site).
  template <class Ranges>
  void timed_loop(std::int64_t n, int kind, const LoopSite& site, Ranges&& ranges);
  /// The loop over an Active-List: timed_loop over its positions, each scheduler range snapped
  /// to whole tiles; visit(t, first, end) for every tile t of the range that has entries (list
  /// positions [first, end)), in tile order. `kind` as for timed_loop.
  template <class TileVisit>
  void list_tiles(const ElementList& list, int kind, const LoopSite& site, TileVisit&& visit);

  template <class Acc, class Prepare, class Body>
  /// Runs the live elements of tile t; returns how many.
  std::int64_t run_tile_blocks(ElementKind kind, std::int64_t t, Acc* partials,
                               Prepare& prepare, Body& body) const {
    Acc acc{};
    const auto context = prepare(t, acc);
    const int per_slot = ids_per_slot(kind);
    std::int64_t live = 0;
    for (std::int64_t s = mesh_.tile_slot_begin[t]; s < mesh_.tile_slot_begin[t + 1]; ++s) {
      for (int d = 0; d < per_slot; ++d) {
        const std::int64_t id = per_slot * s + d;
        if (element_is_live(mesh_, kind, id)) {
          body(id, acc, context);
          ++live;
        }
      }
    }
    if (partials != nullptr) partials[t] = acc;
    return live;
  }

  schedulers::LoopDriver& driver_;
  const ClothMesh& mesh_;
  const ActiveLists* lists_;
  Instrumentation instrumentation_;
  LoopTimes* times_;
  ChunkTrace* trace_;
  int iteration_ = 0;              // solver iteration, for the trace
  std::int64_t loop_counter_ = 0;  // identical on all threads: they run the same loops
  std::vector<Use> uses_;  // buffer in use (and loop kind) per partials array
};

template <class Acc, class Prepare, class Body>
void LoopRunner::run_loop(ElementKind kind, Acc* partials, Prepare& prepare, Body&& body,
                          const LoopSite& site) {
  const int kind_code = static_cast<int>(kind);
  if (driver_.space() == schedulers::IterationSpace::blocks) {
    timed_loop(mesh_.block_count(), kind_code, site,
               [&](std::int64_t b0, std::int64_t b1, auto& timed_call) {
                 timed_call([&] {
                   std::int64_t live = 0;
                   for (std::int64_t t = mesh_.block_tile_begin[b0];
                        t < mesh_.block_tile_begin[b1]; ++t) {
                     live += run_tile_blocks(kind, t, partials, prepare, body);
                   }
                   return live;
                 });
               });
    return;
  }
  const ElementList& list = lists_->of(kind);
  list_tiles(list, kind_code, site, [&](std::int64_t t, std::int64_t first, std::int64_t end) {
    Acc acc{};
    const auto context = prepare(t, acc);
    for (std::int64_t q = first; q < end; ++q) body(list.entries[q], acc, context);
    if (partials != nullptr) partials[t] = acc;
  });
}

template <class TileVisit>
void LoopRunner::list_tiles(const ElementList& list, int kind, const LoopSite& site,
                            TileVisit&& visit) {
  const std::int64_t n = list.size();
  const std::vector<std::int64_t>& begin = list.tile_begin;
  auto tile_containing = [&](std::int64_t q) {
    return static_cast<std::int64_t>(std::upper_bound(begin.begin(), begin.end(), q) -
                                     begin.begin()) - 1;
  };
  // A scheduler's range of list positions is widened/narrowed to whole tiles: every tile
  // belongs to the range holding its first entry, so tile partials never depend on the split.
  auto snap = [&](std::int64_t q) { return q >= n ? n : begin[tile_containing(q)]; };
  timed_loop(n, kind, site, [&](std::int64_t q0, std::int64_t q1, auto& timed_call) {
    const std::int64_t lo = snap(q0), hi = snap(q1);
    if (lo >= hi) return;
    timed_call([&] {
      for (std::int64_t t = tile_containing(lo); begin[t] < hi; ++t) {
        if (begin[t + 1] == begin[t]) continue;
        visit(t, begin[t], begin[t + 1]);
      }
      return hi - lo;
    });
  });
}

template <class Ranges>
void LoopRunner::timed_loop(std::int64_t n, int kind, const LoopSite& site, Ranges&& ranges) {
  const int thread = omp_get_thread_num();
  const bool timed = instrumentation_ != Instrumentation::off && times_ != nullptr;
  ChunkTrace* const trace = trace_;
  const std::uint32_t instance =
      trace == nullptr ? 0 : trace->instance_base() + static_cast<std::uint32_t>(loop_counter_);
  std::int64_t trace_entry = 0;
  if (trace != nullptr) {
    // Room for the most chunks this thread can take (n), so no record below allocates.
    trace->make_room(thread, n);
    trace_entry = trace->ns(ChunkTrace::Clock::now());
    if (thread == 0) trace->add_loop(site, kind, instance, iteration_, n, trace_entry);
  }
  const double entry = timed ? times_->clock() : 0.0;
  // The slot of the thread running a chunk: under taskloop a range may run on another thread
  // than the one that entered this loop, so each chunk is counted where it ran (no shared
  // locals written from two threads).
  auto slot = [&]() -> LoopTimes::PerThread& {
    return times_->threads[static_cast<std::size_t>(omp_get_thread_num())];
  };

  // One clock pair serves both the trace and the chunk timing; the record goes to the
  // executing thread's buffer for the same reason.
  auto traced_call = [&](std::int64_t b, std::int64_t e, auto&& range_work) {
    const ChunkTrace::Clock::time_point t0 = ChunkTrace::Clock::now();
    const std::int64_t elements = range_work();
    const ChunkTrace::Clock::time_point t1 = ChunkTrace::Clock::now();
    const int executing = omp_get_thread_num();
    trace->add_chunk(executing, ChunkRecord{instance, executing, static_cast<std::int32_t>(b),
                                            static_cast<std::int32_t>(e),
                                            static_cast<std::int32_t>(elements), 0,
                                            trace->ns(t0), trace->ns(t1)});
    if (!timed) return;
    auto& mine = slot();
    mine.pending_last_end = std::chrono::duration<double>(t1.time_since_epoch()).count();
    if (instrumentation_ == Instrumentation::chunks) {
      mine.pending_work += std::chrono::duration<double>(t1 - t0).count();
    }
    ++mine.pending_chunks;
  };
  auto timed_call = [&](auto&& range_work) {
    if (!timed) {
      range_work();
      return;
    }
    if (instrumentation_ == Instrumentation::chunks) {
      const double start = times_->clock();
      range_work();
      const double end = times_->clock();
      auto& mine = slot();
      mine.pending_last_end = end;
      mine.pending_work += end - start;
    } else {
      range_work();
      slot().pending_last_end = times_->clock();
    }
    ++slot().pending_chunks;
  };

  auto range = [&](std::int64_t b, std::int64_t e) {
    if (trace == nullptr) {
      ranges(b, e, timed_call);
      return;
    }
    bool ran = false;
    auto traced = [&](auto&& range_work) {
      ran = true;
      traced_call(b, e, range_work);
    };
    ranges(b, e, traced);
    if (!ran) {  // a range of list positions holding no tile start: recorded, empty
      const std::int64_t now = trace->ns(ChunkTrace::Clock::now());
      const int executing = omp_get_thread_num();
      trace->add_chunk(executing,
                       ChunkRecord{instance, executing, static_cast<std::int32_t>(b),
                                   static_cast<std::int32_t>(e), 0, 0, now, now});
    }
  };
  driver_.for_range(n, range);
  if (trace != nullptr) trace->end_loop(thread, trace_entry, trace->ns(ChunkTrace::Clock::now()));

  if (timed) {
    // for_range ended with a barrier, so every thread's entry for this loop's parity is final;
    // no thread can write that entry again before the next loop's barrier.
    const int parity = static_cast<int>(loop_counter_ & 1);
    auto& mine = times_->threads[static_cast<std::size_t>(thread)];
    // A thread that ran no chunk of this loop did no work in it (its last end is its entry).
    const double last_end = mine.pending_chunks > 0 ? mine.pending_last_end : entry;
    const double this_loop =
        instrumentation_ == Instrumentation::chunks ? mine.pending_work : std::max(0.0, last_end - entry);
    mine.work += this_loop;
    mine.chunks += mine.pending_chunks;
    // Consumed here, before the barrier below, not reset at the next loop's entry: a thread
    // still leaving that barrier may already run the next loop's first tasks.
    mine.pending_work = 0.0;
    mine.pending_last_end = 0.0;
    mine.pending_chunks = 0;
    mine.loop_work[parity] = this_loop;
#pragma omp barrier
    if (thread == 0) {
      times_->loop_wall += times_->clock() - entry;
      ++times_->loops;
      const int team = omp_get_num_threads();
      double busiest = 0.0, sum = 0.0;
      for (int k = 0; k < team; ++k) {
        const double w = times_->threads[static_cast<std::size_t>(k)].loop_work[parity];
        busiest = std::max(busiest, w);
        sum += w;
      }
      times_->busiest_sum += busiest;
      times_->mean_sum += sum / team;
    }
  }
  ++loop_counter_;
}

}  // namespace clothbench::kernels
