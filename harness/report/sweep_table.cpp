// Table 2 style tables from a sweep document (see sweep_table.hpp).
#include "harness/report/sweep_table.hpp"

#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "harness/run/core_round_trip.hpp"
#include "harness/sweep/sweep_document.hpp"

namespace clothbench::harness {

using nlohmann::json;

namespace {

bool passed(const json& row) { return row["verification"].value("passed", false); }
double median_time(const json& row) { return row["time_seconds"]["median"].get<double>(); }

/// "clean", "DISTURBED (k of n runs)", or "-" for a row of a document written before
/// disturbance was measured.
std::string timing_label(const json& row) {
  if (!row.contains("disturbance")) return "-";
  const json& d = row["disturbance"];
  if (!d.value("disturbed", false)) return "clean";
  return fmt::format("DISTURBED ({} of {} runs)", d.value("disturbed_runs", 0), d.value("runs", 0));
}

/// Rows grouped per scheduler (order of settings.schedulers, then first appearance),
/// each group sorted by thread count.
std::vector<std::vector<const json*>> grouped_rows(const json& document) {
  const json& order = document["settings"]["schedulers"];
  auto rank = [&](const json& row) {
    for (std::size_t i = 0; i < order.size(); ++i) {
      if (order[i] == row["scheduler"]) return i;
    }
    return order.size();
  };
  std::vector<std::vector<const json*>> groups;
  std::vector<std::pair<std::size_t, std::string>> keys;
  for (const json& row : document["rows"]) {
    const std::pair<std::size_t, std::string> key{rank(row), row["scheduler_canonical"]};
    auto it = std::find(keys.begin(), keys.end(), key);
    if (it == keys.end()) {
      keys.push_back(key);
      groups.emplace_back();
      it = keys.end() - 1;
    }
    groups[static_cast<std::size_t>(it - keys.begin())].push_back(&row);
  }
  std::vector<std::size_t> index(groups.size());
  for (std::size_t i = 0; i < index.size(); ++i) index[i] = i;
  std::stable_sort(index.begin(), index.end(),
                   [&](std::size_t a, std::size_t b) { return keys[a].first < keys[b].first; });
  std::vector<std::vector<const json*>> sorted;
  for (std::size_t i : index) {
    auto g = groups[i];
    std::stable_sort(g.begin(), g.end(), [](const json* a, const json* b) {
      return (*a)["threads"].get<int>() < (*b)["threads"].get<int>();
    });
    sorted.push_back(std::move(g));
  }
  return sorted;
}

/// Seconds: 3 decimals from 1 s up (Table 2 style), else 3 significant digits; a given
/// `format` otherwise; "-" for null/missing.
std::string cell(const json& value, const char* format = nullptr) {
  if (!value.is_number()) return "-";
  const double v = value.get<double>();
  if (format != nullptr) return fmt::format(fmt::runtime(format), v);
  if (v == 0.0) return "0";
  return std::abs(v) >= 1.0 ? fmt::format("{:.3f}", v) : fmt::format("{:.3g}", v);
}

const json& accounting_field(const json& row, const char* key) {
  static const json null_value = nullptr;
  const json& a = row["accounting"];
  return a.is_object() && a.contains(key) ? a[key] : null_value;
}

/// Fixed decimals for the cells of one identity row: 4 significant digits of the run's wall
/// (at least 3 decimals, Table 2 style), the same for every part, so the printed parts add
/// up to the printed wall within a few units of the last decimal.
int identity_decimals(double wall) {
  if (!(wall > 0.0)) return 3;
  return std::max(3, 3 - static_cast<int>(std::floor(std::log10(wall))));
}

std::string fixed(double value, int decimals) { return fmt::format("{:.{}f}", value, decimals); }

/// "instr. run k of n (median)": which run the overheads come from, 1-based for people.
std::string run_label(const AccountingIdentity& id) {
  return id.runs > 0 ? fmt::format("instr. run {} of {} (median)", id.from_run + 1, id.runs)
                     : fmt::format("instr. run {} (median)", id.from_run + 1);
}

constexpr const char* kExceedsMark = "†";  // dagger: the row's footnote says why

/// The accounting table of one scheduler: per row the instrumented run the overheads come
/// from, its wall time and the identity wall = seq + work + para + imbalance + residual.
void write_accounting_table(std::ostringstream& out, const std::vector<const json*>& group,
                            const std::string& level) {
  std::vector<std::string> footnotes;
  bool any = false;
  for (const json* r : group) any = any || accounting_identity(*r).has_value();
  if (!any) return;
  out << fmt::format(
      "\nWhere the time went, in the instrumented run (`{}`) the overheads above come from: "
      "run wall = seq. overhead + parallel work + para. overhead + imbalance + residual "
      "(the residual is the time outside the kernel's step timer). Run wall / Time is that "
      "run against the row's Time; as the run is the median instrumented one, it is what the "
      "instrumentation costs (instrumented median / uninstrumented median).\n\n",
      level);
  out << "| Threads | Overheads from | Run wall [s] | Seq. overhead [s] | Parallel work [s] "
         "| Para. overhead [s] | Imbalance [s] | Residual [s] | Run wall / Time |\n";
  out << "|--:|:--|--:|--:|--:|--:|--:|--:|--:|\n";
  for (const json* r : group) {
    const json& row = *r;
    const std::optional<AccountingIdentity> id = accounting_identity(row);
    if (!id) {
      out << fmt::format("| {} | not instrumented | - | - | - | - | - | - | - |\n",
                         row["threads"].get<int>());
      continue;
    }
    const int d = identity_decimals(id->wall_seconds);
    out << fmt::format("| {} | {} | {} | {} | {} | {} | {} | {} | {:.2f}x{} |\n",
                       row["threads"].get<int>(), run_label(*id), fixed(id->wall_seconds, d),
                       fixed(id->sequential_overhead, d), fixed(id->parallel_work, d),
                       fixed(id->parallel_overhead, d), fixed(id->load_imbalance, d),
                       fixed(id->residual_seconds, d), id->wall_over_time,
                       id->overheads_exceed_time ? std::string(" ") + kExceedsMark : "");
    if (id->overheads_exceed_time) {
      footnotes.push_back(
          fmt::format("{} {} threads: {}.", kExceedsMark, row["threads"].get<int>(), id->note));
    }
  }
  for (const std::string& f : footnotes) out << "\n" << f << "\n";
}

/// True when the row's overheads add up to more than its Time (AccountingIdentity).
bool exceeds(const json& row) {
  const std::optional<AccountingIdentity> id = accounting_identity(row);
  return id && id->overheads_exceed_time;
}

/// settings.instrument, and the schedulers it was limited to (--instrument-only), if any.
std::string instrumentation_setting(const json& settings) {
  const std::string text = fmt::format("`{}`", settings["instrument"].get<std::string>());
  const json only = settings.value("instrument_only", json::array());
  if (!only.is_array() || only.empty()) return text;
  std::vector<std::string> names;
  for (const json& name : only) names.push_back(name.is_string() ? name.get<std::string>() : "?");
  return fmt::format("{} for `{}` only (the other rows uninstrumented: `-` overheads)", text,
                     fmt::join(names, "`, `"));
}

}  // namespace

std::string format_row_line(const json& row) {
  std::string parts;
  const std::optional<AccountingIdentity> id = accounting_identity(row);
  if (id) {
    parts = fmt::format(
        "  overheads from {}: wall {:.4f} = seq {:.4f} + work {:.4f} + para {:.4f} + imb {:.4f} "
        "+ resid {:.4f} s ({:.2f}x time){}",
        run_label(*id), id->wall_seconds, id->sequential_overhead, id->parallel_work,
        id->parallel_overhead, id->load_imbalance, id->residual_seconds, id->wall_over_time,
        id->overheads_exceed_time ? "  OVERHEADS > TIME (instrumented run longer, see table.md)"
                                  : "");
  }
  const bool disturbed = row_disturbed(row);
  const json& disturbance = row.contains("disturbance") ? row["disturbance"] : json();
  if (row.contains("core_round_trip_ns") && row["core_round_trip_ns"].is_object()) {
    const double before = row["core_round_trip_ns"].value("before", 0.0);
    const double after = row["core_round_trip_ns"].value("after", 0.0);
    parts += fmt::format("  core round trip {:.0f}/{:.0f} ns{}", before, after,
                         round_trip_changed(before, after) ? " (CORE PLACEMENT CHANGED)" : "");
  }
  if (row.contains("memory") && row["memory"].is_object() &&
      row["memory"]["peak_resident_bytes"].is_number()) {
    parts += fmt::format(
        "  peak {:.1f} MiB{}", row["memory"]["peak_resident_bytes"].get<double>() / (1 << 20),
        row["memory"]["scope"] == "run" ? "" : " (process)");
  }
  return fmt::format(
      "  {:<28} {:3d} threads{}  time {:.4f} s [{:.4f}-{:.4f}]{}  {}{}\n",
      row["scheduler_canonical"].get<std::string>(), row["threads"].get<int>(),
      row["oversubscribed"].get<bool>() ? " (oversubscribed)" : "",
      row["time_seconds"]["median"].get<double>(), row["time_seconds"]["min"].get<double>(),
      row["time_seconds"]["max"].get<double>(), parts, passed(row) ? "PASSED" : "FAILED",
      disturbed ? fmt::format("  DISTURBED ({} of {} runs, {} re-run)",
                              disturbance["disturbed_runs"].get<int>(),
                              disturbance["runs"].get<int>(), disturbance["reruns"].get<int>())
                : std::string());
}

std::string csv_cell(const json& value) {
  if (value.is_null()) return "";
  if (value.is_boolean()) return value.get<bool>() ? "true" : "false";
  if (value.is_number_integer()) return std::to_string(value.get<long long>());
  if (value.is_number()) return fmt::format("{:.9g}", value.get<double>());
  std::string text = value.is_string() ? value.get<std::string>() : value.dump();
  if (text.find_first_of(",\"\n") != std::string::npos) {
    std::string quoted = "\"";
    for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
    return quoted + "\"";
  }
  return text;
}

bool row_disturbed(const json& row) {
  return row.contains("disturbance") && row["disturbance"].value("disturbed", false);
}

void add_derived(json& document) {
  std::map<std::string, double> own_baseline;
  double best = std::numeric_limits<double>::infinity();
  for (const json& row : document["rows"]) {
    if (row["threads"] == 1 && passed(row) && !row_disturbed(row)) {
      own_baseline[row["scheduler_canonical"]] = median_time(row);
      best = std::min(best, median_time(row));
    }
  }
  for (json& row : document["rows"]) {
    json& d = row["derived"];
    d = {{"speedup", nullptr},
         {"efficiency", nullptr},
         {"speedup_vs_best_1thread", nullptr},
         {"efficiency_vs_best_1thread", nullptr}};
    const double time = median_time(row);
    if (!passed(row) || row_disturbed(row) || !(time > 0.0)) continue;
    const double threads = row["threads"].get<double>();
    const auto own = own_baseline.find(row["scheduler_canonical"]);
    if (own != own_baseline.end()) {
      d["speedup"] = own->second / time;
      d["efficiency"] = own->second / time / threads;
    }
    if (best < std::numeric_limits<double>::infinity()) {
      d["speedup_vs_best_1thread"] = best / time;
      d["efficiency_vs_best_1thread"] = best / time / threads;
    }
  }
}

std::string format_markdown(const json& document) {
  std::ostringstream out;
  const json& scene = document["scene"];
  const json& settings = document["settings"];
  const json& machine = document["machine"];
  out << fmt::format("# clothbench sweep: {}\n\n", scene["name"].get<std::string>());
  out << fmt::format(
      "Scene `{}` (hash {}), {} steps; time = median of {} runs (min-max shown), after a "
      "{}-step warm-up; instrumentation {}; binding `{}`; OMP_WAIT_POLICY `{}`; retries of "
      "a disturbed run {}{}.\n",
      scene["file"].get<std::string>(), scene["hash"].get<std::string>(),
      settings["steps"].get<int>(), settings["repeat"].get<int>(),
      settings.value("warmup_steps", 0), instrumentation_setting(settings),
      settings.value("bind", "none"), settings.value("omp_wait_policy", "not recorded"),
      settings.contains("retries") ? std::to_string(settings["retries"].get<int>()) : "-",
      document.value("complete", false) ? "" : " (INCOMPLETE sweep)");
  if (machine.is_object() && machine.contains("cpu")) {
    const json& load = machine.value("load_average", json::array());
    out << fmt::format("Machine: {} ({} cores, {} PUs), {} {}, {}{}.\n",
                       machine["cpu"].value("model", "?"), machine["cpu"].value("cores", 0),
                       machine["cpu"].value("pus", 0), machine["compiler"].value("id", "?"),
                       machine["compiler"].value("version", "?"),
                       machine["openmp"]["runtime"].value("name", "?"),
                       load.empty() ? std::string()
                                    : fmt::format("; load average {:.2f} at the start",
                                                  load[0].get<double>()));
  }
  for (const auto& group : grouped_rows(document)) {
    const json& first = *group.front();
    out << fmt::format("\n## {}\n\n", first["scheduler_canonical"].get<std::string>());
    if (!first["note"].get<std::string>().empty()) {
      out << fmt::format("Note: {}\n\n", first["note"].get<std::string>());
    }
    out << "| Threads | Seq. overhead [s] | Para. overhead [s] | Imbalance [s] | Imbalance [%] "
           "| Time [s] | Min-max [s] | Speed-up | Efficiency | Speed-up vs best 1-thread "
           "| Verification | Timing |\n";
    out << "|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|:--|:--|\n";
    for (const json* r : group) {
      const json& row = *r;
      const json& t = row["time_seconds"];
      const std::size_t failures = row["verification"]["failures"].size();
      out << fmt::format(
          "| {}{} | {} | {} | {} | {} | {} | {}-{} | {} | {} | {} | {} | {} |\n",
          row["threads"].get<int>(), row["oversubscribed"].get<bool>() ? " (oversubscribed)" : "",
          cell(accounting_field(row, "sequential_overhead_seconds")),
          cell(accounting_field(row, "parallel_overhead_seconds")),
          cell(accounting_field(row, "load_imbalance_seconds")),
          cell(accounting_field(row, "imbalance_percent"), "{:.1f}"),
          // A Time below the overheads beside it carries the dagger of its footnote.
          cell(t["median"]) + (exceeds(row) ? std::string(" ") + kExceedsMark : ""), cell(t["min"]),
          cell(t["max"]), cell(row["derived"]["speedup"], "{:.2f}"),
          cell(row["derived"]["efficiency"], "{:.2f}"),
          cell(row["derived"]["speedup_vs_best_1thread"], "{:.2f}"),
          passed(row) ? std::string("PASSED")
                      : fmt::format("FAILED ({} check{})", failures, failures == 1 ? "" : "s"),
          timing_label(row));
    }
    write_accounting_table(out, group, settings["instrument"].get<std::string>());
  }
  out << "\nSeq. overhead: time outside parallel loops (CG scalars, list rebuilds). Para. "
         "overhead: loop wall time minus the busiest thread's work (fork/join, barriers, "
         "dispatch). Imbalance: busiest minus mean thread work; [%] = busiest/mean - 1. All "
         "three are summed over the loops of one instrumented run, the median of the row's "
         "instrumented runs, not of the timed ones: the table under each scheduler names that "
         "run and shows its own wall time, which the parts add up to. Time: median wall time of "
         "the uninstrumented runs. A row whose overheads add up to more than its Time has "
         "\u2020 after its Time and after its run wall / Time, with the reason (its "
         "instrumented run took longer). Speed-up: against the same scheduler's 1-thread time; "
         "a FAILED run shows no speed-up. Timing: DISTURBED when some of the row's runs were still "
         "disturbed by "
         "other work on the machine after their retries (another process's CPU time or "
         "preemptions, see sweep.json's disturbance records); a DISTURBED row, or one whose "
         "1-thread row is, shows no speed-up.\n";
  return out.str();
}

std::string format_csv(const json& document) {
  std::ostringstream out;
  out << "scheduler,scheduler_canonical,threads,oversubscribed,time_median_s,time_min_s,"
         "time_max_s,sequential_overhead_s,parallel_overhead_s,load_imbalance_s,"
         "parallel_work_s,unaccounted_s,imbalance_percent,thread_work_cv,instrumentation,"
         "instrumentation_cost_s,instrumentation_cost_ratio,overheads_from_run,instrumented_runs,"
         "instrumented_run_wall_s,overheads_exceed_time,"
         "overheads_note,speedup,efficiency,speedup_vs_best_1thread,"
         "efficiency_vs_best_1thread,verification,timing\n";
  for (const auto& group : grouped_rows(document)) {
    for (const json* r : group) {
      const json& row = *r;
      const json& d = row["derived"];
      std::vector<json> cells = {row["scheduler"], row["scheduler_canonical"], row["threads"],
                                 row["oversubscribed"], row["time_seconds"]["median"],
                                 row["time_seconds"]["min"], row["time_seconds"]["max"]};
      for (const char* k : {"sequential_overhead_seconds", "parallel_overhead_seconds",
                            "load_imbalance_seconds", "parallel_work_seconds",
                            "unaccounted_seconds", "imbalance_percent", "thread_work_cv"}) {
        cells.push_back(accounting_field(row, k));
      }
      cells.push_back(row["instrumented"]["level"]);
      cells.push_back(row["instrumented"]["cost_seconds"]);
      const std::optional<double> ratio = instrumentation_cost_ratio(row);
      cells.push_back(ratio ? json(*ratio) : json());
      if (const std::optional<AccountingIdentity> id = accounting_identity(row)) {
        // Its residual is unaccounted_s and its wall over Time instrumentation_cost_ratio.
        cells.insert(cells.end(),
                     {json(id->from_run), id->runs > 0 ? json(id->runs) : json(),
                      json(id->wall_seconds), json(id->overheads_exceed_time), json(id->note)});
      } else {
        cells.insert(cells.end(), 5, json());
      }
      for (const char* k : {"speedup", "efficiency", "speedup_vs_best_1thread",
                            "efficiency_vs_best_1thread"}) {
        cells.push_back(d[k]);
      }
      cells.emplace_back(passed(row) ? "PASSED" : "FAILED");
      cells.emplace_back(timing_label(row));
      for (std::size_t i = 0; i < cells.size(); ++i) {
        out << (i ? "," : "") << csv_cell(cells[i]);
      }
      out << '\n';
    }
  }
  return out.str();
}

json load_sweep_document(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw std::invalid_argument(fmt::format("{}: cannot read the file", file.string()));
  json document;
  try {
    in >> document;
  } catch (const json::exception& error) {
    throw std::invalid_argument(fmt::format("{}: not JSON: {}", file.string(), error.what()));
  }
  const std::vector<std::string> problems = validate_sweep_document(document);
  if (!problems.empty()) {
    std::string text = fmt::format("{}: not a clothbench sweep document:", file.string());
    for (std::size_t i = 0; i < problems.size() && i < 5; ++i) text += "\n  " + problems[i];
    throw std::invalid_argument(text);
  }
  return document;
}

}  // namespace clothbench::harness
