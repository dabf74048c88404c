// The loop-driver interface: the only view the cloth kernel has of a scheduler.
//
// A LoopDriver hands the iterations [0, n) of one parallel loop to the threads of the
// enclosing OpenMP parallel region. It knows nothing about cloth: the kernel decides what
// an iteration is (a block of B x B particles, or an entry of a compacted active list).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

namespace clothbench::schedulers {

/// Which index space a driver's iterations count (MODEL.md section 7).
enum class IterationSpace {
  blocks,  ///< one iteration = one B x B particle block (inactive elements skipped inside)
  active,  ///< one iteration = one entry of a compacted active element list
};

/// Non-owning reference to a callable `void(std::int64_t begin, std::int64_t end)`.
/// Costs one indirect call per chunk, never per element.
class RangeBody {
 public:
  template <class F>
  requires(!std::is_same_v<std::remove_cvref_t<F>, RangeBody>)
      RangeBody(F& f)  // NOLINT(google-explicit-constructor): a view, like std::function_ref
      : object_(static_cast<void*>(&f)),
        call_([](void* o, std::int64_t b, std::int64_t e) { (*static_cast<F*>(o))(b, e); }) {}
  void operator()(std::int64_t begin, std::int64_t end) const { call_(object_, begin, end); }

 private:
  void* object_;
  void (*call_)(void*, std::int64_t, std::int64_t);
};

/// One scheduling backend. `for_range` is a work-sharing construct: it must be called by
/// every thread of the innermost enclosing parallel region (or outside any region, by one
/// thread), calls `body` on disjoint ranges that together cover [0, n) exactly once, and
/// returns on every thread only after all ranges are done (it ends with a barrier).
class LoopDriver {
 public:
  virtual ~LoopDriver() = default;
  virtual void for_range(std::int64_t n, RangeBody body) = 0;
  /// Index space the kernel should present to this driver.
  [[nodiscard]] virtual IterationSpace space() const = 0;
  /// Canonical name, e.g. "dynamic:2@blocks".
  [[nodiscard]] virtual std::string name() const = 0;
  /// Describes a runtime-defect workaround in effect for this driver (empty when none),
  /// e.g. libomp 14 running every iteration of `schedule(monotonic:static)` on every thread.
  [[nodiscard]] virtual std::string note() const { return {}; }
};

}  // namespace clothbench::schedulers
