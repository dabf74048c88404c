// `taskloop[:g]`: one thread creates the tasks of an OpenMP taskloop (grainsize g, or the
// runtime's default when no g is given) inside `single`; all threads of the team execute
// them. The taskloop's implicit taskgroup and the barrier closing `single` make every
// task finish before any thread returns.
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>
#include <type_traits>

#include "schedulers/text.hpp"

namespace clothbench::schedulers {

/// OpenMP taskloop with an optional grainsize (0 = none).
class TaskloopPartitioner {
 public:
  explicit TaskloopPartitioner(std::int64_t grainsize) : grainsize_(grainsize) {}

  /// Work-sharing loop (Partitioner contract); ends with a barrier.
  template <class Body>
  void loop(std::int64_t n, Body&& body) const {
    // A task's iterations are contiguous but its bounds are not visible to the loop body,
    // so the body runs once per iteration.
    using BodyType = std::remove_reference_t<Body>;
    BodyType* body_pointer = &body;
    const auto call = [body_pointer](std::uint64_t i) {
      (*body_pointer)(static_cast<std::int64_t>(i), static_cast<std::int64_t>(i) + 1);
    };
    // `call` is shared, not firstprivate: a firstprivate copy is written by the compiler's
    // task-duplication code into libomp's recycled task memory, which ThreadSanitizer
    // (Archer) reports as a race with the previous task that used those bytes.
    // Unsigned induction variable: Clang 14 warns (-Wsign-compare) inside its own
    // taskloop lowering for a signed 64-bit one.
    const auto count = static_cast<std::uint64_t>(std::max<std::int64_t>(n, 0));
    const auto grainsize = static_cast<std::uint64_t>(grainsize_);
#pragma omp single
    {
      if (grainsize > 0) {
#pragma omp taskloop grainsize(grainsize) shared(call)
        for (std::uint64_t i = 0; i < count; ++i) call(i);
      } else {
#pragma omp taskloop shared(call)
        for (std::uint64_t i = 0; i < count; ++i) call(i);
      }
    }
  }
  [[nodiscard]] std::string name() const {
    return grainsize_ > 0 ? concat("taskloop:", grainsize_) : std::string("taskloop");
  }

 private:
  std::int64_t grainsize_;
};

}  // namespace clothbench::schedulers
