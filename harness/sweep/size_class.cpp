// Size classes of `clothbench sweep --class` (see size_class.hpp).
#include "harness/sweep/size_class.hpp"

#include <fmt/core.h>

#include <array>
#include <stdexcept>
#include <string>

#include "harness/scene/scene.hpp"

namespace clothbench::harness {

namespace {

// The run times in README.md ("Size classes") are measured with these settings; change them
// together.
constexpr std::array<SizeClass, 4> kClasses{{
    {"S", "box-49-drape.toml", 3, 2,
     "the default job: 49 x 49 cloth draping over the box, 60 steps of 8 ms, AMRC L = 2"},
    {"W", "box-101-amrc.toml", 3, 2,
     "a 101 x 101 cloth lying on the box and draping over its edges, 30 steps of 4 ms, AMRC "
     "L = 2"},
    {"A", "paper/box-1001.toml", 1, 0,
     "the paper's box scene at its own size (Table 2): 1001 x 1001, 100 steps, AMRC L = 3"},
    {"B", "box-2001.toml", 1, 0,
     "the box scene beyond the paper: 2001 x 2001, 100 steps, AMRC L = 4"},
}};

}  // namespace

std::span<const SizeClass> size_classes() { return kClasses; }

const SizeClass& find_size_class(std::string_view name) {
  std::string names;
  for (const SizeClass& c : kClasses) {
    if (c.name == name) return c;
    names += names.empty() ? "" : ", ";
    names += c.name;
  }
  throw std::invalid_argument(
      fmt::format("--class: unknown size class '{}' (expected one of {})", name, names));
}

void apply_size_class(const SizeClass& size_class, bool scene_given, bool repeat_given,
                      bool warmup_given, SweepOptions& options) {
  if (scene_given) {
    throw std::invalid_argument(fmt::format(
        "--class {}: a class names its own scene ({}); give either SCENE or --class, not both",
        size_class.name, size_class.scene));
  }
  options.scene_file = scenario_directory() / size_class.scene;
  options.size_class = std::string(size_class.name);
  if (!repeat_given) options.repeat = size_class.repeat;
  if (!warmup_given) options.warmup_steps = size_class.warmup_steps;
}

}  // namespace clothbench::harness
