// Rows, statistics and partial rows of the sweep document (see sweep_document.hpp; its
// validation is in sweep_document_validate.cpp).
#include "harness/sweep/sweep_document.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <numeric>

#include "harness/run/disturbance.hpp"
#include <stdexcept>

namespace clothbench::harness {

using nlohmann::json;

std::size_t median_index(const std::vector<double>& values) {
  if (values.empty()) return 0;
  std::vector<std::size_t> order(values.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return values[a] < values[b]; });
  return order[(values.size() - 1) / 2];
}

json sample_statistics(const std::vector<double>& values) {
  if (values.empty()) return nullptr;
  const auto [lo, hi] = std::minmax_element(values.begin(), values.end());
  return {{"median", values[median_index(values)]}, {"min", *lo}, {"max", *hi}, {"samples", values}};
}

json accounting_json(const OverheadAccounting& a, std::size_t from_run) {
  return {{"from_run", from_run},
          {"wall_seconds", a.wall_seconds},
          {"step_seconds", a.step_seconds},
          {"sequential_overhead_seconds", a.sequential_overhead},
          {"parallel_overhead_seconds", a.parallel_overhead},
          {"load_imbalance_seconds", a.load_imbalance},
          {"parallel_work_seconds", a.parallel_work},
          {"unaccounted_seconds", a.unaccounted},
          {"imbalance_percent", a.imbalance_percent},
          {"thread_work_cv", a.thread_work_cv},
          {"loops", a.loops},
          {"chunks", a.chunks},
          {"thread_work_seconds", a.thread_work}};
}

std::optional<double> instrumentation_cost_ratio(const json& row) {
  const json& timed = row["instrumented"]["time_seconds"];
  const json& plain = row["time_seconds"];
  if (!timed.is_object() || !timed["median"].is_number() || !plain["median"].is_number()) {
    return std::nullopt;
  }
  const double base = plain["median"].get<double>();
  if (!(base > 0.0)) return std::nullopt;
  return timed["median"].get<double>() / base;
}

std::optional<AccountingIdentity> accounting_identity(const json& row) {
  const json& a = row["accounting"];
  if (!a.is_object()) return std::nullopt;
  auto number = [&](const char* key) {
    return a.contains(key) && a[key].is_number() ? a[key].get<double>() : 0.0;
  };
  AccountingIdentity id;
  id.wall_seconds = number("wall_seconds");
  id.sequential_overhead = number("sequential_overhead_seconds");
  id.parallel_work = number("parallel_work_seconds");
  id.parallel_overhead = number("parallel_overhead_seconds");
  id.load_imbalance = number("load_imbalance_seconds");
  id.parts_seconds =
      id.sequential_overhead + id.parallel_work + id.parallel_overhead + id.load_imbalance;
  // The parts add up to the step timer's time; the residual is what the run spent outside it,
  // measured (unaccounted_seconds), so the identity is a check, not a definition.
  id.residual_seconds = number("unaccounted_seconds");
  id.overheads_seconds = id.sequential_overhead + id.parallel_overhead + id.load_imbalance;
  id.time_median_seconds = row["time_seconds"]["median"].get<double>();
  id.wall_over_time = id.time_median_seconds > 0.0 ? id.wall_seconds / id.time_median_seconds : 0.0;
  id.from_run = a.value("from_run", std::size_t{0});
  if (a.contains("runs") && a["runs"].is_number_integer()) {
    id.runs = a["runs"].get<std::size_t>();
  } else if (const json& t = row["instrumented"]["time_seconds"]; t.is_object()) {
    id.runs = t["samples"].size();  // older documents: the instrumented samples
  }
  id.overheads_exceed_time = id.overheads_seconds > id.time_median_seconds;
  if (id.overheads_exceed_time) {
    id.note = fmt::format(
        "the overheads ({:.4g} s) exceed the row's Time ({:.4g} s, median of the uninstrumented "
        "runs): they come from instrumented run {} of {}, which took {:.4g} s, {:.2f}x that "
        "median (the instrumentation's own cost, or other work on the machine: see Timing)",
        id.overheads_seconds, id.time_median_seconds, id.from_run + 1, id.runs, id.wall_seconds,
        id.wall_over_time);
  }
  return id;
}

json identity_json(const AccountingIdentity& id) {
  return {{"wall_seconds", id.wall_seconds},
          {"parts_seconds", id.parts_seconds},
          {"residual_seconds", id.residual_seconds},
          {"overheads_seconds", id.overheads_seconds},
          {"time_median_seconds", id.time_median_seconds},
          {"wall_over_time", id.wall_over_time},
          {"overheads_exceed_time", id.overheads_exceed_time},
          {"note", id.note}};
}

namespace {

json run_memory_json(const RunMemory& memory) {
  return {{"start_resident_bytes", memory.start_bytes},
          {"peak_resident_bytes", memory.peak_bytes},
          {"scope", memory.scope}};
}

/// The row's peak is the highest of its runs whose memory is known; its scope is "run" when
/// each of them had its own high-water mark (reset at its start), else "process".
json row_memory_json(const std::vector<MeasuredRun>& plain, const std::vector<MeasuredRun>& timed) {
  std::uint64_t peak = 0;
  int runs = 0, measured = 0;
  bool own = true;
  json records = json::array();
  for (const auto* list : {&plain, &timed}) {
    for (const MeasuredRun& r : *list) {
      ++runs;
      json record = run_memory_json(r.memory);
      record["instrumented"] = list == &timed;
      records.push_back(std::move(record));
      if (r.memory.scope == "unknown") continue;
      ++measured;
      own = own && r.memory.scope == "run";
      peak = std::max(peak, r.memory.peak_bytes);
    }
  }
  return {{"peak_resident_bytes", measured > 0 ? json(peak) : json(nullptr)},
          {"scope", measured == 0 ? "unknown" : own ? "run" : "process"},
          {"runs_measured", measured},
          {"runs", runs},
          {"records", std::move(records)}};
}

}  // namespace

json make_row(const std::string& scheduler, const std::string& canonical, const std::string& note,
              int threads, bool oversubscribed, const std::vector<MeasuredRun>& plain,
              const std::vector<MeasuredRun>& timed, kernels::Instrumentation level, int steps,
              json binding) {
  std::vector<double> plain_times, timed_times;
  for (const MeasuredRun& r : plain) plain_times.push_back(r.accounting.wall_seconds);
  for (const MeasuredRun& r : timed) timed_times.push_back(r.accounting.wall_seconds);

  // Disturbance: every counted run's record; the row is DISTURBED when any of them stayed
  // disturbed after its retries.
  json runs = json::array();
  int disturbed_runs = 0, reruns = 0;
  for (const auto* list : {&plain, &timed}) {
    for (const MeasuredRun& r : *list) {
      json record = disturbance_json(r.disturbance);
      record["instrumented"] = list == &timed;
      record["attempts"] = r.attempts;
      record["reference"] = r.reference;
      runs.push_back(std::move(record));
      disturbed_runs += r.disturbance.disturbed ? 1 : 0;
      reruns += r.attempts - 1;
    }
  }
  json disturbance = {{"disturbed", disturbed_runs > 0},
                      {"disturbed_runs", disturbed_runs},
                      {"runs", runs.size()},
                      {"reruns", reruns},
                      {"records", std::move(runs)}};

  json failures = json::array();
  bool passed = true, identical = true;
  double max_mass_error = 0.0;
  std::int64_t iterations = 0;
  std::string digest;
  for (const auto* runs : {&plain, &timed}) {
    for (const MeasuredRun& r : *runs) {
      passed = passed && r.verification.passed;
      identical = identical && r.bit_identical;
      max_mass_error = std::max(max_mass_error, r.mass_error);
      for (const std::string& f : r.verification.failures) failures.push_back(f);
      if (digest.empty()) digest = r.state_digest;
      iterations = r.cg_iterations;
    }
  }
  json memory = row_memory_json(plain, timed);
  json instrumented = {{"level", to_string(level)},
                       {"time_seconds", nullptr},
                       {"cost_seconds", nullptr},
                       {"cost_percent", nullptr},
                       {"cost_ratio", nullptr}};
  json accounting = nullptr;
  if (!timed.empty()) {
    const double plain_median = plain_times[median_index(plain_times)];
    const std::size_t pick = median_index(timed_times);
    const double cost = timed_times[pick] - plain_median;
    instrumented["time_seconds"] = sample_statistics(timed_times);
    instrumented["cost_seconds"] = cost;
    instrumented["cost_percent"] = plain_median > 0.0 ? 100.0 * cost / plain_median : 0.0;
    instrumented["cost_ratio"] = plain_median > 0.0 ? timed_times[pick] / plain_median : 0.0;
    accounting = accounting_json(timed[pick].accounting, pick);
    accounting["source"] = "median instrumented run";
    accounting["runs"] = timed.size();
  }
  json row = {{"scheduler", scheduler},
              {"scheduler_canonical", canonical},
              {"note", note},
              {"threads", threads},
              {"oversubscribed", oversubscribed},
              {"time_seconds", sample_statistics(plain_times)},
              {"instrumented", instrumented},
              {"accounting", accounting},
              {"verification",
               {{"passed", passed},
                {"failures", failures},
                {"runs", plain.size() + timed.size()},
                {"bit_identical", identical},
                {"state_digest", digest},
                {"max_mass_error", max_mass_error}}},
              {"disturbance", std::move(disturbance)},
              {"memory", std::move(memory)},
              {"cg_iterations", iterations},
              {"steps", steps},
              {"binding", std::move(binding)},
              {"derived",
               {{"speedup", nullptr},
                {"efficiency", nullptr},
                {"speedup_vs_best_1thread", nullptr},
                {"efficiency_vs_best_1thread", nullptr}}}};
  if (const std::optional<AccountingIdentity> identity = accounting_identity(row)) {
    row["accounting"]["identity"] = identity_json(*identity);
  }
  check_finite(row, "row");
  return row;
}

json settings_json(const SweepOptions& options, const std::vector<int>& threads, int steps) {
  return {{"schedulers", options.schedulers},
          {"threads", threads},
          {"repeat", options.repeat},
          {"warmup_steps", options.warmup_steps},
          {"count_reference_after_seconds", options.count_reference_after_seconds},
          {"steps", steps},
          {"instrument", to_string(options.instrument)},
          {"instrument_only", options.instrument_only},
          {"bind", to_string(options.bind)},
          {"retries", options.retries},
          {"omp_wait_policy", omp_wait_policy()},
          {"oversubscribe", options.allow_oversubscribe},
          {"size_class", options.size_class ? json(*options.size_class) : json(nullptr)}};
}

namespace {

/// `j[key]` as T, or std::invalid_argument naming `where.key`.
template <class T>
T field(const json& j, const std::string& where, const char* key) {
  if (!j.is_object() || !j.contains(key)) {
    throw std::invalid_argument(fmt::format("{}: missing key '{}'", where, key));
  }
  try {
    return j[key].get<T>();
  } catch (const json::exception&) {
    throw std::invalid_argument(fmt::format("{}.{}: wrong type ({})", where, key, j[key].dump()));
  }
}

bool same_key(const json& entry, const RowKey& key) {
  return entry.value("scheduler_canonical", "") == key.scheduler_canonical &&
         entry.value("threads", 0) == key.threads;
}

}  // namespace

json measured_run_json(const MeasuredRun& run) {
  json disturbance = disturbance_json(run.disturbance);
  disturbance["threads"] = run.disturbance.threads;
  disturbance["usable_cores"] = run.disturbance.usable_cores;
  return {{"instrumentation", to_string(run.instrumentation)},
          {"cg_iterations", run.cg_iterations},
          {"steps_done", run.steps_done},
          {"mass_error", run.mass_error},
          {"finite", run.finite},
          {"bit_identical", run.bit_identical},
          {"state_digest", run.state_digest},
          {"attempts", run.attempts},
          {"reference", run.reference},
          {"verification",
           {{"passed", run.verification.passed}, {"failures", run.verification.failures}}},
          {"accounting", accounting_json(run.accounting, 0)},
          {"disturbance", std::move(disturbance)},
          {"memory", run_memory_json(run.memory)}};
}

MeasuredRun measured_run_from_json(const json& j) {
  const std::string w = "run";
  MeasuredRun run;
  run.instrumentation = parse_instrumentation(field<std::string>(j, w, "instrumentation"));
  run.cg_iterations = field<std::int64_t>(j, w, "cg_iterations");
  run.steps_done = field<int>(j, w, "steps_done");
  run.mass_error = field<double>(j, w, "mass_error");
  run.finite = field<bool>(j, w, "finite");
  run.bit_identical = field<bool>(j, w, "bit_identical");
  run.state_digest = field<std::string>(j, w, "state_digest");
  run.attempts = field<int>(j, w, "attempts");
  // Absent in documents written before the reference run was marked.
  if (j.contains("reference")) run.reference = field<bool>(j, w, "reference");
  const json v = field<json>(j, w, "verification");
  run.verification.passed = field<bool>(v, w + ".verification", "passed");
  run.verification.failures = field<std::vector<std::string>>(v, w + ".verification", "failures");
  const json a = field<json>(j, w, "accounting");
  const std::string wa = w + ".accounting";
  OverheadAccounting& acc = run.accounting;
  acc.wall_seconds = field<double>(a, wa, "wall_seconds");
  acc.step_seconds = field<double>(a, wa, "step_seconds");
  acc.sequential_overhead = field<double>(a, wa, "sequential_overhead_seconds");
  acc.parallel_overhead = field<double>(a, wa, "parallel_overhead_seconds");
  acc.load_imbalance = field<double>(a, wa, "load_imbalance_seconds");
  acc.parallel_work = field<double>(a, wa, "parallel_work_seconds");
  acc.unaccounted = field<double>(a, wa, "unaccounted_seconds");
  acc.imbalance_percent = field<double>(a, wa, "imbalance_percent");
  acc.thread_work_cv = field<double>(a, wa, "thread_work_cv");
  acc.loops = field<std::int64_t>(a, wa, "loops");
  acc.chunks = field<std::int64_t>(a, wa, "chunks");
  acc.thread_work = field<std::vector<double>>(a, wa, "thread_work_seconds");
  const json d = field<json>(j, w, "disturbance");
  const std::string wd = w + ".disturbance";
  Disturbance& dist = run.disturbance;
  auto load = [&](const char* key) {
    const json value = field<json>(d, wd, key);
    return value.is_null() ? -1.0 : field<double>(d, wd, key);
  };
  dist.threads = field<int>(d, wd, "threads");
  dist.usable_cores = field<int>(d, wd, "usable_cores");
  dist.wall_seconds = field<double>(d, wd, "wall_seconds");
  dist.cpu_seconds = field<double>(d, wd, "cpu_seconds");
  dist.cpu_share = field<double>(d, wd, "cpu_share");
  dist.involuntary_switches = field<long>(d, wd, "involuntary_switches");
  dist.switch_rate = field<double>(d, wd, "switch_rate_per_core_second");
  dist.load_before = load("load_before");
  dist.load_after = load("load_after");
  dist.wait_policy = field<std::string>(d, wd, "wait_policy");
  dist.oversubscribed = field<bool>(d, wd, "oversubscribed");
  dist.disturbed = field<bool>(d, wd, "disturbed");
  dist.reasons = field<std::vector<std::string>>(d, wd, "reasons");
  if (j.contains("memory")) {  // absent in documents written before memory was measured
    const json m = field<json>(j, w, "memory");
    const std::string wm = w + ".memory";
    run.memory.start_bytes = field<std::uint64_t>(m, wm, "start_resident_bytes");
    run.memory.peak_bytes = field<std::uint64_t>(m, wm, "peak_resident_bytes");
    run.memory.scope = field<std::string>(m, wm, "scope");
    if (run.memory.scope != "run" && run.memory.scope != "process" &&
        run.memory.scope != "unknown") {
      throw std::invalid_argument(
          fmt::format("{}.scope: \"{}\" is not run, process or unknown", wm, run.memory.scope));
    }
  }
  return run;
}

void store_partial_row(json& document, const RowKey& key, const std::vector<MeasuredRun>& plain,
                       const std::vector<MeasuredRun>& timed, double round_trip_before_ns) {
  drop_partial_row(document, key);
  json entry = {{"scheduler_canonical", key.scheduler_canonical},
                {"threads", key.threads},
                {"plain", json::array()},
                {"timed", json::array()}};
  for (const MeasuredRun& r : plain) entry["plain"].push_back(measured_run_json(r));
  for (const MeasuredRun& r : timed) entry["timed"].push_back(measured_run_json(r));
  if (round_trip_before_ns > 0.0) entry["core_round_trip_before_ns"] = round_trip_before_ns;
  if (!document["partial_rows"].is_array()) document["partial_rows"] = json::array();
  document["partial_rows"].push_back(std::move(entry));
}

bool take_partial_row(const json& document, const RowKey& key, std::vector<MeasuredRun>& plain,
                      std::vector<MeasuredRun>& timed, double* round_trip_before_ns) {
  if (round_trip_before_ns != nullptr) *round_trip_before_ns = 0.0;
  if (!document.contains("partial_rows") || !document["partial_rows"].is_array()) return false;
  for (const json& entry : document["partial_rows"]) {
    if (!same_key(entry, key)) continue;
    if (round_trip_before_ns != nullptr && entry.contains("core_round_trip_before_ns")) {
      *round_trip_before_ns = field<double>(entry, "partial_rows[]", "core_round_trip_before_ns");
    }
    for (const json& r : field<json>(entry, "partial_rows[]", "plain")) {
      plain.push_back(measured_run_from_json(r));
    }
    for (const json& r : field<json>(entry, "partial_rows[]", "timed")) {
      timed.push_back(measured_run_from_json(r));
    }
    return true;
  }
  return false;
}

void drop_partial_row(json& document, const RowKey& key) {
  if (!document.contains("partial_rows")) return;
  json& entries = document["partial_rows"];
  if (entries.is_array()) {
    json kept = json::array();
    for (json& entry : entries) {
      if (!same_key(entry, key)) kept.push_back(std::move(entry));
    }
    entries = std::move(kept);
  }
  if (!entries.is_array() || entries.empty()) document.erase("partial_rows");
}

bool has_row(const json& document, const RowKey& key) {
  if (!document.contains("rows")) return false;
  return std::any_of(document["rows"].begin(), document["rows"].end(), [&](const json& row) {
    return row.value("scheduler_canonical", "") == key.scheduler_canonical &&
           row.value("threads", 0) == key.threads;
  });
}

void check_finite(const json& j, const std::string& path) {
  if (j.is_number_float() && !std::isfinite(j.get<double>())) {
    throw std::runtime_error("non-finite value in result field " + path);
  }
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) check_finite(it.value(), path + "." + it.key());
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i) check_finite(j[i], fmt::format("{}[{}]", path, i));
  }
}

std::string utc_now() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

}  // namespace clothbench::harness
