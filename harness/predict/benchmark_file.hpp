// Reading the Google Benchmark JSON that clothbench-micro writes (--benchmark_format=json
// --benchmark_out=FILE), for the predictor's scheduling costs (overhead_model.hpp) and its
// bandwidth ceiling (bandwidth_model.hpp).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace clothbench::harness {

/// The document of `file`, its "benchmarks" array checked. `role` names the file in errors
/// (e.g. "overheads file"). Throws std::invalid_argument naming the file when it cannot be
/// opened, is not JSON, or holds no "benchmarks" array.
nlohmann::json read_benchmark_file(const std::filesystem::path& file, const std::string& role);

}  // namespace clothbench::harness
