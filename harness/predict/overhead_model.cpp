// Reading the scheduling-overhead micro-benchmark's results (see overhead_model.hpp).
#include "harness/predict/overhead_model.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <utility>
#include <vector>

#include "harness/predict/benchmark_file.hpp"

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
  const nlohmann::json document = read_benchmark_file(file, "overheads file");
  struct Figures {
    double loop_seconds;
    double chunks_per_thread;
    bool disturbed;
  };
  // By spec, then team size.
  std::map<std::string, std::map<int, Figures>> by_spec;
  std::map<std::string, std::map<int, double>> round_trips;  // by spec, team size: ns
  const std::string prefix = "scheduling_overhead/";
  for (const auto& b : document["benchmarks"]) {
    const std::string name = b.value("name", std::string());
    if (name.rfind(prefix, 0) != 0 || !b.contains("overhead_loop_us_median")) continue;
    std::string spec = name.substr(prefix.size());
    spec = spec.substr(0, spec.find('/'));  // "/threads:T/iterations:30/real_time" follows
    const int threads = static_cast<int>(b.value("threads", 0.0));
    if (threads < 1) continue;
    double sum = 0.0;
    int count = 0;
    for (const char* key : {"core_round_trip_ns_before", "core_round_trip_ns_after"}) {
      if (b.contains(key) && b[key].is_number() && b[key].get<double>() > 0.0) {
        sum += b[key].get<double>();
        ++count;
      }
    }
    if (count > 0) round_trips[spec][threads] = sum / count;
    by_spec[spec][threads] = {1e-6 * b["overhead_loop_us_median"].get<double>(),
                              b.value("chunks_per_loop", 0.0) / threads,
                              b.value("disturbed", 0.0) != 0.0};
  }
  const std::string rerun =
      "(run clothbench-micro --benchmark_filter=scheduling_overhead --benchmark_format=json "
      "--benchmark_out=FILE, which measures 1 thread and the machine's team size)";
  const auto reference = by_spec.find("static@blocks");
  if (reference == by_spec.end()) {
    throw std::invalid_argument(file.string() +
                                ": holds no scheduling_overhead/static@blocks result " + rerun);
  }
  const auto& sizes = reference->second;
  const int team = sizes.rbegin()->first;
  if (sizes.count(1) == 0 || team < 2) {
    throw std::invalid_argument(fmt::format(
        "{}: holds scheduling_overhead/static@blocks at {} thread{} only; the model adds what P "
        "threads cost beyond 1 thread and needs both {}",
        file.string(), team, team == 1 ? "" : "s", rerun));
  }
  const Figures& static_one = sizes.at(1);
  const Figures& static_team = sizes.at(team);
  OverheadModel model;
  model.measured = true;
  model.measured_threads = team;
  const auto round_trip = [&](const std::string& spec) {
    const auto it = round_trips.find(spec);
    if (it == round_trips.end()) return 0.0;
    const auto at = it->second.find(team);
    return at == it->second.end() ? 0.0 : at->second;
  };
  model.round_trip_ns = round_trip("static@blocks");
  if (document.contains("context") && document["context"].is_object() &&
      document["context"].contains("omp_wait_policy")) {
    model.wait_policy = document["context"]["omp_wait_policy"].get<std::string>();
  }
  model.loop_seconds_at_one = static_one.loop_seconds;
  model.loop_seconds_at_measured = static_team.loop_seconds;
  model.loop_seconds = std::max(0.0, static_team.loop_seconds - static_one.loop_seconds);
  model.source = fmt::format(
      "{}: scheduling_overhead medians at {} threads minus those at 1 thread (OMP_WAIT_POLICY "
      "{}), added above 1 thread only (the trace's times hold the 1-thread costs); per loop "
      "{:.2f} us = static@blocks {:.2f} - {:.2f} us",
      file.string(), team, model.wait_policy, 1e6 * model.loop_seconds,
      1e6 * static_team.loop_seconds, 1e6 * static_one.loop_seconds);
  if (model.round_trip_ns > 0.0) {
    model.source += fmt::format(
        "; per-loop cost measured with the cores {:.0f} ns apart (cache-line round trip)",
        model.round_trip_ns);
  }
  std::vector<std::string> one_size;
  for (const auto& [spec, at] : by_spec) {
    const bool disturbed =
        std::any_of(at.begin(), at.end(), [](const auto& entry) { return entry.second.disturbed; });
    if (disturbed) model.disturbed.push_back(spec);
    if (spec == "static@blocks" || disturbed) continue;
    if (at.count(1) == 0 || at.count(team) == 0) {
      one_size.push_back(spec);
      continue;
    }
    const Figures& one = at.at(1);
    const Figures& many = at.at(team);
    if (one.chunks_per_thread <= 0.0 || many.chunks_per_thread <= 0.0) continue;
    const double at_one = (one.loop_seconds - static_one.loop_seconds) / one.chunks_per_thread;
    const double at_team = (many.loop_seconds - static_team.loop_seconds) / many.chunks_per_thread;
    model.dispatch_seconds[spec] = std::max(0.0, at_team - at_one);
    if (round_trip(spec) > 0.0) model.dispatch_round_trip_ns[spec] = round_trip(spec);
  }
  model.dispatch_seconds["static@blocks"] = 0.0;
  if (!model.disturbed.empty()) {
    model.source += fmt::format(
        "; {} of {} results disturbed by other work on the machine, not "
        "used for dispatch costs: {}",
        model.disturbed.size(), by_spec.size(), fmt::join(model.disturbed, ", "));
  }
  if (!one_size.empty()) {
    model.source +=
        fmt::format("; measured at one team size only, not used: {}", fmt::join(one_size, ", "));
  }
  return model;
}

std::string wait_policy_mismatch(const OverheadModel& model, const std::string& trace_policy) {
  const auto recorded = [](const std::string& p) { return p == "active" || p == "passive"; };
  if (!model.measured || !recorded(model.wait_policy) || !recorded(trace_policy) ||
      model.wait_policy == trace_policy) {
    return {};
  }
  return fmt::format(
      "the overheads were measured with OMP_WAIT_POLICY {} but the traced run had {}: a thread "
      "that sleeps at a barrier takes far longer to start the next loop than one that spins, so "
      "the per-loop cost does not carry over (measure it again with OMP_WAIT_POLICY={})",
      model.wait_policy, trace_policy, trace_policy);
}

nlohmann::json overhead_model_json(const OverheadModel& model) {
  return {{"source", model.source},
          {"measured_threads", model.measured_threads},
          {"wait_policy", model.wait_policy},
          {"round_trip_ns", model.round_trip_ns},
          {"dispatch_round_trip_ns", model.dispatch_round_trip_ns},
          {"loop_seconds", model.loop_seconds},
          {"loop_seconds_at_one_thread", model.loop_seconds_at_one},
          {"loop_seconds_at_measured_threads", model.loop_seconds_at_measured},
          {"dispatch_seconds", model.dispatch_seconds},
          {"disturbed", model.disturbed}};
}

OverheadModel overhead_model_from_json(const nlohmann::json& stored, const std::string& origin) {
  OverheadModel model;
  try {
    model.measured_threads = stored.at("measured_threads").get<int>();
    model.loop_seconds = stored.at("loop_seconds").get<double>();
    model.loop_seconds_at_one = stored.at("loop_seconds_at_one_thread").get<double>();
    model.loop_seconds_at_measured = stored.at("loop_seconds_at_measured_threads").get<double>();
    model.dispatch_seconds = stored.at("dispatch_seconds").get<std::map<std::string, double>>();
    model.disturbed = stored.at("disturbed").get<std::vector<std::string>>();
    model.wait_policy = stored.value("wait_policy", std::string("not recorded"));
    model.round_trip_ns = stored.value("round_trip_ns", 0.0);
    model.dispatch_round_trip_ns =
        stored.value("dispatch_round_trip_ns", std::map<std::string, double>{});
    model.source = origin + ", copied from " + stored.at("source").get<std::string>();
  } catch (const nlohmann::json::exception& error) {
    throw std::invalid_argument(origin + ": overheads: " + error.what());
  }
  model.measured = true;
  return model;
}

}  // namespace clothbench::harness
