// Scene files (TOML) and fabric presets -> a validated kernels::SimulationConfig.
// The keys, units, defaults and valid ranges are documented in scenarios/README.md.
// Parsing (toml++ -> typed values with source positions, toml_reader.hpp) is kept apart
// from building and checking the configuration (scene_loader.cpp), as pbrt-v4 does.
#pragma once

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "kernels/kes_parameters.hpp"
#include "kernels/simulation_config.hpp"

namespace clothbench::harness {

/// A scene or presets file that cannot be used. what() reads
/// `FILE:LINE:COLUMN: [section] key: what is wrong (what was expected)`;
/// TOML syntax errors carry toml++'s line and column.
class SceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A place in a scene file (1-based line and column), as the loader's messages name it.
struct SourcePosition {
  unsigned line = 1;
  unsigned column = 1;
};

/// One loaded scene: the validated simulation plus what identifies its source.
struct Scene {
  std::string name;            ///< [scene] name; the file's stem when absent
  std::string description;     ///< [scene] description; may be empty
  std::filesystem::path file;  ///< the scene file as given to load_scene
  std::string source_text;     ///< the file's bytes, for provenance in results
  /// FNV-1a 64-bit hash of source_text, 16 lower-case hex digits (stable across builds).
  std::string source_sha256_or_fnv;
  int steps = 100;                       ///< [scene] steps: time steps to simulate (>= 1)
  kernels::SimulationConfig simulation;  ///< every value checked, vectors normalised
  /// Where the value of [cloth] particles is written: checks made after loading (the memory
  /// estimate) name FILE:LINE:COLUMN like the loader's own errors.
  SourcePosition particles_position;
};

/// Reads, parses and validates `scene_file`. `presets_file` is read only when the scene
/// names a fabric preset ([cloth] fabric = "name"). Throws SceneError.
Scene load_scene(const std::filesystem::path& scene_file,
                 const std::filesystem::path& presets_file);

/// As load_scene, from text already in memory; `file` names it in messages.
Scene parse_scene(std::string_view source_text, const std::filesystem::path& file,
                  const std::filesystem::path& presets_file);

/// The shipped fabric presets: $CLOTHBENCH_PRESETS if set and non-empty, else
/// <source dir>/scenarios/presets/fabrics.toml.
std::filesystem::path default_presets_file();

/// The shipped scenario directory (next to the presets file).
std::filesystem::path scenario_directory();

/// Names of the presets in a presets file, sorted. Throws SceneError.
std::vector<std::string> fabric_preset_names(const std::filesystem::path& presets_file);

/// One validated preset, in Kawabata's units. Throws SceneError (unknown names list the
/// valid ones).
kernels::KesParameters load_fabric_preset(const std::filesystem::path& presets_file,
                                          std::string_view name);

/// FNV-1a 64-bit hash fed piece by piece: hashing pieces in turn gives the hash of their
/// concatenation, without making it.
class Fnv1a64 {
 public:
  void add(std::string_view bytes) {
    for (const char c : bytes) {
      hash_ ^= static_cast<unsigned char>(c);
      hash_ *= 0x100000001b3ull;
    }
  }
  /// The hash so far as 16 lower-case hex digits.
  [[nodiscard]] std::string hex() const;

 private:
  std::uint64_t hash_ = 0xcbf29ce484222325ull;
};

/// FNV-1a 64-bit hash of `bytes` as 16 lower-case hex digits.
std::string fnv1a64_hex(std::string_view bytes);

}  // namespace clothbench::harness
