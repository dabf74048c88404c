// Shared by the in-process stress-cell tests (integration_stress_quick_matrix.cpp: the quick
// matrix, run by scripts/test; slow_stress.cpp: full-size cells, label slow): a cell of the
// shipped matrix by name, one run of it on the static scheduler, and what every passing cell
// must show.
#pragma once

#include <gtest/gtest.h>

#include <ostream>
#include <stdexcept>
#include <string>

#include "harness/scene/scene.hpp"
#include "harness/stress/stress_cell.hpp"
#include "harness/stress/stress_matrix.hpp"
#include "schedulers/registry.hpp"

namespace clothbench::stress_test {

using harness::StressCell;
using harness::StressCellResult;
using harness::StressSize;

/// The cell `name` of the `size` matrix built from the shipped base scene.
inline StressCell cell_of(StressSize size, const std::string& name) {
  const harness::Scene base =
      harness::load_scene(harness::default_stress_base_scene(), harness::default_presets_file());
  for (StressCell& c : harness::stress_matrix(base, size, harness::default_presets_file())) {
    if (c.name == name) return c;
  }
  throw std::invalid_argument("no stress cell " + name);
}

/// Runs `cell` to the end on the static scheduler.
inline StressCellResult run(const StressCell& cell) {
  const auto driver = schedulers::make_driver("static");
  const auto result = harness::run_stress_cell(cell, *driver, [] { return true; });
  if (!result) throw std::logic_error("a cell that is never stopped returned nothing");
  return *result;
}

/// The cell's failure lines, one per line (for test messages).
inline std::string failures(const StressCellResult& r) {
  std::string text;
  for (const std::string& f : r.failures) text += "\n  " + f;
  return text;
}

/// Whatever a cell stresses, these hold when it passes.
inline void expect_passed(const StressCellResult& r) {
  EXPECT_TRUE(r.passed) << r.name << failures(r);
  EXPECT_EQ(r.steps_completed, r.steps_planned) << r.name;
  EXPECT_FALSE(r.non_finite.has_value()) << r.name;
  EXPECT_LE(r.mass_drift, harness::kMassTolerance) << r.name;
  EXPECT_LT(r.max_particle_penetration, r.contact_distance) << r.name;
  EXPECT_LT(r.max_surface_penetration, r.contact_distance) << r.name;
  EXPECT_FALSE(r.cost_trend.growing) << r.name;
  EXPECT_EQ(r.max_ghost_offset, 0.0) << r.name;
}

/// A cell of one size of the matrix, as a test parameter.
struct Named {
  StressSize size;
  const char* name;
};

inline void PrintTo(const Named& n, std::ostream* os) {
  *os << (n.size == StressSize::quick ? "quick " : "full ") << n.name;
}

/// GoogleTest name of a cell: quick_base, full_dt_1e_4, ...
inline std::string test_name(const testing::TestParamInfo<Named>& info) {
  std::string name =
      std::string(info.param.size == StressSize::quick ? "quick_" : "full_") + info.param.name;
  for (char& c : name) {
    if (c == '-' || c == '+' || c == '.') c = '_';
  }
  return name;
}

}  // namespace clothbench::stress_test
