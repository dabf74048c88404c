// The accounting identity of a sweep row and its labelling (issue 18, step 3): a row's
// overheads come from one instrumented run, which every report shows with its own wall time
// (wall = seq. overhead + parallel work + para. overhead + imbalance + residual), and a row
// whose overheads add up to more than its Time (the uninstrumented median) is marked with the
// reason in table.md, table.csv, the per-row line and sweep.json. Made-up rows only: no timing
// is measured here.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "harness/report/sweep_table.hpp"
#include "harness/sweep/measured_run.hpp"
#include "harness/sweep/sweep_document.hpp"

namespace {

using clothbench::harness::accounting_identity;
using clothbench::harness::AccountingIdentity;
using nlohmann::json;
using testing::HasSubstr;
using testing::Not;

/// A 2-thread row whose Time is 20.6 s (uninstrumented runs 20.4, 20.6, 20.9 s) and whose
/// overheads come from instrumented run 2 of 3 (24, 25, 26 s), which took `run_wall` s:
/// seq 0.5 + work 3.4 + para `para` + imbalance 4.0 + residual 0.1 = run_wall.
json made_up_row(double para, bool older_document = false) {
  const double run_wall = 0.5 + 3.4 + para + 4.0 + 0.1;
  json accounting = {{"from_run", 1},
                     {"wall_seconds", run_wall},
                     {"step_seconds", run_wall - 0.1},
                     {"sequential_overhead_seconds", 0.5},
                     {"parallel_overhead_seconds", para},
                     {"load_imbalance_seconds", 4.0},
                     {"parallel_work_seconds", 3.4},
                     {"unaccounted_seconds", 0.1},
                     {"imbalance_percent", 117.6},
                     {"thread_work_cv", 0.5},
                     {"loops", 10},
                     {"chunks", 20},
                     {"thread_work_seconds", {1.7, 5.1}}};
  json instrumented = {{"level", "loops"},
                       {"time_seconds",
                        {{"median", run_wall},
                         {"min", run_wall - 1.0},
                         {"max", run_wall + 1.0},
                         {"samples", {run_wall - 1.0, run_wall, run_wall + 1.0}}}},
                       {"cost_seconds", run_wall - 20.6},
                       {"cost_percent", 100.0 * (run_wall - 20.6) / 20.6}};
  if (!older_document) {
    accounting["source"] = "median instrumented run";
    accounting["runs"] = 3;
    instrumented["cost_ratio"] = run_wall / 20.6;
  }
  json row = {{"scheduler", "static"},
              {"scheduler_canonical", "static@blocks"},
              {"note", ""},
              {"threads", 2},
              {"oversubscribed", false},
              {"time_seconds",
               {{"median", 20.6}, {"min", 20.4}, {"max", 20.9}, {"samples", {20.4, 20.6, 20.9}}}},
              {"instrumented", instrumented},
              {"accounting", accounting},
              {"verification",
               {{"passed", true},
                {"failures", json::array()},
                {"runs", 6},
                {"bit_identical", true},
                {"state_digest", "00"},
                {"max_mass_error", 0.0}}},
              {"cg_iterations", 7},
              {"steps", 3},
              {"binding", {{"mode", "none"}, {"bound", false}, {"threads", json::array()}}},
              {"derived",
               {{"speedup", nullptr},
                {"efficiency", nullptr},
                {"speedup_vs_best_1thread", nullptr},
                {"efficiency_vs_best_1thread", nullptr}}}};
  if (!older_document) {
    row["accounting"]["identity"] = clothbench::harness::identity_json(*accounting_identity(row));
  }
  return row;
}

json document_of(const std::vector<json>& rows) {
  return {{"schema", "clothbench.sweep"},
          {"schema_version", 1},
          {"created_utc", "2024-01-01T00:00:00Z"},
          {"updated_utc", "2024-01-01T00:00:00Z"},
          {"complete", true},
          {"command", {"clothbench", "sweep"}},
          {"settings",
           {{"schedulers", {"static"}},
            {"threads", {2}},
            {"repeat", 3},
            {"warmup_steps", 2},
            {"steps", 3},
            {"instrument", "loops"},
            {"bind", "none"},
            {"oversubscribe", false}}},
          {"scene", {{"name", "made-up"}, {"file", "m.toml"}, {"hash", "abc"}, {"source", ""}}},
          {"machine", json::object()},
          {"openmp_environment", json::object()},
          {"reference", {{"scheduler", "static@blocks"}, {"threads", 1}, {"state_digest", "00"}}},
          {"rows", rows}};
}

// The case: para. overhead 17 s, overheads 21.5 s against a Time of 20.6 s, from an
// instrumented run of 25 s.
constexpr double kLongPara = 17.0;

TEST(SweepAccounting, IdentityOfALongerInstrumentedRunIsFlaggedWithItsReason) {
  const std::optional<AccountingIdentity> id = accounting_identity(made_up_row(kLongPara));
  ASSERT_TRUE(id.has_value());
  EXPECT_DOUBLE_EQ(id->wall_seconds, 25.0);
  EXPECT_NEAR(id->parts_seconds + id->residual_seconds, id->wall_seconds, 1e-12);
  EXPECT_NEAR(id->residual_seconds, 0.1, 1e-12);
  EXPECT_NEAR(id->overheads_seconds, 21.5, 1e-12);
  EXPECT_DOUBLE_EQ(id->time_median_seconds, 20.6);
  EXPECT_DOUBLE_EQ(id->wall_over_time, 25.0 / 20.6);
  EXPECT_TRUE(id->overheads_exceed_time);
  EXPECT_EQ(id->from_run, 1u);
  EXPECT_EQ(id->runs, 3u);
  EXPECT_THAT(id->note, HasSubstr("the overheads (21.5 s) exceed the row's Time (20.6 s"));
  EXPECT_THAT(id->note, HasSubstr("instrumented run 2 of 3, which took 25 s, 1.21x that median"));
}

TEST(SweepAccounting, MarkdownShowsTheRunWallTheIdentityAndTheDaggerWithItsFootnote) {
  json d = document_of({made_up_row(kLongPara)});
  clothbench::harness::add_derived(d);
  const std::string md = clothbench::harness::format_markdown(d);
  EXPECT_THAT(md, HasSubstr("| Threads | Overheads from | Run wall [s] | Seq. overhead [s] "
                            "| Parallel work [s] | Para. overhead [s] | Imbalance [s] "
                            "| Residual [s] | Run wall / Time |\n"));
  EXPECT_THAT(md, HasSubstr("| 2 | instr. run 2 of 3 (median) | 25.000 | 0.500 | 3.400 | 17.000 "
                            "| 4.000 | 0.100 | 1.21x \u2020 |\n"));
  EXPECT_THAT(md, HasSubstr("\n\u2020 2 threads: the overheads (21.5 s) exceed the row's Time "
                            "(20.6 s, median of the uninstrumented runs): they come from "
                            "instrumented run 2 of 3, which took 25 s, 1.21x that median"));
  // The Table 2 row: its overheads beside its Time, which carries the dagger.
  EXPECT_THAT(md,
              HasSubstr("| 2 | 0.5 | 17.000 | 4.000 | 117.6 | 20.600 \u2020 | 20.400-20.900 |"));
}

TEST(SweepAccounting, CsvAndRowLineCarryTheSameLabel) {
  json d = document_of({made_up_row(kLongPara)});
  clothbench::harness::add_derived(d);
  const std::string csv = clothbench::harness::format_csv(d);
  EXPECT_THAT(csv, HasSubstr(",instrumentation_cost_ratio,overheads_from_run,instrumented_runs,"
                             "instrumented_run_wall_s,"
                             "overheads_exceed_time,overheads_note,"));
  EXPECT_THAT(csv, HasSubstr(",loops,4.4,1.21359223,1,3,25,true,\"the overheads "
                             "(21.5 s) exceed the row's Time (20.6 s, median of the uninstrumented "
                             "runs): they come from instrumented run 2 of 3, which took 25 s"));
  const std::string line = clothbench::harness::format_row_line(d["rows"][0]);
  EXPECT_THAT(line, HasSubstr("overheads from instr. run 2 of 3 (median): wall 25.0000 = seq "
                              "0.5000 + work 3.4000 + para 17.0000 + imb 4.0000 + resid 0.1000 s "
                              "(1.21x time)  OVERHEADS > TIME"));
}

TEST(SweepAccounting, ALongerRunWhoseOverheadsStayUnderTheTimeShowsItsRatioButNoDagger) {
  // Para. overhead 12.8 s: the run took 20.8 s, longer than the 20.6 s median, but its
  // overheads (17.3 s) stay under the Time.
  json d = document_of({made_up_row(12.8)});
  const std::optional<AccountingIdentity> id = accounting_identity(d["rows"][0]);
  ASSERT_TRUE(id.has_value());
  EXPECT_GT(id->wall_seconds, id->time_median_seconds);
  EXPECT_FALSE(id->overheads_exceed_time);
  EXPECT_TRUE(id->note.empty());
  clothbench::harness::add_derived(d);
  const std::string md = clothbench::harness::format_markdown(d);
  EXPECT_THAT(md, HasSubstr("| 2 | instr. run 2 of 3 (median) | 20.800 | 0.500 | 3.400 | 12.800 "
                            "| 4.000 | 0.100 | 1.01x |\n"));
  EXPECT_THAT(md, Not(HasSubstr("\n\u2020 ")));
  EXPECT_THAT(md, HasSubstr("| 2 | 0.5 | 12.800 | 4.000 | 117.6 | 20.600 | 20.400-20.900 |"));
  EXPECT_THAT(clothbench::harness::format_csv(d), HasSubstr(",false,,,,,,PASSED,-\n"));
  EXPECT_THAT(clothbench::harness::format_row_line(d["rows"][0]),
              Not(HasSubstr("OVERHEADS > TIME")));
}

TEST(SweepAccounting, OlderDocumentsWithoutTheIdentityBlockGetTheSameTable) {
  json older = document_of({made_up_row(kLongPara, true)});
  json newer = document_of({made_up_row(kLongPara)});
  EXPECT_TRUE(clothbench::harness::validate_sweep_document(older).empty());
  EXPECT_TRUE(clothbench::harness::validate_sweep_document(newer).empty());
  clothbench::harness::add_derived(older);
  clothbench::harness::add_derived(newer);
  EXPECT_EQ(clothbench::harness::format_markdown(older),
            clothbench::harness::format_markdown(newer));
  EXPECT_EQ(clothbench::harness::format_csv(older), clothbench::harness::format_csv(newer));
}

TEST(SweepAccounting, ValidatorChecksTheIdentityBlockWhenPresent) {
  json d = document_of({made_up_row(kLongPara)});
  d["rows"][0]["accounting"]["identity"]["overheads_exceed_time"] = "yes";
  const auto problems = clothbench::harness::validate_sweep_document(d);
  ASSERT_FALSE(problems.empty());
  EXPECT_THAT(problems.front(), HasSubstr("rows[0].accounting.identity.overheads_exceed_time"));
}

/// A measured run of `wall` s whose parts are seq 0.5, work 3.4, para `para`, imbalance 4.0.
clothbench::harness::MeasuredRun run_of(double wall, double para = 0.0) {
  clothbench::harness::MeasuredRun r;
  r.accounting.wall_seconds = wall;
  r.accounting.step_seconds = para > 0.0 ? wall - 0.1 : wall;
  r.accounting.sequential_overhead = para > 0.0 ? 0.5 : 0.0;
  r.accounting.parallel_work = para > 0.0 ? 3.4 : wall;
  r.accounting.parallel_overhead = para;
  r.accounting.load_imbalance = para > 0.0 ? 4.0 : 0.0;
  r.accounting.unaccounted = para > 0.0 ? 0.1 : 0.0;
  r.state_digest = "00";
  return r;
}

TEST(SweepAccounting, MakeRowTakesTheMedianInstrumentedRunAndRecordsItsIdentity) {
  using clothbench::harness::MeasuredRun;
  const std::vector<MeasuredRun> plain = {run_of(20.9), run_of(20.4), run_of(20.6)};
  // Instrumented runs of 26, 24 and 25 s: the median is the third (index 2).
  const std::vector<MeasuredRun> timed = {run_of(26.0, 18.0), run_of(24.0, 16.0),
                                          run_of(25.0, kLongPara)};
  const json row = clothbench::harness::make_row(
      "static", "static@blocks", "", 2, false, plain, timed,
      clothbench::kernels::Instrumentation::loops, 3,
      {{"mode", "none"}, {"bound", false}, {"threads", json::array()}});
  const json& a = row["accounting"];
  EXPECT_EQ(a["from_run"], 2);
  EXPECT_EQ(a["runs"], 3);
  EXPECT_EQ(a["source"], "median instrumented run");
  EXPECT_DOUBLE_EQ(a["wall_seconds"].get<double>(), 25.0);
  EXPECT_DOUBLE_EQ(row["instrumented"]["cost_ratio"].get<double>(), 25.0 / 20.6);
  const json& id = a["identity"];
  EXPECT_TRUE(id["overheads_exceed_time"].get<bool>());
  EXPECT_NEAR(id["residual_seconds"].get<double>(), 0.1, 1e-12);
  EXPECT_THAT(id["note"].get<std::string>(), HasSubstr("instrumented run 3 of 3, which took 25 s"));
  EXPECT_TRUE(clothbench::harness::validate_sweep_document(document_of({row})).empty());
}

}  // namespace
