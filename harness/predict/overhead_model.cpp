// Reading the scheduling-overhead micro-benchmark's results (see overhead_model.hpp).
#include "harness/predict/overhead_model.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

namespace clothbench::harness {

namespace {

/// "dynamic:1@blocks" -> "dynamic"; "nonmonotonic:dynamic:2@blocks" -> "nonmonotonic:dynamic".
std::string kind_of(const std::string& canonical) {
  std::string head = canonical.substr(0, canonical.find('@'));
  const std::size_t colon = head.rfind(':');
  if (colon != std::string::npos &&
      std::all_of(head.begin() + static_cast<std::ptrdiff_t>(colon) + 1, head.end(),
                  [](char c) { return c >= '0' && c <= '9'; })) {
    head.resize(colon);
  }
  return head + canonical.substr(std::min(canonical.size(), canonical.find('@')));
}

}  // namespace

double OverheadModel::dispatch(const std::string& canonical) const {
  if (const auto it = dispatch_seconds.find(canonical); it != dispatch_seconds.end()) {
    return it->second;
  }
  for (const auto& [spec, seconds] : dispatch_seconds) {
    if (kind_of(spec) == kind_of(canonical)) return seconds;
  }
  return 0.0;
}

std::string OverheadModel::dispatch_source(const std::string& canonical) const {
  if (!measured) return "assumed 0";
  if (dispatch_seconds.count(canonical) != 0) return "measured";
  for (const auto& [spec, seconds] : dispatch_seconds) {
    if (kind_of(spec) == kind_of(canonical)) return "from " + spec;
  }
  return "not measured: 0";
}

OverheadModel read_overhead_model(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw std::invalid_argument(file.string() + ": cannot open the overheads file");
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
  struct Figures {
    double loop_seconds;
    double chunks_per_thread;
    int threads;
    bool disturbed;
  };
  std::map<std::string, Figures> by_spec;
  const std::string prefix = "scheduling_overhead/";
  for (const auto& b : document["benchmarks"]) {
    const std::string name = b.value("name", std::string());
    if (name.rfind(prefix, 0) != 0 || !b.contains("overhead_loop_us_median")) continue;
    std::string spec = name.substr(prefix.size());
    spec = spec.substr(0, spec.find('/'));  // "/iterations:30/real_time" follows
    const int threads = static_cast<int>(b.value("threads", 0.0));
    if (threads < 1) continue;
    by_spec[spec] = {1e-6 * b["overhead_loop_us_median"].get<double>(),
                     b.value("chunks_per_loop", 0.0) / threads, threads,
                     b.value("disturbed", 0.0) != 0.0};
  }
  const auto reference = by_spec.find("static@blocks");
  if (reference == by_spec.end()) {
    throw std::invalid_argument(
        file.string() +
        ": holds no scheduling_overhead/static@blocks result (run clothbench-micro "
        "--benchmark_filter=scheduling_overhead --benchmark_format=json --benchmark_out=FILE)");
  }
  OverheadModel model;
  model.measured = true;
  model.measured_threads = reference->second.threads;
  model.loop_seconds = std::max(0.0, reference->second.loop_seconds);
  model.source = fmt::format(
      "{}: scheduling_overhead medians at {} threads (per loop {:.2f} us from static@blocks)",
      file.string(), model.measured_threads, 1e6 * model.loop_seconds);
  for (const auto& [spec, f] : by_spec) {
    if (f.disturbed) model.disturbed.push_back(spec);
    if (spec == "static@blocks" || f.chunks_per_thread <= 0.0 || f.disturbed) continue;
    model.dispatch_seconds[spec] =
        std::max(0.0, (f.loop_seconds - model.loop_seconds) / f.chunks_per_thread);
  }
  model.dispatch_seconds["static@blocks"] = 0.0;
  if (!model.disturbed.empty()) {
    std::string names;
    for (const std::string& spec : model.disturbed) names += (names.empty() ? "" : ", ") + spec;
    model.source += fmt::format(
        "; {} of {} results disturbed by other work on the machine, not "
        "used for dispatch costs: {}",
        model.disturbed.size(), by_spec.size(), names);
  }
  return model;
}

}  // namespace clothbench::harness
