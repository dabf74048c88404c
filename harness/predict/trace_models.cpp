// The predictor's models copied into trace headers (see trace_models.hpp).
#include "harness/predict/trace_models.hpp"

#include <stdexcept>

#include "harness/predict/bandwidth_model.hpp"
#include "harness/predict/overhead_model.hpp"
#include "harness/run/disturbance.hpp"

namespace clothbench::harness {

nlohmann::json trace_model_headers(const std::optional<std::filesystem::path>& overheads,
                                   const std::optional<std::filesystem::path>& bandwidth,
                                   bool traced, const std::string& trace_flag) {
  nlohmann::json headers = nlohmann::json::object();
  // What the traced run's loops paid to wake sleeping threads depends on it (predict compares
  // it with the overhead model's).
  headers["omp_wait_policy"] = omp_wait_policy();
  auto copy = [&](const std::optional<std::filesystem::path>& file, const std::string& flag,
                  const std::string& key, auto&& read) {
    if (!file) return;
    if (!traced) throw std::invalid_argument(flag + ": needs " + trace_flag);
    try {
      headers[key] = read(*file);
    } catch (const std::invalid_argument& error) {
      throw std::invalid_argument(flag + ": " + error.what());
    }
  };
  copy(overheads, "--trace-overheads", "overheads", [](const std::filesystem::path& file) {
    return overhead_model_json(read_overhead_model(file));
  });
  copy(bandwidth, "--trace-bandwidth", "bandwidth", [](const std::filesystem::path& file) {
    return bandwidth_model_json(read_bandwidth_model(file));
  });
  return headers;
}

}  // namespace clothbench::harness
