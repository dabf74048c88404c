// `static` over blocks: plain `omp for schedule(static)`. The baseline driver.
#pragma once

#include <cstdint>
#include <string>

#include "schedulers/loop_driver.hpp"
#include "schedulers/omp_schedule_partitioner.hpp"
#include "schedulers/partitioner.hpp"

namespace clothbench::schedulers {

/// Equal contiguous shares, decided up front (OpenMP `schedule(static)`); the same
/// backend as `make_driver("static@blocks")`, constructible without the registry.
class OmpStaticDriver final : public LoopDriver {
 public:
  explicit OmpStaticDriver(IterationSpace space = IterationSpace::blocks) : space_(space) {}
  void for_range(std::int64_t n, RangeBody body) override { partitioner_.loop(n, body); }
  [[nodiscard]] IterationSpace space() const override { return space_; }
  [[nodiscard]] std::string name() const override {
    return concat(partitioner_.name(), "@", space_name(space_));
  }

 private:
  OmpSchedulePartitioner partitioner_{OmpScheduleKind::static_schedule, OmpScheduleModifier::none,
                                      0};
  IterationSpace space_;
};

}  // namespace clothbench::schedulers
