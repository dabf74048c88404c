// What a resumed sweep must share with the document it continues (`clothbench sweep
// --resume`): the scene, the settings that change how a row is measured, the OpenMP
// environment and the machine context fields of the build and the processor.
#pragma once

#include <filesystem>

#include <nlohmann/json.hpp>

#include "harness/scene/scene.hpp"
#include "harness/sweep/sweep_options.hpp"

namespace clothbench::harness {

/// The document in `file`, after checking that this sweep (`scene` run for `steps` steps,
/// `options`, this `machine` context and `settings` as settings_json gives them) may continue
/// it; otherwise std::invalid_argument naming the first field that differs.
nlohmann::json resumed_document(const std::filesystem::path& file, const Scene& scene, int steps,
                                const SweepOptions& options, const nlohmann::json& machine,
                                const nlohmann::json& settings);

}  // namespace clothbench::harness
