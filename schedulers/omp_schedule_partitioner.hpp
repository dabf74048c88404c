// The OpenMP schedule clauses as partitioners: `static`, `static:k`, `dynamic:k`,
// `guided:k` and `runtime`, each optionally with the OpenMP 4.5 `monotonic:` or
// `nonmonotonic:` modifier. Every variant is the literal `#pragma omp for schedule(...)`
// so the OpenMP runtime hands out the iterations exactly as it would in the paper's code.
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>
#include <type_traits>

#include "schedulers/text.hpp"

namespace clothbench::schedulers {

/// The schedule kind of an OpenMP `schedule` clause.
enum class OmpScheduleKind { static_schedule, dynamic_schedule, guided_schedule, runtime_schedule };

/// The optional OpenMP 4.5 schedule modifier.
enum class OmpScheduleModifier { none, monotonic, nonmonotonic };

/// Spec prefix of a modifier: "", "monotonic:" or "nonmonotonic:".
[[nodiscard]] inline const char* modifier_prefix(OmpScheduleModifier modifier) {
  if (modifier == OmpScheduleModifier::monotonic) return "monotonic:";
  if (modifier == OmpScheduleModifier::nonmonotonic) return "nonmonotonic:";
  return "";
}

/// Calls a range body once per run of consecutive iterations a thread receives, cut at
/// the chunk boundaries that are known in advance (multiples of `boundary_step`), so a
/// dynamic chunk's work runs as soon as its last iteration is handed out: never later.
/// Use `boundary_step` = 1 when chunk boundaries are unknown (guided, runtime).
template <class Body>
class ChunkRun {
 public:
  ChunkRun(Body& body, std::int64_t n, std::int64_t boundary_step)
      : body_(body),
        n_(n),
        step_(std::max<std::int64_t>(boundary_step, 1)),
        boundary_(std::min(n_, step_)) {}
  /// Records that this thread received iteration `i`.
  void add(std::int64_t i) {
    if (i != end_) {
      flush();
      begin_ = i;
      boundary_ = std::min(n_, (i / step_ + 1) * step_);
    }
    end_ = i + 1;
    if (end_ == boundary_) {
      body_(begin_, end_);
      begin_ = end_;
      boundary_ = std::min(n_, boundary_ + step_);
    }
  }
  /// Runs the pending range, if any (call after the loop).
  void flush() {
    if (end_ > begin_) body_(begin_, end_);
    begin_ = end_;
  }

 private:
  Body& body_;
  std::int64_t n_;
  std::int64_t step_;
  std::int64_t begin_ = 0;
  std::int64_t end_ = 0;
  std::int64_t boundary_ = 0;
};

/// One OpenMP schedule clause. `chunk` is the clause's chunk size (0 = none, only
/// meaningful for `static`; dynamic and guided default to 1). `effective_modifier` is the
/// modifier actually compiled in: equal to `modifier` unless a runtime defect forces a
/// workaround (see schedulers/self_test.hpp), while `name()` always shows `modifier`.
class OmpSchedulePartitioner {
 public:
  OmpSchedulePartitioner(OmpScheduleKind kind, OmpScheduleModifier modifier, int chunk,
                         OmpScheduleModifier effective_modifier)
      : kind_(kind), modifier_(modifier), effective_(effective_modifier), chunk_(chunk) {}
  OmpSchedulePartitioner(OmpScheduleKind kind, OmpScheduleModifier modifier, int chunk)
      : OmpSchedulePartitioner(kind, modifier, chunk, modifier) {}

  /// Work-sharing loop (Partitioner contract); ends with a barrier.
  template <class Body>
  void loop(std::int64_t n, Body&& body) const {
    const int chunk = std::max(chunk_, 1);
    // Only static without a chunk and chunked static/dynamic have boundaries known in
    // advance; guided and runtime get one body call per iteration.
    std::int64_t boundary_step = 1;
    if (kind_ == OmpScheduleKind::static_schedule) boundary_step = chunk_ > 0 ? chunk_ : n;
    if (kind_ == OmpScheduleKind::dynamic_schedule) boundary_step = chunk;
    ChunkRun<std::remove_reference_t<Body>> run(body, n, boundary_step);
    switch (kind_) {
      case OmpScheduleKind::static_schedule:
        if (chunk_ > 0) {
          static_chunked(n, chunk, run);
        } else {
          static_unchunked(n, run);
        }
        break;
      case OmpScheduleKind::dynamic_schedule:
        dynamic(n, chunk, run);
        break;
      case OmpScheduleKind::guided_schedule:
        guided(n, chunk, run);
        break;
      case OmpScheduleKind::runtime_schedule:
        runtime(n, run);
        break;
    }
    run.flush();
#pragma omp barrier
  }

  /// Scheduling part of the spec, e.g. "monotonic:static:4" or "guided:1".
  [[nodiscard]] std::string name() const {
    std::string text = modifier_prefix(modifier_);
    switch (kind_) {
      case OmpScheduleKind::static_schedule:
        text += "static";
        break;
      case OmpScheduleKind::dynamic_schedule:
        text += "dynamic";
        break;
      case OmpScheduleKind::guided_schedule:
        text += "guided";
        break;
      case OmpScheduleKind::runtime_schedule:
        return text + "runtime";
    }
    if (kind_ != OmpScheduleKind::static_schedule || chunk_ > 0) {
      text += concat(":", std::max(chunk_, 1));
    }
    return text;
  }

 private:
  // One function per kind; each case is the literal clause. `nowait` + the barrier in
  // loop() equals the implicit barrier, after this thread's last range has run.
  template <class Run>
  void static_unchunked(std::int64_t n, Run& run) const {
    switch (effective_) {
      case OmpScheduleModifier::none:
#pragma omp for schedule(static) nowait
        for (std::int64_t i = 0; i < n; ++i) run.add(i);
        break;
      case OmpScheduleModifier::monotonic:
#pragma omp for schedule(monotonic : static) nowait
        for (std::int64_t i = 0; i < n; ++i) run.add(i);
        break;
      case OmpScheduleModifier::nonmonotonic:
#pragma omp for schedule(nonmonotonic : static) nowait
        for (std::int64_t i = 0; i < n; ++i) run.add(i);
        break;
    }
  }
  template <class Run>
  void static_chunked(std::int64_t n, int chunk, Run& run) const {
    switch (effective_) {
      case OmpScheduleModifier::none:
#pragma omp for schedule(static, chunk) nowait
        for (std::int64_t i = 0; i < n; ++i) run.add(i);
        break;
      case OmpScheduleModifier::monotonic:
#pragma omp for schedule(monotonic : static, chunk) nowait
        for (std::int64_t i = 0; i < n; ++i) run.add(i);
        break;
      case OmpScheduleModifier::nonmonotonic:
#pragma omp for schedule(nonmonotonic : static, chunk) nowait
        for (std::int64_t i = 0; i < n; ++i) run.add(i);
        break;
    }
  }
  template <class Run>
  void dynamic(std::int64_t n, int chunk, Run& run) const {
    switch (effective_) {
      case OmpScheduleModifier::none:
#pragma omp for schedule(dynamic, chunk) nowait
        for (std::int64_t i = 0; i < n; ++i) run.add(i);
        break;
      case OmpScheduleModifier::monotonic:
#pragma omp for schedule(monotonic : dynamic, chunk) nowait
        for (std::int64_t i = 0; i < n; ++i) run.add(i);
        break;
      case OmpScheduleModifier::nonmonotonic:
#pragma omp for schedule(nonmonotonic : dynamic, chunk) nowait
        for (std::int64_t i = 0; i < n; ++i) run.add(i);
        break;
    }
  }
  template <class Run>
  void guided(std::int64_t n, int chunk, Run& run) const {
    switch (effective_) {
      case OmpScheduleModifier::none:
#pragma omp for schedule(guided, chunk) nowait
        for (std::int64_t i = 0; i < n; ++i) run.add(i);
        break;
      case OmpScheduleModifier::monotonic:
#pragma omp for schedule(monotonic : guided, chunk) nowait
        for (std::int64_t i = 0; i < n; ++i) run.add(i);
        break;
      case OmpScheduleModifier::nonmonotonic:
#pragma omp for schedule(nonmonotonic : guided, chunk) nowait
        for (std::int64_t i = 0; i < n; ++i) run.add(i);
        break;
    }
  }
  template <class Run>
  void runtime(std::int64_t n, Run& run) const {
    switch (effective_) {
      case OmpScheduleModifier::none:
#pragma omp for schedule(runtime) nowait
        for (std::int64_t i = 0; i < n; ++i) run.add(i);
        break;
      case OmpScheduleModifier::monotonic:
#pragma omp for schedule(monotonic : runtime) nowait
        for (std::int64_t i = 0; i < n; ++i) run.add(i);
        break;
      case OmpScheduleModifier::nonmonotonic:
#pragma omp for schedule(nonmonotonic : runtime) nowait
        for (std::int64_t i = 0; i < n; ++i) run.add(i);
        break;
    }
  }

  OmpScheduleKind kind_;
  OmpScheduleModifier modifier_;
  OmpScheduleModifier effective_;
  int chunk_;
};

}  // namespace clothbench::schedulers
