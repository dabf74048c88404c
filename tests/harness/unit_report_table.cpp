// Golden tests of the Table 2 writers (Markdown, CSV), the derived speed-ups, the sweep
// document validator, and the sweep's list parsing and progress bar text.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

#include "harness/report/sweep_table.hpp"
#include "harness/sweep/progress_bar.hpp"
#include "harness/sweep/sweep_document.hpp"
#include "harness/sweep/sweep_options.hpp"

namespace {

using clothbench::harness::add_derived;
using nlohmann::json;

/// A row with fixed numbers; accounting adds up to 10 s of work + overheads.
json row(const std::string& scheduler, int threads, double time, bool passed = true) {
  return {{"scheduler", scheduler},
          {"scheduler_canonical", scheduler + "@blocks"},
          {"note", ""},
          {"threads", threads},
          {"oversubscribed", threads > 2},
          {"time_seconds", {{"median", time}, {"min", time * 0.99}, {"max", time * 1.02}, {"samples", {time}}}},
          {"instrumented", {{"level", "loops"}, {"time_seconds", nullptr}, {"cost_seconds", 0.01}, {"cost_percent", 0.1}}},
          {"accounting",
           {{"from_run", 0}, {"wall_seconds", time}, {"step_seconds", time},
            {"sequential_overhead_seconds", 0.5}, {"parallel_overhead_seconds", 0.025},
            {"load_imbalance_seconds", 0.125}, {"parallel_work_seconds", time - 0.65},
            {"unaccounted_seconds", 0.0}, {"imbalance_percent", 2.5}, {"thread_work_cv", 0.01},
            {"loops", 10}, {"chunks", 20}, {"thread_work_seconds", {1.0}}}},
          {"verification", {{"passed", passed}, {"failures", passed ? json::array() : json{"bad"}},
                            {"runs", 2}, {"bit_identical", passed}, {"state_digest", "00"},
                            {"max_mass_error", 0.0}}},
          {"cg_iterations", 7},
          {"steps", 3},
          {"binding", {{"mode", "none"}, {"bound", false}, {"threads", json::array()}}},
          {"derived", {{"speedup", nullptr}, {"efficiency", nullptr},
                       {"speedup_vs_best_1thread", nullptr}, {"efficiency_vs_best_1thread", nullptr}}}};
}

json document() {
  return {{"schema", "clothbench.sweep"},
          {"schema_version", 1},
          {"created_utc", "2024-01-01T00:00:00Z"},
          {"updated_utc", "2024-01-01T00:00:00Z"},
          {"complete", true},
          {"command", {"clothbench", "sweep"}},
          {"settings", {{"schedulers", {"static", "dynamic:2"}}, {"threads", {1, 2, 4}}, {"repeat", 3},
                        {"warmup_steps", 2}, {"steps", 3}, {"instrument", "loops"}, {"bind", "none"},
                        {"oversubscribe", true}}},
          {"scene", {{"name", "golden"}, {"file", "g.toml"}, {"hash", "abc"}, {"source", ""}}},
          {"machine", json::object()},
          {"openmp_environment", json::object()},
          {"reference", {{"scheduler", "static@blocks"}, {"threads", 1}, {"state_digest", "00"}}},
          // Out of order on purpose: tables group per scheduler and sort by threads.
          {"rows", {row("dynamic:2", 2, 5.0), row("static", 1, 10.0), row("static", 2, 6.0),
                    row("dynamic:2", 1, 8.0), row("dynamic:2", 4, 4.0, false)}}};
}

TEST(ReportTable, DerivedSpeedupsAgainstOwnAndBestOneThreadRun) {
  json d = document();
  add_derived(d);
  const json& dyn2 = d["rows"][0]["derived"];
  EXPECT_DOUBLE_EQ(dyn2["speedup"].get<double>(), 8.0 / 5.0);
  EXPECT_DOUBLE_EQ(dyn2["efficiency"].get<double>(), 8.0 / 5.0 / 2);
  EXPECT_DOUBLE_EQ(dyn2["speedup_vs_best_1thread"].get<double>(), 8.0 / 5.0);
  EXPECT_DOUBLE_EQ(d["rows"][2]["derived"]["speedup"].get<double>(), 10.0 / 6.0);
  EXPECT_DOUBLE_EQ(d["rows"][2]["derived"]["speedup_vs_best_1thread"].get<double>(), 8.0 / 6.0);
  // A failed run never appears as a speed-up.
  EXPECT_TRUE(d["rows"][4]["derived"]["speedup"].is_null());
  EXPECT_TRUE(d["rows"][4]["derived"]["speedup_vs_best_1thread"].is_null());
}

TEST(ReportTable, FailedBaselineGivesNoSpeedup) {
  json d = document();
  d["rows"][1]["verification"]["passed"] = false;  // static, 1 thread
  add_derived(d);
  EXPECT_TRUE(d["rows"][2]["derived"]["speedup"].is_null());
  EXPECT_DOUBLE_EQ(d["rows"][2]["derived"]["speedup_vs_best_1thread"].get<double>(), 8.0 / 6.0);
}

TEST(ReportTable, MarkdownGolden) {
  json d = document();
  add_derived(d);
  const std::string md = clothbench::harness::format_markdown(d);
  const std::string expected_static =
      "## static@blocks\n\n"
      "| Threads | Seq. overhead [s] | Para. overhead [s] | Imbalance [s] | Imbalance [%] | Time [s] "
      "| Min-max [s] | Speed-up | Efficiency | Speed-up vs best 1-thread | Verification | Timing |\n"
      "|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|:--|:--|\n"
      // Rows of a document written before disturbance was measured: timing "-".
      "| 1 | 0.5 | 0.025 | 0.125 | 2.5 | 10.000 | 9.900-10.200 | 1.00 | 1.00 | 0.80 | PASSED | - |\n"
      "| 2 | 0.5 | 0.025 | 0.125 | 2.5 | 6.000 | 5.940-6.120 | 1.67 | 0.83 | 1.33 | PASSED | - |\n";
  EXPECT_NE(md.find(expected_static), std::string::npos) << md;
  EXPECT_NE(md.find("| 4 (oversubscribed) | 0.5 | 0.025 | 0.125 | 2.5 | 4.000 | 3.960-4.080 | - | - "
                    "| - | FAILED (1 check) | - |"),
            std::string::npos)
      << md;
  // Scheduler order follows settings.schedulers, not row order.
  EXPECT_LT(md.find("## static@blocks"), md.find("## dynamic:2@blocks"));
  EXPECT_NE(md.find("# clothbench sweep: golden"), std::string::npos);
}

TEST(ReportTable, CsvGolden) {
  json d = document();
  add_derived(d);
  const std::string csv = clothbench::harness::format_csv(d);
  EXPECT_EQ(
      csv.substr(0, csv.find('\n')),
      "scheduler,scheduler_canonical,threads,oversubscribed,time_median_s,time_min_s,"
      "time_max_s,sequential_overhead_s,parallel_overhead_s,load_imbalance_s,"
      "parallel_work_s,unaccounted_s,imbalance_percent,thread_work_cv,instrumentation,"
      "instrumentation_cost_s,instrumentation_cost_ratio,overheads_from_run,instrumented_runs,"
      "instrumented_run_wall_s,overheads_exceed_time,"
      "overheads_note,speedup,efficiency,speedup_vs_best_1thread,"
      "efficiency_vs_best_1thread,verification,timing");
  EXPECT_NE(csv.find("\nstatic,static@blocks,1,false,10,9.9,10.2,0.5,0.025,0.125,9.35,0,2.5,0.01,"
                     "loops,0.01,,0,,10,false,,1,1,0.8,0.8,PASSED,-\n"),
            std::string::npos)
      << csv;
  EXPECT_NE(csv.find("\ndynamic:2,dynamic:2@blocks,4,true,4,3.96,4.08,0.5,0.025,0.125,3.35,0,2.5,"
                     "0.01,loops,0.01,,0,,4,false,,,,,,FAILED,-\n"),
            std::string::npos)
      << csv;
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 6);
}

TEST(ReportTable, ValidatorNamesMissingAndMistypedKeys) {
  EXPECT_TRUE(clothbench::harness::validate_sweep_document(document()).empty());
  json d = document();
  d["rows"][0].erase("threads");
  d["rows"][1]["verification"]["passed"] = "yes";
  d["schema_version"] = 99;
  const auto problems = clothbench::harness::validate_sweep_document(d);
  const std::string all = [&] {
    std::string s;
    for (const auto& p : problems) s += p + "\n";
    return s;
  }();
  EXPECT_NE(all.find("rows[0]: missing key 'threads'"), std::string::npos) << all;
  EXPECT_NE(all.find("rows[1].verification.passed: expected bool"), std::string::npos) << all;
  EXPECT_NE(all.find("schema_version"), std::string::npos) << all;
}

TEST(ReportTable, ValidatorChecksTheSessionsOfAResumedSweep) {
  json d = document();
  d["sessions"] = json::array({{{"started_utc", "2026-11-30T00:00:00Z"},
                                {"load_average", {0.1, 0.2, 0.3}},
                                {"rows_at_start", 0},
                                {"reference", "run"}},
                               {{"started_utc", "2026-11-30T01:00:00Z"},
                                {"load_average", {0.1, 0.2, 0.3}},
                                {"rows_at_start", 2},
                                {"reference", "stored"}},
                               {{"started_utc", "2026-11-30T02:00:00Z"},
                                {"load_average", {0.1, 0.2, 0.3}},
                                {"rows_at_start", 3},
                                {"reference", "digest"}}});
  d["reference"]["wall_seconds"] = 12.5;
  d["reference"]["disturbed"] = false;
  d["reference"]["counted_in_row"] = true;
  EXPECT_TRUE(clothbench::harness::validate_sweep_document(d).empty());
  d["sessions"][1]["reference"] = "guessed";
  d["reference"]["counted_in_row"] = "yes";
  d["sessions"][0].erase("rows_at_start");
  const auto problems = clothbench::harness::validate_sweep_document(d);
  std::string all;
  for (const auto& p : problems) all += p + "\n";
  EXPECT_NE(all.find("sessions[1].reference: expected \"run\", \"stored\" or \"digest\""),
            std::string::npos)
      << all;
  EXPECT_NE(all.find("reference.counted_in_row: expected bool"), std::string::npos) << all;
  EXPECT_NE(all.find("sessions[0]: missing key 'rows_at_start'"), std::string::npos) << all;
  d["sessions"] = "yesterday";
  EXPECT_FALSE(clothbench::harness::validate_sweep_document(d).empty());
}

TEST(SweepOptions, ThreadListsAndErrors) {
  using clothbench::harness::parse_thread_list;
  EXPECT_EQ(parse_thread_list("1,2,4", "--threads"), (std::vector<int>{1, 2, 4}));
  EXPECT_EQ(parse_thread_list("1-3,8,2", "--threads"), (std::vector<int>{1, 2, 3, 8}));
  for (const char* bad : {"0", "1,,2", "x", "4-2", "-1", "2.5", ""}) {
    EXPECT_THROW(parse_thread_list(bad, "--threads"), std::invalid_argument) << bad;
  }
  try {
    parse_thread_list("1,0", "--threads");
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--threads: '0'"), std::string::npos) << e.what();
  }
  EXPECT_EQ(clothbench::harness::default_thread_counts(2), (std::vector<int>{1, 2}));
  EXPECT_EQ(clothbench::harness::default_thread_counts(6), (std::vector<int>{1, 2, 4, 6}));
  EXPECT_EQ(clothbench::harness::default_thread_counts(8), (std::vector<int>{1, 2, 4, 8}));
  EXPECT_EQ(clothbench::harness::default_thread_counts(1), (std::vector<int>{1}));
}

TEST(SweepOptions, TheReferenceRunCountsInItsRowOnlyWhenMeasuredAsTheRowsRunsAre) {
  using clothbench::harness::BindMode;
  using clothbench::harness::ReferenceRunFacts;
  using clothbench::harness::reference_counts_in_row;
  clothbench::harness::SweepOptions options;
  options.warmup_steps = 0;
  options.count_reference_after_seconds = 60.0;
  const std::vector<int> threads = {2, 1};
  const ReferenceRunFacts counted{false, false, 60.0};  // exactly the threshold counts
  EXPECT_TRUE(reference_counts_in_row(options, threads, counted));
  EXPECT_TRUE(reference_counts_in_row(options, threads, {false, false, 3600.0}));

  // Each condition alone keeps it out of the row.
  EXPECT_FALSE(reference_counts_in_row(options, threads, {true, false, 3600.0}));  // resuming
  EXPECT_FALSE(reference_counts_in_row(options, threads, {false, true, 3600.0}));  // disturbed
  EXPECT_FALSE(reference_counts_in_row(options, threads, {false, false, 59.9}));   // too short
  EXPECT_FALSE(reference_counts_in_row(options, {2, 4}, counted));  // no 1-thread row
  clothbench::harness::SweepOptions warm = options;
  warm.warmup_steps = 1;  // the rows' runs follow a warm-up the reference did not have
  EXPECT_FALSE(reference_counts_in_row(warm, threads, counted));
  clothbench::harness::SweepOptions bound = options;
  bound.bind = BindMode::core;  // the rows' threads are pinned, the reference's were not
  EXPECT_FALSE(reference_counts_in_row(bound, threads, counted));
  clothbench::harness::SweepOptions never = options;
  never.count_reference_after_seconds = 1e9;
  EXPECT_FALSE(reference_counts_in_row(never, threads, {false, false, 3600.0}));
  // The defaults (a 2-step warm-up per row) never count it.
  EXPECT_FALSE(
      reference_counts_in_row(clothbench::harness::SweepOptions{}, threads, {false, false, 1e6}));
}

TEST(SweepStatistics, MedianIsTheLowerMiddleSample) {
  using clothbench::harness::median_index;
  EXPECT_EQ(median_index({3.0, 1.0, 2.0}), 2u);
  EXPECT_EQ(median_index({4.0, 1.0, 3.0, 2.0}), 3u);  // lower middle: 2.0
  const json s = clothbench::harness::sample_statistics({3.0, 1.0, 2.0});
  EXPECT_EQ(s["median"], 2.0);
  EXPECT_EQ(s["min"], 1.0);
  EXPECT_EQ(s["max"], 3.0);
}

TEST(ProgressBar, RendersFractionAndEta) {
  using clothbench::harness::ProgressBar;
  EXPECT_EQ(ProgressBar::render(0.5, 30.0, "static x 2 threads", 10),
            "[#####.....]  50%  ETA    30s  static x 2 threads");
  EXPECT_EQ(ProgressBar::render(0.0, 1.0, "", 4), "[....]   0%  ETA      ?  ");
  EXPECT_EQ(clothbench::harness::format_duration(3725), "1h02m");
  EXPECT_EQ(clothbench::harness::format_duration(65), "1m05s");
}

}  // namespace
