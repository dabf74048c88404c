// What `clothbench run|sweep --trace ... --trace-overheads FILE --trace-bandwidth FILE` copy
// into every trace's header for `clothbench predict`: the scheduling costs of the
// scheduling_overhead micro-benchmark (overhead_model.hpp) and the triad's bandwidth by thread
// count (bandwidth_model.hpp), each read and checked once, before any run.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

namespace clothbench::harness {

/// The header entries {"omp_wait_policy": this process's, "overheads": ..., "bandwidth": ...},
/// the last two present when their file is given. `traced`: --trace was given; `trace_flag` names
/// it
/// ("--trace FILE", "--trace DIR"). Throws std::invalid_argument naming the flag, and the file
/// when it cannot be read, or the flag when it is given without --trace.
nlohmann::json trace_model_headers(const std::optional<std::filesystem::path>& overheads,
                                   const std::optional<std::filesystem::path>& bandwidth,
                                   bool traced, const std::string& trace_flag);

}  // namespace clothbench::harness
