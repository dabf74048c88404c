// The records of `clothbench stress`: one JSON object per cell, and the stress.md / stress.csv
// tables made from the whole document (stress.json). Layout of stress.json:
//   schema "clothbench.stress", schema_version, created_utc, updated_utc, complete, passed,
//   command, settings {size, scheduler, threads, oversubscribed, only},
//   base_scene {name, file, hash, source}, machine, openmp_environment,
//   criteria {mass_relative_tolerance, penetration, cost_growth_factor, cost_floor},
//   cells [cell_json()...], summary {planned, finished, passed, failed}.
// Every number is finite; a figure that is not (or not measured) is null.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "harness/run/run_summary.hpp"  // solver_name
#include "harness/stress/stress_cell.hpp"

namespace clothbench::harness {

inline constexpr int kStressSchemaVersion = 1;

/// One cell's record (the "cells" entries of stress.json).
nlohmann::json cell_json(const StressCellResult& result);

/// The Markdown report: heading, context, one table row per cell, the failures, the overall
/// line ("Result: PASSED (n of n cells)") and the column definitions.
std::string stress_markdown(const nlohmann::json& document);

/// CSV (RFC 4180): a header line and one line per cell; empty fields for null.
std::string stress_csv(const nlohmann::json& document);

/// Checks the structure of a stress document (schema, version, every key of a cell with its
/// JSON type). Returns one line per problem (empty = valid).
std::vector<std::string> validate_stress_document(const nlohmann::json& document);

}  // namespace clothbench::harness
