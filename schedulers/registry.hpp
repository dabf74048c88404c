// The scheduler registry: the type-erased boundary between the harness and the
// partitioners. A scheduler is named by a spec string:
//
//   [monotonic:|nonmonotonic:]<kind>[:<k>][@blocks|@active]
//
// kinds: static[:k] dynamic[:k] guided[:k] runtime (the OpenMP clauses; modifiers allowed),
// taskloop[:g], fac2[:k], tss[:k], gss[:k] (self-scheduling), active-lists.
// dynamic, guided, fac2, tss and gss default to k = 1; static and taskloop without k are
// distinct schedules (no chunk clause). The space defaults to @blocks, except for
// active-lists (@active). Presets name the paper's configurations (Table 2):
// paper-static, paper-dynamic1/2/3, paper-guided, paper-active-lists.
#pragma once

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "schedulers/loop_driver.hpp"
#include "schedulers/omp_schedule_partitioner.hpp"

namespace clothbench::schedulers {

/// A spec parsed into its parts. `chunk` is 0 when the spec gives none and the kind has
/// no default (static, taskloop); otherwise the effective k.
struct SchedulerSpec {
  OmpScheduleModifier modifier = OmpScheduleModifier::none;
  std::string kind;  ///< "static", "dynamic", ..., "active-lists"
  std::int64_t chunk = 0;
  IterationSpace space = IterationSpace::blocks;
  /// Canonical text, e.g. "nonmonotonic:dynamic:2@blocks"; equals the driver's name().
  [[nodiscard]] std::string canonical() const;
};

/// Thrown when a driver fails its self-test probe and no workaround exists.
class SchedulerDefectError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Parses a spec or preset name; throws std::invalid_argument naming the problem and
/// listing the valid names (see scheduler_grammar()).
SchedulerSpec parse_scheduler_spec(std::string_view spec);

/// Builds the driver for `spec`, then probes it (self_test.hpp) with 4 threads. A runtime
/// defect with a spec-exact workaround is worked around and described by note(); any
/// other probe failure throws SchedulerDefectError. Call outside parallel regions.
/// Throws std::invalid_argument for unknown or malformed specs.
std::unique_ptr<LoopDriver> make_driver(std::string_view spec);

/// Builds the literal driver for `spec` with neither probe nor workaround (for tests
/// and defect reports).
std::unique_ptr<LoopDriver> make_driver_without_self_test(std::string_view spec);

/// Canonical specs of one representative driver per kind, modifier and space the
/// registry knows (chunk sizes are free parameters, so this is not every valid spec).
std::vector<std::string> available_schedulers();

/// The paper presets: (preset name, canonical spec).
std::vector<std::pair<std::string, std::string>> scheduler_presets();

/// Human-readable grammar and list of valid names, as used in error messages.
std::string scheduler_grammar();

}  // namespace clothbench::schedulers
