// Reading the triad's bandwidth by thread count (see bandwidth_model.hpp).
#include "harness/predict/bandwidth_model.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>
#include <vector>

#include "harness/predict/benchmark_file.hpp"

namespace clothbench::harness {

namespace {

/// "1 thread 9.81 GB/s, 2 threads 12.40 GB/s".
std::string figures(const std::map<int, double>& triad) {
  std::string text;
  for (const auto& [threads, rate] : triad) {
    text += fmt::format("{}{} thread{} {:.2f} GB/s", text.empty() ? "" : ", ", threads,
                        threads == 1 ? "" : "s", 1e-9 * rate);
  }
  return text;
}

/// Throws naming `where` unless `rate` is a positive, finite number of bytes per second.
double positive_rate(const nlohmann::json& rate, const std::string& where) {
  if (rate.is_null()) throw std::invalid_argument(where + ": no bytes_per_second");
  if (!rate.is_number() || !(rate.get<double>() > 0.0) || !std::isfinite(rate.get<double>())) {
    throw std::invalid_argument(
        fmt::format("{}: bytes_per_second {} is not a positive number of bytes per second", where,
                    rate.dump()));
  }
  return rate.get<double>();
}

/// Throws naming `where` when `triad` holds no 1-thread figure.
void require_one_thread(const std::map<int, double>& triad, const std::string& where) {
  if (triad.count(1) == 0) {
    throw std::invalid_argument(where +
                                ": holds no triad at 1 thread (the ceiling at 1 thread needs it)");
  }
}

}  // namespace

double BandwidthModel::at(int threads) const {
  if (triad.empty()) return 0.0;
  const auto above = triad.lower_bound(threads);
  if (above == triad.end()) return triad.rbegin()->second;  // flat beyond the largest
  if (above->first == threads || above == triad.begin()) return above->second;
  const auto below = std::prev(above);
  const double share = static_cast<double>(threads - below->first) /
                       static_cast<double>(above->first - below->first);
  return below->second + share * (above->second - below->second);
}

std::string BandwidthModel::basis(int threads) const {
  if (triad.empty()) return "none";
  if (triad.count(threads) != 0) return "measured";
  const int largest = largest_threads();
  if (threads > largest) {
    return fmt::format("flat beyond {0} core{1}: the {0}-core triad", largest,
                       largest == 1 ? "" : "s");
  }
  const auto above = triad.lower_bound(threads);
  return fmt::format("interpolated between {} and {} threads", std::prev(above)->first,
                     above->first);
}

BandwidthModel read_bandwidth_model(const std::filesystem::path& file) {
  const nlohmann::json document = read_benchmark_file(file, "bandwidth file");
  std::map<int, std::vector<double>> rates;
  for (const auto& b : document["benchmarks"]) {
    const std::string name = b.value("name", std::string());
    if (name.rfind("triad/", 0) != 0 || b.value("run_type", std::string()) == "aggregate") {
      continue;
    }
    const std::string where = file.string() + ": " + name;
    const int threads = static_cast<int>(b.value("threads", 0.0));
    if (threads < 1) throw std::invalid_argument(where + ": no `threads` counter of at least 1");
    rates[threads].push_back(
        positive_rate(b.contains("bytes_per_second") ? b["bytes_per_second"] : nullptr, where));
  }
  if (rates.empty()) {
    throw std::invalid_argument(file.string() +
                                ": holds no triad result (run clothbench-micro "
                                "--benchmark_filter=^triad --benchmark_format=json "
                                "--benchmark_out=FILE)");
  }
  BandwidthModel model;
  for (auto& [threads, values] : rates) {
    std::sort(values.begin(), values.end());
    const std::size_t n = values.size();
    model.triad[threads] = n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
  }
  require_one_thread(model.triad, file.string());
  const nlohmann::json context = document.value("context", nlohmann::json::object());
  model.source =
      fmt::format("{}: STREAM triad of clothbench-micro{}{}: {}", file.string(),
                  context.contains("date") ? ", " + context.value("date", "") : "",
                  context.contains("host_name") ? " on " + context.value("host_name", "") : "",
                  figures(model.triad));
  if (context.contains("clothbench_micro_smoke")) {
    model.source += " (SMOKE run: arrays that fit in cache, not a memory bandwidth)";
  }
  return model;
}

nlohmann::json bandwidth_model_json(const BandwidthModel& model) {
  nlohmann::json triad = nlohmann::json::array();
  for (const auto& [threads, rate] : model.triad) {
    triad.push_back({{"threads", threads}, {"bytes_per_second", rate}});
  }
  return {{"source", model.source}, {"triad", triad}};
}

BandwidthModel bandwidth_model_from_json(const nlohmann::json& stored, const std::string& origin) {
  const std::string where = origin + ": bandwidth";
  BandwidthModel model;
  try {
    for (const auto& entry : stored.at("triad")) {
      const int threads = entry.at("threads").get<int>();
      if (threads < 1) throw std::invalid_argument(where + ": threads below 1");
      model.triad[threads] =
          positive_rate(entry.contains("bytes_per_second") ? entry["bytes_per_second"] : nullptr,
                        fmt::format("{} at {} threads", where, threads));
    }
    model.source = origin + ", copied from " + stored.at("source").get<std::string>();
  } catch (const nlohmann::json::exception& error) {
    throw std::invalid_argument(where + ": " + error.what());
  }
  require_one_thread(model.triad, where);
  return model;
}

}  // namespace clothbench::harness
