// Size classes of `clothbench sweep --class S|W|A|B`, after the NAS Parallel Benchmarks:
// one name picks a scene and the sweep settings that suit its size, so that results of the
// same class from different machines compare. The classes and their measured run times are in
// README.md ("Size classes").
#pragma once

#include <span>
#include <string_view>

#include "harness/sweep/sweep_options.hpp"

namespace clothbench::harness {

struct SizeClass {
  std::string_view name;   ///< "S", "W", "A", "B"
  std::string_view scene;  ///< scene file, relative to the shipped scenario directory
  int repeat;              ///< measured repetitions per row and timing level
  int warmup_steps;        ///< steps of each row's uncounted warm-up run
  std::string_view what;   ///< one line for the console and the record
};

/// The classes, smallest first.
std::span<const SizeClass> size_classes();

/// The class of that name; std::invalid_argument naming --class and the valid names otherwise.
const SizeClass& find_size_class(std::string_view name);

/// Sets the scene, and the repetitions and warm-up steps the user did not give, from the class.
/// A scene given as well is an error (std::invalid_argument naming --class and SCENE).
void apply_size_class(const SizeClass& size_class, bool scene_given, bool repeat_given,
                      bool warmup_given, SweepOptions& options);

}  // namespace clothbench::harness
