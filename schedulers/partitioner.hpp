// The Partitioner concept (Taskflow style) and the adapter that turns a partitioner into a
// type-erased LoopDriver for the registry.
//
// A partitioner is a tiny type with a templated hot loop `loop(n, body)`: a work-sharing
// construct that every thread of the enclosing parallel region calls, that calls
// `body(begin, end)` on disjoint non-empty ranges covering [0, n) exactly once, and that
// returns on every thread only after all ranges are done (it ends with a barrier).
// Kernels may call a partitioner directly (the body is then inlined); the harness
// chooses one by name through `make_driver` (schedulers/registry.hpp).
#pragma once

#include <concepts>
#include <cstdint>
#include <string>
#include <utility>

#include "schedulers/loop_driver.hpp"
#include "schedulers/text.hpp"

namespace clothbench::schedulers {

/// Stand-in for any range body in the Partitioner concept: `void(begin, end)`.
struct RangeBodyArchetype {
  void operator()(std::int64_t begin, std::int64_t end) const;
};

/// A scheduling technique: `loop(n, body)` is a work-sharing loop over [0, n) (see the
/// file comment for its contract) and `name()` gives the scheduling part of the spec,
/// e.g. "nonmonotonic:dynamic:2" (without the `@space` suffix).
template <class P>
concept Partitioner = requires(P& partitioner, const P& constant, std::int64_t n,
                               RangeBodyArchetype body) {
  { partitioner.loop(n, body) } -> std::same_as<void>;
  { constant.name() } -> std::convertible_to<std::string>;
};

/// Text of a space suffix: "blocks" or "active".
[[nodiscard]] inline const char* space_name(IterationSpace space) {
  return space == IterationSpace::blocks ? "blocks" : "active";
}

/// Type-erased LoopDriver owning one partitioner (constructed in place: partitioners
/// with shared atomic counters can be neither copied nor moved).
template <Partitioner P>
class PartitionerDriver final : public LoopDriver {
 public:
  /// Builds the partitioner from `arguments`; `note` describes a defect workaround.
  template <class... Arguments>
  explicit PartitionerDriver(IterationSpace space, std::string note, Arguments&&... arguments)
      : partitioner_(std::forward<Arguments>(arguments)...),
        space_(space),
        note_(std::move(note)) {}

  void for_range(std::int64_t n, RangeBody body) override { partitioner_.loop(n, body); }
  [[nodiscard]] IterationSpace space() const override { return space_; }
  [[nodiscard]] std::string name() const override {
    return concat(partitioner_.name(), "@", space_name(space_));
  }
  [[nodiscard]] std::string note() const override { return note_; }
  /// The wrapped partitioner, for callers that want the inlined hot loop.
  [[nodiscard]] P& partitioner() { return partitioner_; }

 private:
  P partitioner_;
  IterationSpace space_;
  std::string note_;
};

}  // namespace clothbench::schedulers
