// Row-by-row comparison of two sweep documents and its Markdown / JSON forms
// (compare_runs.hpp).
#include "harness/compare/compare_runs.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "harness/report/sweep_table.hpp"

namespace clothbench::harness {

using nlohmann::json;

std::string to_string(CompareVerdict verdict) {
  switch (verdict) {
    case CompareVerdict::slower:
      return "slower";
    case CompareVerdict::faster:
      return "faster";
    case CompareVerdict::no_difference:
      return "same";
    case CompareVerdict::failed:
      return "FAILED";
    case CompareVerdict::disturbed:
      return "DISTURBED";
    case CompareVerdict::only_in_a:
      return "only in A";
    case CompareVerdict::only_in_b:
      return "only in B";
  }
  return "?";
}

int Comparison::regressions() const {
  return static_cast<int>(
      std::count_if(rows.begin(), rows.end(), [](const RowComparison& r) { return r.regression; }));
}

namespace {

/// The row's timed repetitions (time_seconds.samples); empty when any is not a positive number.
std::vector<double> timed_samples(const json& row) {
  std::vector<double> samples;
  for (const json& s : row["time_seconds"]["samples"]) {
    if (!s.is_number() || !(s.get<double>() > 0.0)) return {};
    samples.push_back(s.get<double>());
  }
  return samples;
}

/// clothbench's and LB4OMP's imbalance of a row, when it has an accounting block.
void imbalances(const json& row, std::optional<double>& clothbench, std::optional<double>& lb4omp) {
  const json& a = row["accounting"];
  if (!a.is_object()) return;
  clothbench = a["imbalance_percent"].get<double>();
  std::vector<double> work;
  for (const json& w : a["thread_work_seconds"]) {
    if (w.is_number()) work.push_back(w.get<double>());
  }
  lb4omp = lb4omp_percent_imbalance(work);
}

const json* find_row(const json& document, const std::string& scheduler, int threads) {
  for (const json& row : document["rows"]) {
    if (row["scheduler_canonical"] == scheduler && row["threads"] == threads) return &row;
  }
  return nullptr;
}

/// Which of A and B a condition holds in: "A", "B", "A and B".
std::string which(bool in_a, bool in_b) { return in_a && in_b ? "A and B" : (in_a ? "A" : "B"); }

RowComparison compare_row(const json& a, const json& b, const CompareOptions& options) {
  RowComparison c;
  c.scheduler = a["scheduler_canonical"].get<std::string>();
  c.threads = a["threads"].get<int>();
  const std::vector<double> sa = timed_samples(a), sb = timed_samples(b);
  c.repetitions_a = a["time_seconds"]["samples"].size();
  c.repetitions_b = b["time_seconds"]["samples"].size();
  imbalances(a, c.imbalance_a, c.lb4omp_a);
  imbalances(b, c.imbalance_b, c.lb4omp_b);
  const bool failed_a = !a["verification"]["passed"].get<bool>();
  const bool failed_b = !b["verification"]["passed"].get<bool>();
  if (failed_a || failed_b) {
    c.verdict = CompareVerdict::failed;
    c.notes.push_back(fmt::format("FAILED verification in {}: its times are not compared",
                                  which(failed_a, failed_b)));
    return c;
  }
  if (sa.empty() || sb.empty()) {
    c.verdict = CompareVerdict::failed;
    c.notes.push_back(fmt::format("no positive timed repetitions in {}: not compared",
                                  which(sa.empty(), sb.empty())));
    return c;
  }
  c.median_a = median(sa);
  c.median_b = median(sb);
  c.ratio = *c.median_b / *c.median_a;
  c.interval = bootstrap_ratio_of_medians(sa, sb, options.resamples, options.seed);
  c.test = mann_whitney_u(sa, sb);
  c.few_repetitions = sa.size() < kRecommendedRepetitions || sb.size() < kRecommendedRepetitions;
  if (c.few_repetitions) {
    c.notes.push_back(fmt::format("{} / {} repetitions: fewer than {}, the test has little power",
                                  sa.size(), sb.size(), kRecommendedRepetitions));
  }
  const bool disturbed_a = row_disturbed(a), disturbed_b = row_disturbed(b);
  if (disturbed_a || disturbed_b) {
    c.verdict = CompareVerdict::disturbed;
    c.notes.push_back(
        fmt::format("DISTURBED in {}: figures shown, no verdict", which(disturbed_a, disturbed_b)));
    return c;
  }
  if (c.test->p_value < options.alpha) {
    // B tends to be slower when more (a, b) pairs have b > a, i.e. U of B exceeds U of A.
    c.verdict = c.test->u_y > c.test->u_x ? CompareVerdict::slower : CompareVerdict::faster;
  } else {
    c.verdict = CompareVerdict::no_difference;
  }
  c.regression = c.verdict == CompareVerdict::slower && *c.ratio > 1.0 + options.threshold;
  if (c.regression) {
    c.notes.push_back(fmt::format("REGRESSION: {:+.1f} % beyond the {:.1f} % threshold",
                                  100.0 * (*c.ratio - 1.0), 100.0 * options.threshold));
  }
  return c;
}

RowComparison unmatched(const json& row, CompareVerdict verdict) {
  RowComparison c;
  c.scheduler = row["scheduler_canonical"].get<std::string>();
  c.threads = row["threads"].get<int>();
  c.verdict = verdict;
  (verdict == CompareVerdict::only_in_a ? c.repetitions_a : c.repetitions_b) =
      row["time_seconds"]["samples"].size();
  c.notes.push_back(verdict == CompareVerdict::only_in_a ? "unmatched: no such row in B"
                                                         : "unmatched: no such row in A");
  return c;
}

std::string number(const std::optional<double>& value, const char* format) {
  return value ? fmt::format(fmt::runtime(format), *value) : "-";
}

/// One line about a document: scene, steps, when and from which revision.
std::string about(const json& d) {
  const json& build = d["machine"].value("build", json::object());
  return fmt::format("scene \"{}\" ({}), {} steps, created {}, revision {}",
                     d["scene"]["name"].get<std::string>(), d["scene"]["hash"].get<std::string>(),
                     d["settings"]["steps"].get<int>(), d["created_utc"].get<std::string>(),
                     build.value("git_revision", std::string("unknown")));
}

json number_json(const std::optional<double>& value) {
  return value ? json(*value) : json(nullptr);
}

}  // namespace

Comparison compare_sweeps(const json& a, const json& b, const std::string& file_a,
                          const std::string& file_b, const CompareOptions& options) {
  Comparison comparison{file_a, file_b, about(a), about(b), options, {}, {}};
  if (a["scene"]["hash"] != b["scene"]["hash"]) {
    comparison.warnings.push_back(
        fmt::format("the documents are of different scenes: A {} ({}), B {} ({})",
                    a["scene"]["name"].get<std::string>(), a["scene"]["hash"].get<std::string>(),
                    b["scene"]["name"].get<std::string>(), b["scene"]["hash"].get<std::string>()));
  }
  if (a["settings"]["steps"] != b["settings"]["steps"]) {
    comparison.warnings.push_back(fmt::format("the step counts differ: A {}, B {}",
                                              a["settings"]["steps"].get<int>(),
                                              b["settings"]["steps"].get<int>()));
  }
  for (const json& row : a["rows"]) {
    const json* other = find_row(b, row["scheduler_canonical"], row["threads"].get<int>());
    comparison.rows.push_back(other ? compare_row(row, *other, options)
                                    : unmatched(row, CompareVerdict::only_in_a));
  }
  for (const json& row : b["rows"]) {
    if (!find_row(a, row["scheduler_canonical"], row["threads"].get<int>())) {
      comparison.rows.push_back(unmatched(row, CompareVerdict::only_in_b));
    }
  }
  return comparison;
}

std::string format_comparison_markdown(const Comparison& c) {
  std::string text = fmt::format("# clothbench compare\n\nA: {}\n   {}\nB: {}\n   {}\n\n", c.file_a,
                                 c.about_a, c.file_b, c.about_b);
  for (const std::string& w : c.warnings) text += fmt::format("warning: {}\n", w);
  if (!c.warnings.empty()) text += "\n";
  text += fmt::format(
      "- B/A: ratio of the medians of the timed repetitions; 95 % CI: percentile bootstrap of\n"
      "  that ratio ({} resamples, seed {})\n"
      "- p: two-sided Mann-Whitney U test, exact without ties up to {} repetitions in all, else\n"
      "  normal approximation with tie correction; slower / faster when p < {} (no correction\n"
      "  for the number of rows); a regression (!) is slower by more than {:.1f} %\n"
      "- Imbalance % clothbench: 100 (busiest / mean - 1), summed over loops; LB4OMP:\n"
      "  (max - mean) / max x P / (P - 1) x 100 of the per-thread work totals\n\n",
      c.options.resamples, c.options.seed, kMannWhitneyExactLimit, c.options.alpha,
      100.0 * c.options.threshold);
  text +=
      "| Scheduler | Threads | Reps A/B | A median (s) | B median (s) | B/A | 95 % CI | p | "
      "Verdict | Imbalance % clothbench A/B | Imbalance % LB4OMP A/B | Notes |\n"
      "|---|---:|---:|---:|---:|---:|---|---:|---|---:|---:|---|\n";
  for (const RowComparison& r : c.rows) {
    const std::string interval =
        r.interval ? fmt::format("[{:.3f}, {:.3f}]", r.interval->low, r.interval->high) : "-";
    const std::string p =
        r.test ? fmt::format("{:.3g} ({})", r.test->p_value,
                             r.test->method == MannWhitneyMethod::exact ? "exact" : "normal")
               : "-";
    std::string notes;
    for (const std::string& n : r.notes) notes += (notes.empty() ? "" : "; ") + n;
    text += fmt::format(
        "| {} | {} | {}/{} | {} | {} | {} | {} | {} | {}{} | {} / {} | {} / {} | {} |\n",
        r.scheduler, r.threads, r.repetitions_a, r.repetitions_b, number(r.median_a, "{:.4f}"),
        number(r.median_b, "{:.4f}"), number(r.ratio, "{:.3f}"), interval, p, to_string(r.verdict),
        r.regression ? " !" : "", number(r.imbalance_a, "{:.1f}"), number(r.imbalance_b, "{:.1f}"),
        number(r.lb4omp_a, "{:.1f}"), number(r.lb4omp_b, "{:.1f}"), notes.empty() ? "-" : notes);
  }
  auto count = [&](CompareVerdict v) {
    return std::count_if(c.rows.begin(), c.rows.end(),
                         [&](const RowComparison& r) { return r.verdict == v; });
  };
  text += fmt::format(
      "\n{} slower, {} faster, {} same, {} FAILED (not compared), {} DISTURBED (not judged), "
      "{} unmatched. ",
      count(CompareVerdict::slower), count(CompareVerdict::faster),
      count(CompareVerdict::no_difference), count(CompareVerdict::failed),
      count(CompareVerdict::disturbed),
      count(CompareVerdict::only_in_a) + count(CompareVerdict::only_in_b));
  text += c.regressions() > 0
              ? fmt::format("{} regression(s) beyond {:.1f} % (marked !): exit code 1.\n",
                            c.regressions(), 100.0 * c.options.threshold)
              : fmt::format("No regression beyond {:.1f} %.\n", 100.0 * c.options.threshold);
  return text;
}

json comparison_json(const Comparison& c) {
  json rows = json::array();
  for (const RowComparison& r : c.rows) {
    json row = {
        {"scheduler_canonical", r.scheduler},
        {"threads", r.threads},
        {"repetitions", {{"a", r.repetitions_a}, {"b", r.repetitions_b}}},
        {"median_seconds", {{"a", number_json(r.median_a)}, {"b", number_json(r.median_b)}}},
        {"ratio", number_json(r.ratio)},
        {"interval", nullptr},
        {"mann_whitney", nullptr},
        {"verdict", to_string(r.verdict)},
        {"regression", r.regression},
        {"few_repetitions", r.few_repetitions},
        {"imbalance_percent",
         {{"clothbench", {{"a", number_json(r.imbalance_a)}, {"b", number_json(r.imbalance_b)}}},
          {"lb4omp", {{"a", number_json(r.lb4omp_a)}, {"b", number_json(r.lb4omp_b)}}}}},
        {"notes", r.notes}};
    if (r.interval) row["interval"] = {{"low", r.interval->low}, {"high", r.interval->high}};
    if (r.test) {
      row["mann_whitney"] = {
          {"u_a", r.test->u_x},
          {"u_b", r.test->u_y},
          {"p_value", r.test->p_value},
          {"method", r.test->method == MannWhitneyMethod::exact ? "exact" : "normal"}};
    }
    rows.push_back(std::move(row));
  }
  return {{"schema", "clothbench.compare"},
          {"schema_version", 1},
          {"a", {{"file", c.file_a}, {"about", c.about_a}}},
          {"b", {{"file", c.file_b}, {"about", c.about_b}}},
          {"settings",
           {{"alpha", c.options.alpha},
            {"threshold", c.options.threshold},
            {"resamples", c.options.resamples},
            {"seed", c.options.seed},
            {"interval", "percentile bootstrap of median(B) / median(A), 95 %"},
            {"test",
             "two-sided Mann-Whitney U: exact without ties when n_a + n_b <= 40, else "
             "normal approximation with tie and continuity corrections"}}},
          {"warnings", c.warnings},
          {"rows", std::move(rows)},
          {"regressions", c.regressions()}};
}

}  // namespace clothbench::harness
