// stress.json cells, stress.md and stress.csv (see stress_report.hpp).
#include "harness/stress/stress_report.hpp"

#include <fmt/core.h>

#include <cmath>
#include <sstream>

#include "harness/report/sweep_table.hpp"
#include "harness/stress/stress_matrix.hpp"

namespace clothbench::harness {

using nlohmann::json;

namespace {

json number(double v) { return std::isfinite(v) ? json(v) : json(); }

json trend_json(const Trend& t) {
  if (!t.assessed) {
    return {{"quarter_means", nullptr}, {"last_to_first", nullptr}, {"grows_without_bound", false}};
  }
  json quarters = json::array();
  for (double q : t.quarter_mean) quarters.push_back(number(q));
  return {{"quarter_means", quarters},
          {"last_to_first", t.ratio ? number(*t.ratio) : json()},
          {"grows_without_bound", t.growing}};
}

/// The cost trend with its bound: the rejection level and whether the last quarter left it.
json cost_trend_json(const StressCellResult& r) {
  json t = trend_json(r.cost_trend);
  t["bound"] = number(r.cost_bound);
  t["last_quarter_above_bound"] =
      r.cost_trend.assessed && !(r.cost_trend.quarter_mean[3] <= r.cost_bound);
  return t;
}

/// A figure for the Markdown table: `format` applied, "-" for null.
std::string shown(const json& value, const char* format) {
  if (!value.is_number()) return "-";
  return fmt::format(fmt::runtime(format), value.get<double>());
}

std::string non_finite_text(const json& nf) {
  if (nf.is_null()) return "-";
  if (nf["element"] == "step") {
    return fmt::format("step {}: {}", nf["step"].get<int>(), nf["term"].get<std::string>());
  }
  return fmt::format("step {}: {} of {} {} = {}", nf["step"].get<int>(),
                     nf["term"].get<std::string>(), nf["element"].get<std::string>(),
                     nf["index"].get<std::string>(), nf["value"].get<std::string>());
}

std::string trend_text(const json& trend) {
  std::string text = shown(trend["last_to_first"], "{:.3g}");
  if (trend["grows_without_bound"].get<bool>()) text += " (grows)";
  if (trend.value("last_quarter_above_bound", false)) text += " (above bound)";
  return text;
}

}  // namespace

json cell_json(const StressCellResult& r) {
  json non_finite;
  if (r.non_finite) {
    non_finite = {{"step", r.non_finite->step},   {"element", r.non_finite->element},
                  {"index", r.non_finite->index}, {"term", r.non_finite->term},
                  {"value", r.non_finite->value}, {"text", r.non_finite->text}};
    // The snapshot's files by name: they sit next to stress.json.
    json files = json::array();
    for (const auto& file : r.snapshot_files) files.push_back(file.filename().string());
    non_finite["snapshot"] = files;
  }
  const double steps = std::max(1, r.steps_completed);
  return {
      {"name", r.name},
      {"axis", r.axis},
      {"change", r.change},
      {"particles", {r.particles_i, r.particles_j}},
      {"time_step_s", number(r.time_step)},
      {"contact_distance_m", number(r.contact_distance)},
      {"steps", {{"planned", r.steps_planned}, {"completed", r.steps_completed}}},
      {"non_finite", non_finite},
      {"max_strain", number(r.max_strain)},
      {"min_strain", number(r.min_strain)},
      {"max_penetration_m",
       {{"particles", number(r.max_particle_penetration)},
        {"surface", number(r.max_surface_penetration)}}},
      {"max_ghost_offset_m", number(r.max_ghost_offset)},
      {"mass_drift", number(r.mass_drift)},
      {"cost_trend", cost_trend_json(r)},
      {"work_trend", trend_json(r.work_trend)},
      {"kinetic_energy",
       {{"max_j", number(r.max_kinetic_energy)}, {"trend", trend_json(r.kinetic_energy_trend)}}},
      {"cg",  // the step minimiser's work (the key predates Newton)
       {{"method", r.method},
        {"iterations", r.cg_iterations},
        {"linear_iterations", r.linear_iterations},
        {"evaluations", r.evaluations},
        {"per_step_mean", number(static_cast<double>(r.cg_iterations) / steps)},
        {"per_step_max", r.max_step_iterations}}},
      {"rejected_steps", r.rejected_steps},
      {"unconverged_steps", r.unconverged_steps},
      {"amrc",
       {{"checks", r.amrc_checks}, {"refined", r.amrc_refined}, {"coarsened", r.amrc_coarsened}}},
      {"seconds", {{"steps", number(r.step_seconds)}, {"wall", number(r.wall_seconds)}}},
      {"memory",
       {{"start_resident_bytes", r.memory.start_bytes},
        {"peak_resident_bytes", r.memory.peak_bytes},
        {"scope", r.memory.scope}}},
      {"passed", r.passed},
      {"failures", r.failures}};
}

namespace {

/// "Newton 4" / "CG 12": the mean iterations a step, named by the method that ran (documents
/// written before the method was recorded show the number alone).
std::string solver_mean(const json& cg) {
  const std::string mean = shown(cg["per_step_mean"], "{:.0f}");
  const std::string name = solver_name(cg.value("method", std::string()));
  return name.empty() ? mean : fmt::format("{} {}", name, mean);
}

/// The most iterations of one step; under Newton with its inner PCG iterations a step.
std::string solver_max(const json& cg, int steps) {
  const std::string max = fmt::format("{}", cg["per_step_max"].get<int>());
  if (solver_name(cg.value("method", std::string())) != "Newton" || steps <= 0) return max;
  return fmt::format("{} (PCG {:.0f} a step)", max,
                     cg.value("linear_iterations", std::int64_t{0}) / static_cast<double>(steps));
}

}  // namespace

std::string stress_markdown(const json& document) {
  std::ostringstream out;
  const json& settings = document["settings"];
  const json& base = document["base_scene"];
  out << fmt::format("# Stress matrix ({})\n\n", settings["size"].get<std::string>());
  out << fmt::format(
      "Base scene: {} (`{}`, hash {}). Scheduler {}, {} threads{}. {}.\n\n",
      base["name"].get<std::string>(), base["file"].get<std::string>(),
      base["hash"].get<std::string>(), settings["scheduler"].get<std::string>(),
      settings["threads"].get<int>(),
      settings["oversubscribed"].get<bool>() ? " (oversubscribed)" : "",
      document["complete"].get<bool>() ? "Complete" : "Incomplete (stopped or still running)");
  if (settings["size"] == "quick") {
    out << fmt::format(
        "The quick size runs every cell on {} x {} particles but the mesh cells, with few "
        "steps.\n\n",
        kQuickParticles, kQuickParticles);
  }
  out << "| cell | change | particles | steps | first non-finite | strain min / max | max "
         "penetration "
         "particles / surface (mm) | cost trend | mass drift | solver iterations per step (mean / "
         "max) | rejected / unconverged steps | time (s) | result |\n";
  out << "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  std::vector<std::string> failures;
  for (const json& c : document["cells"]) {
    const json& pen = c["max_penetration_m"];
    const bool passed = c["passed"].get<bool>();
    out << fmt::format(
        "| {} | {} | {} x {} | {} / {} | {} | {} / {} | {} / {} | {} | {} | {} / {} | {} / {} | {} "
        "| {} "
        "|\n",
        c["name"].get<std::string>(), c["change"].get<std::string>(), c["particles"][0].get<int>(),
        c["particles"][1].get<int>(), c["steps"]["completed"].get<int>(),
        c["steps"]["planned"].get<int>(), non_finite_text(c["non_finite"]),
        shown(c["min_strain"], "{:.4f}"), shown(c["max_strain"], "{:.4f}"),
        pen["particles"].is_number() ? fmt::format("{:.3f}", 1e3 * pen["particles"].get<double>())
                                     : "-",
        pen["surface"].is_number() ? fmt::format("{:.3f}", 1e3 * pen["surface"].get<double>())
                                   : "-",
        trend_text(c["cost_trend"]), shown(c["mass_drift"], "{:.1e}"), solver_mean(c["cg"]),
        solver_max(c["cg"], c["steps"]["completed"].get<int>()),
        c["rejected_steps"].get<std::int64_t>(), c["unconverged_steps"].get<int>(),
        shown(c["seconds"]["wall"], "{:.1f}"), passed ? "PASSED" : "FAILED");
    for (const json& f : c["failures"]) {
      failures.push_back(
          fmt::format("- {}: {}", c["name"].get<std::string>(), f.get<std::string>()));
    }
  }
  const json& summary = document["summary"];
  // A report written before its first cell finished has nothing to pass or fail yet.
  const bool none_finished = summary["finished"].get<int>() == 0;
  out << fmt::format("\nResult: {} ({} of {} cells passed{})\n",
                     none_finished                    ? "NONE FINISHED YET"
                     : document["passed"].get<bool>() ? "PASSED"
                                                      : "FAILED",
                     summary["passed"].get<int>(), summary["finished"].get<int>(),
                     summary["finished"] == summary["planned"]
                         ? ""
                         : fmt::format("; {} of {} cells finished", summary["finished"].get<int>(),
                                       summary["planned"].get<int>()));
  if (!failures.empty()) {
    out << "\nFailures:\n\n";
    for (const std::string& f : failures) out << f << '\n';
  }
  out << "\nColumns: *steps* completed / planned; *first non-finite*: the step and the value "
         "where the state stopped being finite; *max penetration*: deepest active particle and "
         "deepest point of the interpolated surface inside an obstacle over the run (a particle "
         "must stay outside, as in every run; the surface below the contact distance); *cost "
         "trend*: mean of the steps' final squared RMS residual over the last quarter of the "
         "run divided by that of the first quarter, "
         "\"(grows)\" when it grows without bound (last quarter above 10x the larger of the first "
         "quarter and the step-rejection level, reject_residual squared, and not falling), "
         "\"(above bound)\" when the last quarter's mean is above that level (its steps were "
         "accepted only because their halvings ran out); either fails the cell; "
         "*mass drift*: largest relative "
         "error of the total mass over the run (must stay <= 1e-12); *rejected steps*: attempts "
         "redone as two half steps; *unconverged steps*: steps accepted above the solver's "
         "tolerance (iteration cap, stalled line search, or halvings exhausted); *time*: wall time "
         "of the cell with its per-step checks.\n";
  return out.str();
}

std::string stress_csv(const json& document) {
  const std::vector<std::string> header = {"cell",
                                           "axis",
                                           "change",
                                           "particles_i",
                                           "particles_j",
                                           "time_step_s",
                                           "steps_planned",
                                           "steps_completed",
                                           "non_finite_step",
                                           "non_finite_element",
                                           "non_finite_index",
                                           "non_finite_term",
                                           "non_finite_value",
                                           "max_strain",
                                           "min_strain",
                                           "max_particle_penetration_m",
                                           "max_surface_penetration_m",
                                           "contact_distance_m",
                                           "max_ghost_offset_m",
                                           "mass_drift",
                                           "cost_last_to_first",
                                           "cost_grows_without_bound",
                                           "cost_last_quarter_above_bound",
                                           "work_last_to_first",
                                           "max_kinetic_energy_j",
                                           "solver_method",
                                           "cg_iterations",
                                           "cg_iterations_per_step_mean",
                                           "cg_iterations_per_step_max",
                                           "linear_iterations",
                                           "evaluations",
                                           "rejected_steps",
                                           "unconverged_steps",
                                           "amrc_checks",
                                           "step_seconds",
                                           "wall_seconds",
                                           "passed",
                                           "failures"};
  std::ostringstream out;
  for (std::size_t i = 0; i < header.size(); ++i) out << (i ? "," : "") << header[i];
  out << '\n';
  for (const json& c : document["cells"]) {
    const json& nf = c["non_finite"];
    auto nf_field = [&](const char* key) { return nf.is_null() ? json() : nf[key]; };
    std::string failures;
    for (const json& f : c["failures"])
      failures += (failures.empty() ? "" : "; ") + f.get<std::string>();
    const std::vector<json> fields = {c["name"],
                                      c["axis"],
                                      c["change"],
                                      c["particles"][0],
                                      c["particles"][1],
                                      c["time_step_s"],
                                      c["steps"]["planned"],
                                      c["steps"]["completed"],
                                      nf_field("step"),
                                      nf_field("element"),
                                      nf_field("index"),
                                      nf_field("term"),
                                      nf_field("value"),
                                      c["max_strain"],
                                      c["min_strain"],
                                      c["max_penetration_m"]["particles"],
                                      c["max_penetration_m"]["surface"],
                                      c["contact_distance_m"],
                                      c["max_ghost_offset_m"],
                                      c["mass_drift"],
                                      c["cost_trend"]["last_to_first"],
                                      c["cost_trend"]["grows_without_bound"],
                                      c["cost_trend"]["last_quarter_above_bound"],
                                      c["work_trend"]["last_to_first"],
                                      c["kinetic_energy"]["max_j"],
                                      c["cg"].value("method", json()),
                                      c["cg"]["iterations"],
                                      c["cg"]["per_step_mean"],
                                      c["cg"]["per_step_max"],
                                      c["cg"].value("linear_iterations", json()),
                                      c["cg"]["evaluations"],
                                      c["rejected_steps"],
                                      c["unconverged_steps"],
                                      c["amrc"]["checks"],
                                      c["seconds"]["steps"],
                                      c["seconds"]["wall"],
                                      c["passed"],
                                      failures};
    for (std::size_t i = 0; i < fields.size(); ++i) out << (i ? "," : "") << csv_cell(fields[i]);
    out << '\n';
  }
  return out.str();
}

std::vector<std::string> validate_stress_document(const json& d) {
  std::vector<std::string> problems;
  auto expect = [&](const json& parent, const std::string& path, const char* key,
                    bool (json::*is)() const noexcept, bool nullable = false) {
    if (!parent.is_object() || !parent.contains(key)) {
      problems.push_back(path + "." + key + ": missing");
      return;
    }
    const json& v = parent[key];
    if (!(v.*is)() && !(nullable && v.is_null())) {
      problems.push_back(path + "." + key + ": wrong type (" + v.type_name() + ")");
    }
  };
  expect(d, "stress", "schema", &json::is_string);
  if (problems.empty() && d["schema"] != "clothbench.stress")
    problems.push_back("stress.schema: not clothbench.stress");
  expect(d, "stress", "schema_version", &json::is_number_integer);
  if (d.contains("schema_version") && d["schema_version"] != kStressSchemaVersion) {
    problems.push_back("stress.schema_version: not " + std::to_string(kStressSchemaVersion));
  }
  for (const char* key : {"created_utc", "updated_utc"}) expect(d, "stress", key, &json::is_string);
  for (const char* key : {"complete", "passed"}) expect(d, "stress", key, &json::is_boolean);
  for (const char* key : {"settings", "base_scene", "machine", "criteria", "summary"}) {
    expect(d, "stress", key, &json::is_object);
  }
  expect(d, "stress", "cells", &json::is_array);
  if (!d.contains("cells") || !d["cells"].is_array()) return problems;
  for (std::size_t i = 0; i < d["cells"].size(); ++i) {
    const json& c = d["cells"][i];
    const std::string path = "stress.cells[" + std::to_string(i) + "]";
    for (const char* key : {"name", "axis", "change"}) expect(c, path, key, &json::is_string);
    for (const char* key : {"particles", "failures"}) expect(c, path, key, &json::is_array);
    for (const char* key : {"steps", "max_penetration_m", "cost_trend", "work_trend",
                            "kinetic_energy", "cg", "amrc", "seconds"}) {
      expect(c, path, key, &json::is_object);
    }
    expect(c, path, "non_finite", &json::is_object, true);
    for (const char* key : {"time_step_s", "contact_distance_m", "max_strain", "min_strain",
                            "max_ghost_offset_m", "mass_drift"}) {
      expect(c, path, key, &json::is_number, true);
    }
    for (const char* key : {"rejected_steps", "unconverged_steps"}) {
      expect(c, path, key, &json::is_number_integer);
    }
    expect(c, path, "passed", &json::is_boolean);
    // Inside the blocks that are objects (a block of the wrong type is reported above).
    auto inner = [&](const char* block, const char* key, bool (json::*is)() const noexcept,
                     bool nullable = false) {
      if (c.is_object() && c.contains(block) && c[block].is_object()) {
        expect(c[block], path + "." + block, key, is, nullable);
      }
    };
    inner("steps", "planned", &json::is_number_integer);
    inner("steps", "completed", &json::is_number_integer);
    inner("max_penetration_m", "particles", &json::is_number, true);
    inner("max_penetration_m", "surface", &json::is_number, true);
    inner("cost_trend", "last_to_first", &json::is_number, true);
    inner("cost_trend", "grows_without_bound", &json::is_boolean);
    inner("cost_trend", "last_quarter_above_bound", &json::is_boolean);
    inner("cg", "iterations", &json::is_number_integer);
    inner("seconds", "wall", &json::is_number, true);
    // Absent in documents written before memory was measured.
    if (c.is_object() && c.contains("memory") && !c["memory"].is_object()) {
      problems.push_back(path + ".memory: wrong type (" + c["memory"].type_name() + ")");
    }
    inner("memory", "start_resident_bytes", &json::is_number_integer);
    inner("memory", "peak_resident_bytes", &json::is_number_integer);
    inner("memory", "scope", &json::is_string);
  }
  return problems;
}

}  // namespace clothbench::harness
