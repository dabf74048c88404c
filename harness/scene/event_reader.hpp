// Internal to harness/scene: the scripted events of a scene file ([[event]] tables).
// Keys and ranges: scenarios/README.md.
#pragma once

#include <toml++/toml.h>
#include <string>

#include "kernels/simulation_config.hpp"

namespace clothbench::harness::scene_detail {

/// The valid values of `kind` in an [[event]] table.
inline constexpr const char* kEventKinds[] = {"move-obstacle", "release-pin", "force"};

/// Reads every [[event]] of `node` into simulation.events (file order), checking each against
/// the scene's `steps`, its obstacles, its grid and its pins (a release needs a particle
/// pinned at that step). Call after [cloth] and [[obstacle]] are read. Throws SceneError.
void read_events(const toml::node& node, const std::string& file, int steps,
                 kernels::SimulationConfig& simulation);

}  // namespace clothbench::harness::scene_detail
