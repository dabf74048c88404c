// Options of `clothbench stress` (see stress_options.hpp).
#include "harness/stress/stress_options.hpp"

#include <fmt/core.h>
#include <fnmatch.h>

#include <stdexcept>

#include "harness/sweep/sweep_options.hpp"

namespace clothbench::harness {

StressSize parse_stress_size(std::string_view text) {
  if (text == "quick") return StressSize::quick;
  if (text == "full") return StressSize::full;
  throw std::invalid_argument(
      fmt::format("--size: '{}' is not a size (expected quick or full)", text));
}

std::string to_string(StressSize size) { return size == StressSize::quick ? "quick" : "full"; }

std::filesystem::path default_stress_base_scene() {
  return std::filesystem::path(CLOTHBENCH_SOURCE_DIR) / "scenarios" / "stress-base.toml";
}

bool cell_selected(std::string_view name, std::string_view only) {
  if (only.empty()) return true;
  const std::string subject(name);
  for (const std::string& pattern : split_list(only, "--only")) {
    if (fnmatch(pattern.c_str(), subject.c_str(), 0) == 0) return true;
  }
  return false;
}

}  // namespace clothbench::harness
