// Reading clothbench-micro's Google Benchmark JSON (see benchmark_file.hpp).
#include "harness/predict/benchmark_file.hpp"

#include <fstream>
#include <stdexcept>

namespace clothbench::harness {

nlohmann::json read_benchmark_file(const std::filesystem::path& file, const std::string& role) {
  std::ifstream in(file);
  if (!in) throw std::invalid_argument(file.string() + ": cannot open the " + role);
  nlohmann::json document;
  try {
    document = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& error) {
    throw std::invalid_argument(file.string() + ": not JSON: " + error.what());
  }
  if (!document.is_object() || !document.contains("benchmarks") ||
      !document["benchmarks"].is_array()) {
    throw std::invalid_argument(file.string() +
                                ": not Google Benchmark JSON (no \"benchmarks\" array)");
  }
  return document;
}

}  // namespace clothbench::harness
