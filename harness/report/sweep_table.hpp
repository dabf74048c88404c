// Tables from a sweep document (harness/sweep/sweep_document.hpp): the paper's Table 2
// layout (threads, seq. overhead, para. overhead, time, speed-up; plus load imbalance,
// efficiency and verification) per scheduler, as Markdown or CSV; under each scheduler's
// table the accounting of the instrumented run its overheads come from (the identity
// wall = seq. overhead + parallel work + para. overhead + imbalance + residual).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace clothbench::harness {

/// Fills every row's `derived` block: speedup and efficiency against the 1-thread row of
/// the same scheduler, and against the fastest passed 1-thread row of any scheduler.
/// A row that failed verification or is disturbed (row_disturbed), or whose baseline failed,
/// is disturbed or is missing, gets nulls: such a run never appears as a speed-up.
void add_derived(nlohmann::json& document);

/// True when the row's runs stayed disturbed by other work (its `disturbance` block; rows of
/// older documents without one are not).
bool row_disturbed(const nlohmann::json& row);

/// Markdown: a heading and context paragraph, then one Table-2 style table per scheduler
/// (in the order of settings.schedulers, threads ascending) and the column definitions.
std::string format_markdown(const nlohmann::json& document);

/// The per-row line the sweep prints when a row is finished: time (median, min-max), the
/// instrumented run the overheads come from with its identity wall = seq + work + para +
/// imbalance + residual and its wall against the Time, verification and timing verdicts.
std::string format_row_line(const nlohmann::json& row);

/// CSV (RFC 4180, header line, one line per row, empty cell for a missing value).
std::string format_csv(const nlohmann::json& document);

/// One CSV field (RFC 4180): empty for null, true/false, integers as such, other numbers with
/// 9 significant digits, text quoted when it holds a comma, quote or line break.
std::string csv_cell(const nlohmann::json& value);

/// Reads and validates a sweep document; throws std::invalid_argument naming the file and
/// the first problems when it cannot be read, parsed or is not a valid sweep document.
nlohmann::json load_sweep_document(const std::filesystem::path& file);

}  // namespace clothbench::harness
