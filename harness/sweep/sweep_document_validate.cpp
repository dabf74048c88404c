// Validation of the sweep document (see sweep_document.hpp): every field a reader relies on,
// with the path of each problem; older documents' absent blocks are accepted.
#include <fmt/core.h>

#include <stdexcept>

#include "harness/sweep/sweep_document.hpp"

namespace clothbench::harness {

using nlohmann::json;

namespace {

/// Appends a problem when `object[key]` is missing or fails `is_type`.
template <class Check>
void expect(const json& object, const std::string& where, const char* key, Check is_type,
            const char* type, std::vector<std::string>& problems) {
  if (!object.is_object() || !object.contains(key)) {
    problems.push_back(fmt::format("{}: missing key '{}'", where, key));
  } else if (!is_type(object[key])) {
    problems.push_back(fmt::format("{}.{}: expected {}", where, key, type));
  }
}

/// Calls check(entry, "key[i]") for every entry of the optional array d[key]; a problem when
/// d[key] is there but not an array.
template <class Check>
void each_entry(const json& d, const char* key, std::vector<std::string>& problems, Check check) {
  if (!d.contains(key)) return;
  if (!d[key].is_array()) {
    problems.push_back(fmt::format("document.{}: expected array", key));
    return;
  }
  for (std::size_t i = 0; i < d[key].size(); ++i) check(d[key][i], fmt::format("{}[{}]", key, i));
}

const auto is_number = [](const json& j) { return j.is_number(); };
const auto is_number_or_null = [](const json& j) { return j.is_number() || j.is_null(); };
const auto is_string = [](const json& j) { return j.is_string(); };
const auto is_bool = [](const json& j) { return j.is_boolean(); };
const auto is_array = [](const json& j) { return j.is_array(); };
const auto is_object = [](const json& j) { return j.is_object(); };
const auto is_object_or_null = [](const json& j) { return j.is_object() || j.is_null(); };
const auto is_integer = [](const json& j) { return j.is_number_integer(); };

void validate_statistics(const json& s, const std::string& where, std::vector<std::string>& p) {
  for (const char* k : {"median", "min", "max"}) expect(s, where, k, is_number, "number", p);
  expect(s, where, "samples", is_array, "array", p);
  if (p.empty() && !(s["min"] <= s["median"] && s["median"] <= s["max"])) {
    p.push_back(where + ": min <= median <= max does not hold");
  }
}

void validate_row_into(const json& row, const std::string& w, std::vector<std::string>& p);

/// Appends the problems of one row to `all`.
void validate_row(const json& row, const std::string& w, std::vector<std::string>& all) {
  std::vector<std::string> p;
  validate_row_into(row, w, p);
  all.insert(all.end(), p.begin(), p.end());
}

void validate_row_into(const json& row, const std::string& w, std::vector<std::string>& p) {
  expect(row, w, "scheduler", is_string, "string", p);
  expect(row, w, "scheduler_canonical", is_string, "string", p);
  expect(row, w, "note", is_string, "string", p);
  expect(row, w, "threads", is_integer, "integer", p);
  expect(row, w, "oversubscribed", is_bool, "bool", p);
  expect(row, w, "time_seconds", is_object, "object", p);
  expect(row, w, "instrumented", is_object, "object", p);
  expect(row, w, "accounting", is_object_or_null, "object or null", p);
  if (row.is_object() && row.contains("disturbance")) {  // absent in older documents
    const json& d = row["disturbance"];
    expect(d, w + ".disturbance", "disturbed", is_bool, "bool", p);
    expect(d, w + ".disturbance", "disturbed_runs", is_integer, "integer", p);
    expect(d, w + ".disturbance", "runs", is_integer, "integer", p);
    expect(d, w + ".disturbance", "reruns", is_integer, "integer", p);
    expect(d, w + ".disturbance", "records", is_array, "array", p);
  }
  if (row.is_object() && row.contains("memory")) {  // absent in older documents
    const json& m = row["memory"];
    expect(m, w + ".memory", "peak_resident_bytes", is_number_or_null, "number or null", p);
    expect(m, w + ".memory", "scope", is_string, "string", p);
    expect(m, w + ".memory", "runs_measured", is_integer, "integer", p);
    expect(m, w + ".memory", "runs", is_integer, "integer", p);
    expect(m, w + ".memory", "records", is_array, "array", p);
  }
  expect(row, w, "verification", is_object, "object", p);
  expect(row, w, "cg_iterations", is_integer, "integer", p);
  expect(row, w, "steps", is_integer, "integer", p);
  expect(row, w, "binding", is_object, "object", p);
  expect(row, w, "derived", is_object, "object", p);
  if (!p.empty()) return;
  validate_statistics(row["time_seconds"], w + ".time_seconds", p);
  const json& v = row["verification"];
  expect(v, w + ".verification", "passed", is_bool, "bool", p);
  expect(v, w + ".verification", "failures", is_array, "array", p);
  expect(v, w + ".verification", "bit_identical", is_bool, "bool", p);
  expect(v, w + ".verification", "state_digest", is_string, "string", p);
  expect(v, w + ".verification", "max_mass_error", is_number, "number", p);
  for (const char* k : {"speedup", "efficiency", "speedup_vs_best_1thread",
                        "efficiency_vs_best_1thread"}) {
    expect(row["derived"], w + ".derived", k, is_number_or_null, "number or null", p);
  }
  if (row["accounting"].is_object()) {
    for (const char* k : {"wall_seconds", "step_seconds", "sequential_overhead_seconds",
                          "parallel_overhead_seconds", "load_imbalance_seconds",
                          "parallel_work_seconds", "unaccounted_seconds", "imbalance_percent",
                          "thread_work_cv"}) {
      expect(row["accounting"], w + ".accounting", k, is_number, "number", p);
    }
    expect(row["accounting"], w + ".accounting", "thread_work_seconds", is_array, "array", p);
    if (row["accounting"].contains("identity")) {  // absent in older documents
      const json& id = row["accounting"]["identity"];
      const std::string where = w + ".accounting.identity";
      for (const char* k : {"wall_seconds", "parts_seconds", "residual_seconds",
                            "overheads_seconds", "time_median_seconds", "wall_over_time"}) {
        expect(id, where, k, is_number, "number", p);
      }
      expect(id, where, "overheads_exceed_time", is_bool, "bool", p);
      expect(id, where, "note", is_string, "string", p);
    }
  }
  const json& b = row["binding"];
  expect(b, w + ".binding", "mode", is_string, "string", p);
  expect(b, w + ".binding", "threads", is_array, "array", p);
}

/// The run records marked `reference` agree with `reference.counted_in_row`: when counted,
/// the first uninstrumented run of the reference's row (finished or partial) is the only
/// marked run; otherwise no run is. Records written before runs were marked carry no field and
/// are not checked (a sweep begun by an older build and resumed by a newer one).
void validate_reference_marks(const json& d, std::vector<std::string>& p) {
  const json& reference = d["reference"];
  const bool counted = reference.value("counted_in_row", false);
  const std::string scheduler = reference.value("scheduler", "");
  const int reference_threads = reference.value("threads", 1);
  auto marked = [](const json& record) {
    return record.is_object() && record.value("reference", false);
  };
  auto check_list = [&](const json& records, bool is_reference_row, const std::string& where,
                        auto instrumented_of) {
    for (std::size_t r = 0; r < records.size(); ++r) {
      const json& record = records[r];
      const bool first_plain = is_reference_row && r == 0 && !instrumented_of(record);
      if (marked(record) && !(counted && first_plain)) {
        p.push_back(fmt::format("{}[{}].reference: marks a run that is not the counted reference "
                                "run (reference.counted_in_row is {})",
                                where, r, counted));
      }
      if (first_plain && counted && record.is_object() && record.contains("reference") &&
          !marked(record)) {
        p.push_back(fmt::format("{}[{}].reference: reference.counted_in_row is true but the "
                                "row's first run is not marked as the reference run",
                                where, r));
      }
    }
  };
  for (std::size_t i = 0; i < d["rows"].size(); ++i) {
    const json& row = d["rows"][i];
    if (!row.contains("disturbance")) continue;
    const bool is_reference_row = row.value("scheduler_canonical", "") == scheduler &&
                                  row.value("threads", 0) == reference_threads;
    check_list(row["disturbance"]["records"], is_reference_row,
               fmt::format("rows[{}].disturbance.records", i),
               [](const json& record) { return record.value("instrumented", false); });
  }
  if (!d.contains("partial_rows") || !d["partial_rows"].is_array()) return;
  for (std::size_t i = 0; i < d["partial_rows"].size(); ++i) {
    const json& entry = d["partial_rows"][i];
    const bool is_reference_row = entry.value("scheduler_canonical", "") == scheduler &&
                                  entry.value("threads", 0) == reference_threads;
    auto never = [](const json&) { return false; };
    auto always = [](const json&) { return true; };
    check_list(entry["plain"], is_reference_row, fmt::format("partial_rows[{}].plain", i), never);
    check_list(entry["timed"], false, fmt::format("partial_rows[{}].timed", i), always);
  }
}

}  // namespace

std::vector<std::string> validate_sweep_document(const json& d) {
  if (!d.is_object()) return {"document: expected a JSON object"};
  std::vector<std::string> version;  // reported, but the structure is still checked
  if (d.value("schema", "") != "clothbench.sweep") version.push_back("schema: expected \"clothbench.sweep\"");
  if (d.value("schema_version", 0) != kSweepSchemaVersion) {
    version.push_back(fmt::format("schema_version: expected {}", kSweepSchemaVersion));
  }
  std::vector<std::string> p;
  for (const char* k : {"created_utc", "updated_utc"}) expect(d, "document", k, is_string, "string", p);
  expect(d, "document", "complete", is_bool, "bool", p);
  expect(d, "document", "command", is_array, "array", p);
  for (const char* k : {"settings", "scene", "machine", "openmp_environment", "reference"}) {
    expect(d, "document", k, is_object, "object", p);
  }
  expect(d, "document", "rows", is_array, "array", p);
  if (!p.empty()) {
    p.insert(p.begin(), version.begin(), version.end());
    return p;
  }
  for (const char* k : {"name", "file", "hash", "source"}) expect(d["scene"], "scene", k, is_string, "string", p);
  expect(d["reference"], "reference", "state_digest", is_string, "string", p);
  // Absent in older documents.
  if (d["reference"].contains("wall_seconds")) {
    expect(d["reference"], "reference", "wall_seconds", is_number, "number", p);
  }
  for (const char* k : {"disturbed", "counted_in_row"}) {
    if (d["reference"].contains(k)) expect(d["reference"], "reference", k, is_bool, "bool", p);
  }
  // Absent in older documents.
  each_entry(d, "sessions", p, [&](const json& session, const std::string& where) {
    expect(session, where, "started_utc", is_string, "string", p);
    expect(session, where, "rows_at_start", is_integer, "integer", p);
    expect(session, where, "reference", is_string, "string", p);
    if (session.is_object() && session.contains("reference") && session["reference"] != "run" &&
        session["reference"] != "stored" && session["reference"] != "digest") {
      p.push_back(where + ".reference: expected \"run\", \"stored\" or \"digest\"");
    }
  });
  // Present only while a row is unfinished.
  each_entry(d, "partial_rows", p, [&](const json& entry, const std::string& where) {
    expect(entry, where, "scheduler_canonical", is_string, "string", p);
    expect(entry, where, "threads", is_integer, "integer", p);
    if (entry.is_object() && entry.contains("core_round_trip_before_ns")) {
      expect(entry, where, "core_round_trip_before_ns", is_number, "number", p);
    }
    for (const char* list : {"plain", "timed"}) {
      expect(entry, where, list, is_array, "array", p);
      if (!entry.is_object() || !entry.contains(list) || !entry[list].is_array()) continue;
      for (std::size_t r = 0; r < entry[list].size(); ++r) {
        try {
          (void)measured_run_from_json(entry[list][r]);
        } catch (const std::invalid_argument& e) {
          p.push_back(fmt::format("{}.{}[{}]: {}", where, list, r, e.what()));
        }
      }
    }
  });
  expect(d["settings"], "settings", "schedulers", is_array, "array", p);
  expect(d["settings"], "settings", "threads", is_array, "array", p);
  expect(d["settings"], "settings", "steps", is_integer, "integer", p);
  expect(d["settings"], "settings", "instrument", is_string, "string", p);
  if (d["settings"].is_object() && d["settings"].contains("instrument_only")) {  // newer documents
    expect(d["settings"], "settings", "instrument_only", is_array, "array", p);
  }
  for (std::size_t i = 0; i < d["rows"].size(); ++i) {
    validate_row(d["rows"][i], fmt::format("rows[{}]", i), p);
  }
  if (p.empty()) validate_reference_marks(d, p);
  p.insert(p.begin(), version.begin(), version.end());
  return p;
}

}  // namespace clothbench::harness
