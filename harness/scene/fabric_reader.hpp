// Internal to harness/scene: KES fabric tables, shared by scene files ([fabric]) and the
// presets file (one table per preset). Keys and ranges: scenarios/README.md.
#pragma once

#include <toml++/toml.h>
#include <string>
#include <string_view>
#include <vector>

#include "harness/scene/toml_reader.hpp"
#include "kernels/kes_parameters.hpp"

namespace clothbench::harness::scene_detail {

/// Applies the KES keys of `reader`'s table and of its `warp` / `weft` sub-tables on top of
/// `fabric`, checking each value's range. Keys other than the KES ones and `extra_keys`
/// are errors.
void read_fabric(const TableReader& reader, kernels::KesParameters& fabric,
                 const std::vector<std::string>& extra_keys);

/// A parsed presets file.
struct PresetsDocument {
  std::string file;
  toml::table document;
};

/// Reads and parses a presets file (SceneError on I/O or syntax errors).
PresetsDocument open_presets(const std::string& file);

/// The preset names of a presets document, sorted.
std::vector<std::string> preset_names(const PresetsDocument& presets);

/// The validated preset `name`; nullopt when there is no such preset.
std::optional<kernels::KesParameters> find_preset(const PresetsDocument& presets,
                                                  std::string_view name);

}  // namespace clothbench::harness::scene_detail
