// Parsing of the sweep's list arguments (see sweep_options.hpp).
#include "harness/sweep/sweep_options.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <charconv>
#include <stdexcept>

#include "schedulers/registry.hpp"

namespace clothbench::harness {

namespace {

/// A whole-string non-negative integer, or nullopt.
std::optional<int> parse_int(std::string_view text) {
  int value = 0;
  const auto* end = text.data() + text.size();
  const auto [ptr, error] = std::from_chars(text.data(), end, value);
  if (error != std::errc{} || ptr != end || text.empty()) return std::nullopt;
  return value;
}

}  // namespace

std::vector<std::string> split_list(std::string_view text, const char* flag) {
  std::vector<std::string> items;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = text.find(',', start);
    const std::string_view item =
        text.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start);
    if (item.empty()) {
      throw std::invalid_argument(
          fmt::format("{}: empty item in list '{}' (expected a,b,c)", flag, text));
    }
    items.emplace_back(item);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return items;
}

std::vector<int> parse_thread_list(std::string_view text, const char* flag) {
  std::vector<int> counts;
  for (const std::string& item : split_list(text, flag)) {
    const std::size_t dash = item.find('-');
    std::optional<int> low, high;
    if (dash == std::string::npos) {
      low = high = parse_int(item);
    } else {
      low = parse_int(std::string_view(item).substr(0, dash));
      high = parse_int(std::string_view(item).substr(dash + 1));
    }
    if (!low || !high || *low > *high) {
      throw std::invalid_argument(fmt::format(
          "{}: '{}' is not a thread count (expected positive integers such as 1,2,4 or 1-8)", flag,
          item));
    }
    if (*low < 1) {
      throw std::invalid_argument(
          fmt::format("{}: '{}': thread counts start at 1", flag, item));
    }
    for (int n = *low; n <= *high; ++n) {
      if (std::find(counts.begin(), counts.end(), n) == counts.end()) counts.push_back(n);
    }
  }
  return counts;
}

std::vector<int> default_thread_counts(int cores) {
  std::vector<int> counts;
  for (int n = 1; n < cores; n *= 2) counts.push_back(n);
  counts.push_back(std::max(1, cores));
  return counts;
}

bool reference_counts_in_row(const SweepOptions& options, const std::vector<int>& threads,
                             const ReferenceRunFacts& reference) {
  return !reference.resuming && options.warmup_steps == 0 && options.bind == BindMode::none &&
         !reference.disturbed &&
         reference.wall_seconds >= options.count_reference_after_seconds &&
         std::find(threads.begin(), threads.end(), 1) != threads.end();
}

kernels::Instrumentation parse_instrumentation(std::string_view text) {
  if (text == "off") return kernels::Instrumentation::off;
  if (text == "loops") return kernels::Instrumentation::loops;
  if (text == "chunks") return kernels::Instrumentation::chunks;
  throw std::invalid_argument(
      fmt::format("--instrument: '{}' is not one of off, loops, chunks", text));
}

std::string to_string(kernels::Instrumentation instrumentation) {
  switch (instrumentation) {
    case kernels::Instrumentation::off: return "off";
    case kernels::Instrumentation::loops: return "loops";
    case kernels::Instrumentation::chunks: return "chunks";
  }
  return "off";
}

std::string to_string(BindMode mode) { return mode == BindMode::core ? "core" : "none"; }

std::vector<std::string> canonical_instrument_only(const SweepOptions& options,
                                                   const std::vector<std::string>& grid) {
  std::vector<std::string> canonical;
  for (const std::string& spec : options.instrument_only) {
    if (options.instrument == kernels::Instrumentation::off) {
      throw std::invalid_argument("--instrument-only: needs --instrument loops or chunks");
    }
    std::string name;
    try {
      name = schedulers::make_driver(spec)->name();
    } catch (const std::invalid_argument& error) {
      throw std::invalid_argument(fmt::format("--instrument-only: {}", error.what()));
    }
    if (std::find(grid.begin(), grid.end(), name) == grid.end()) {
      throw std::invalid_argument(
          fmt::format("--instrument-only: '{}' ({}) is not one of --schedulers", spec, name));
    }
    if (std::find(canonical.begin(), canonical.end(), name) == canonical.end()) {
      canonical.push_back(name);
    }
  }
  return canonical;
}

}  // namespace clothbench::harness
