// The finished runs of an unfinished sweep row (sweep_document.hpp, `partial_rows`): a run
// written to the document and read back makes the same row as the run itself, so a row
// finished by a resumed session equals one measured without the interruption; the entries
// are kept per (scheduler, threads), replaced and dropped; a damaged entry is named by the
// validator. Made-up runs only: nothing is timed here.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "harness/sweep/measured_run.hpp"
#include "harness/sweep/sweep_document.hpp"

namespace {

using clothbench::harness::MeasuredRun;
using clothbench::harness::RowKey;
using nlohmann::json;
using testing::HasSubstr;

/// A run whose every field differs from its default, with values that need all 17 digits.
MeasuredRun made_up_run(double wall, bool instrumented, bool no_load_after) {
  MeasuredRun r;
  r.instrumentation = instrumented ? clothbench::kernels::Instrumentation::loops
                                   : clothbench::kernels::Instrumentation::off;
  r.accounting.wall_seconds = wall;
  r.accounting.step_seconds = wall - 1.0 / 3.0;
  r.accounting.sequential_overhead = 0.1 + 1e-17;
  r.accounting.parallel_overhead = 2.0 / 7.0;
  r.accounting.load_imbalance = 0.3;
  r.accounting.parallel_work = wall - 1.0;
  r.accounting.unaccounted = 1.0 / 3.0;
  r.accounting.imbalance_percent = 12.345678901234567;
  r.accounting.thread_work_cv = 0.0625;
  r.accounting.loops = 123456789012;
  r.accounting.chunks = 987654321098;
  r.accounting.thread_work = {wall / 3.0, wall / 7.0};
  r.cg_iterations = 4321;
  r.steps_done = 100;
  r.mass_error = 3.3e-16;
  r.finite = true;
  r.bit_identical = !no_load_after;
  r.state_digest = "0123456789abcdef";
  r.verification.fail("made-up failure, " + std::to_string(wall));
  r.disturbance.threads = 2;
  r.disturbance.usable_cores = 2;
  r.disturbance.wall_seconds = wall;
  r.disturbance.cpu_seconds = 1.97 * wall;
  r.disturbance.cpu_share = 0.985;
  r.disturbance.involuntary_switches = 77;
  r.disturbance.switch_rate = 0.1 / 3.0;
  r.disturbance.load_before = 1.25;
  r.disturbance.load_after = no_load_after ? -1.0 : 1.5;
  r.disturbance.wait_policy = "passive";
  r.disturbance.oversubscribed = false;
  r.disturbance.disturbed = no_load_after;
  if (no_load_after) r.disturbance.reasons = {"made-up reason"};
  r.attempts = no_load_after ? 3 : 1;
  r.memory.start_bytes = 123456789012 + static_cast<std::uint64_t>(wall);
  r.memory.peak_bytes = 987654321098 + static_cast<std::uint64_t>(wall);
  r.memory.scope = no_load_after ? "process" : "run";
  return r;
}

/// Reading `run` throws std::invalid_argument whose message contains `expected`.
void expect_read_error(const json& run, const std::string& expected) {
  try {
    (void)clothbench::harness::measured_run_from_json(run);
    ADD_FAILURE() << "a damaged run was read; expected: " << expected;
  } catch (const std::invalid_argument& e) {
    EXPECT_THAT(e.what(), HasSubstr(expected));
  }
}

json row_of(const std::vector<MeasuredRun>& plain, const std::vector<MeasuredRun>& timed) {
  return clothbench::harness::make_row("static", "static@blocks", "", 2, false, plain, timed,
                                       clothbench::kernels::Instrumentation::loops, 100,
                                       {{"mode", "none"}, {"bound", false}, {"threads", json::array()}});
}

/// The document text and back, as a resumed session reads it from disk.
json through_text(const json& j) { return json::parse(j.dump(2)); }

TEST(SweepPartialRows, ARunReadBackMakesTheSameRowAsTheRunItself) {
  std::vector<MeasuredRun> plain = {made_up_run(2954.123456789012, false, false),
                                    made_up_run(3190.4 / 3.0, false, true)};
  plain[0].reference = true;  // the sweep's reference run, counted in its row
  const std::vector<MeasuredRun> timed = {made_up_run(3001.0 / 7.0, true, false),
                                          made_up_run(2999.9999999999995, true, true)};
  std::vector<MeasuredRun> plain_back, timed_back;
  for (const MeasuredRun& r : plain) {
    plain_back.push_back(
        clothbench::harness::measured_run_from_json(through_text(clothbench::harness::measured_run_json(r))));
  }
  for (const MeasuredRun& r : timed) {
    timed_back.push_back(
        clothbench::harness::measured_run_from_json(through_text(clothbench::harness::measured_run_json(r))));
  }
  EXPECT_EQ(row_of(plain_back, timed_back), row_of(plain, timed));
  // Fields the row does not show come back too.
  EXPECT_EQ(plain_back[1].disturbance.load_after, -1.0);
  EXPECT_EQ(plain_back[1].attempts, 3);
  EXPECT_EQ(timed_back[0].instrumentation, clothbench::kernels::Instrumentation::loops);
  EXPECT_EQ(timed_back[0].accounting.thread_work, timed[0].accounting.thread_work);
  EXPECT_EQ(plain_back[0].steps_done, 100);
  EXPECT_EQ(plain_back[0].disturbance.threads, 2);
  EXPECT_EQ(plain_back[0].memory.start_bytes, plain[0].memory.start_bytes);
  EXPECT_EQ(plain_back[0].memory.peak_bytes, plain[0].memory.peak_bytes);
  EXPECT_EQ(plain_back[0].memory.scope, "run");
  EXPECT_EQ(plain_back[1].memory.scope, "process");
  EXPECT_TRUE(plain_back[0].reference);
  EXPECT_FALSE(plain_back[1].reference);
  EXPECT_EQ(row_of(plain, timed)["disturbance"]["records"][0]["reference"], true);
  EXPECT_EQ(row_of(plain, timed)["disturbance"]["records"][1]["reference"], false);
  // A run written before runs were marked reads as not the reference.
  json unmarked = clothbench::harness::measured_run_json(plain[0]);
  unmarked.erase("reference");
  EXPECT_FALSE(clothbench::harness::measured_run_from_json(unmarked).reference);
}

TEST(SweepPartialRows, TheRowsPeakIsItsHighestRunsAndOnlyItsOwnWhenEveryRunsIs) {
  std::vector<MeasuredRun> plain = {made_up_run(10.0, false, false),
                                    made_up_run(30.0, false, false)};
  std::vector<MeasuredRun> timed = {made_up_run(20.0, true, false)};
  json row = row_of(plain, timed);
  EXPECT_EQ(row["memory"]["peak_resident_bytes"], plain[1].memory.peak_bytes);
  EXPECT_EQ(row["memory"]["scope"], "run");
  EXPECT_EQ(row["memory"]["runs_measured"], 3);
  EXPECT_EQ(row["memory"]["runs"], 3);
  ASSERT_EQ(row["memory"]["records"].size(), 3u);
  EXPECT_EQ(row["memory"]["records"][1]["start_resident_bytes"], plain[1].memory.start_bytes);
  EXPECT_EQ(row["memory"]["records"][2]["instrumented"], true);

  // One run whose high-water mark could not be reset: the row's peak may be an earlier run's.
  timed[0].memory.scope = "process";
  EXPECT_EQ(row_of(plain, timed)["memory"]["scope"], "process");
  // A run of an older session (no memory recorded) is left out of the peak and counted.
  timed[0].memory = {};
  timed[0].memory.peak_bytes = 0;
  row = row_of(plain, timed);
  EXPECT_EQ(row["memory"]["peak_resident_bytes"], plain[1].memory.peak_bytes);
  EXPECT_EQ(row["memory"]["scope"], "run");
  EXPECT_EQ(row["memory"]["runs_measured"], 2);
  EXPECT_EQ(row["memory"]["runs"], 3);
  // No run measured: no peak.
  for (MeasuredRun& r : plain) r.memory = {};
  row = row_of(plain, {timed[0]});
  EXPECT_TRUE(row["memory"]["peak_resident_bytes"].is_null());
  EXPECT_EQ(row["memory"]["scope"], "unknown");
}

TEST(SweepPartialRows, ARunWithoutMemoryReadsAsUnknownAndABadScopeIsNamed) {
  json run = clothbench::harness::measured_run_json(made_up_run(5.0, false, false));
  json older = run;
  older.erase("memory");  // written before memory was measured
  const MeasuredRun back = clothbench::harness::measured_run_from_json(older);
  EXPECT_EQ(back.memory.scope, "unknown");
  EXPECT_EQ(back.memory.peak_bytes, 0u);
  json bad = run;
  bad["memory"]["scope"] = "machine";
  expect_read_error(bad, "run.memory.scope: \"machine\" is not run, process or unknown");
  json missing = run;
  missing["memory"].erase("peak_resident_bytes");
  expect_read_error(missing, "run.memory: missing key 'peak_resident_bytes'");
}

TEST(SweepPartialRows, EntriesAreKeptPerRowReplacedTakenAndDropped) {
  json document = {{"rows", json::array()}};
  const RowKey one{"static@blocks", 1}, two{"static@blocks", 2};
  std::vector<MeasuredRun> plain = {made_up_run(10.0, false, false)};
  std::vector<MeasuredRun> timed;
  clothbench::harness::store_partial_row(document, one, plain, timed);
  timed.push_back(made_up_run(11.0, true, false));
  clothbench::harness::store_partial_row(document, one, plain, timed);  // replaces
  clothbench::harness::store_partial_row(document, two, plain, {});
  ASSERT_EQ(document["partial_rows"].size(), 2u);
  document = through_text(document);

  std::vector<MeasuredRun> p, t;
  ASSERT_TRUE(clothbench::harness::take_partial_row(document, one, p, t));
  ASSERT_EQ(p.size(), 1u);
  ASSERT_EQ(t.size(), 1u);
  EXPECT_EQ(p[0].accounting.wall_seconds, 10.0);
  EXPECT_EQ(t[0].accounting.wall_seconds, 11.0);
  std::vector<MeasuredRun> none_p, none_t;
  EXPECT_FALSE(clothbench::harness::take_partial_row(document, {"guided:1", 1}, none_p, none_t));
  EXPECT_TRUE(none_p.empty() && none_t.empty());

  // The core round trip before the row's first run goes with its runs (rows of 2 or more
  // threads); none is written for a row without one.
  EXPECT_FALSE(document["partial_rows"][0].contains("core_round_trip_before_ns"));
  double trip = -1.0;
  ASSERT_TRUE(clothbench::harness::take_partial_row(document, one, p, t, &trip));
  EXPECT_EQ(trip, 0.0);
  clothbench::harness::store_partial_row(document, two, plain, timed, 123.456789012345678);
  document = through_text(document);
  std::vector<MeasuredRun> p2, t2;
  ASSERT_TRUE(clothbench::harness::take_partial_row(document, two, p2, t2, &trip));
  EXPECT_EQ(trip, 123.456789012345678);
  EXPECT_EQ(t2.size(), 1u);

  clothbench::harness::drop_partial_row(document, one);
  ASSERT_EQ(document["partial_rows"].size(), 1u);
  EXPECT_EQ(document["partial_rows"][0]["threads"], 2);
  clothbench::harness::drop_partial_row(document, two);
  EXPECT_FALSE(document.contains("partial_rows")) << "no empty array is left behind";
}

TEST(SweepPartialRows, AMissingOrMistypedFieldIsNamed) {
  json run = clothbench::harness::measured_run_json(made_up_run(5.0, false, false));
  json missing = run;
  missing["accounting"].erase("loops");
  expect_read_error(missing, "run.accounting: missing key 'loops'");
  json mistyped = run;
  mistyped["disturbance"]["cpu_share"] = "high";
  expect_read_error(mistyped, "run.disturbance.cpu_share: wrong type");
}

json made_up_document() {
  return {{"schema", "clothbench.sweep"},
          {"schema_version", clothbench::harness::kSweepSchemaVersion},
          {"created_utc", "2026-11-30T07:00:00Z"},
          {"updated_utc", "2026-11-30T07:00:00Z"},
          {"complete", false},
          {"command", json::array()},
          {"settings",
           {{"schedulers", {"static"}}, {"threads", {1}}, {"repeat", 1}, {"steps", 100}, {"instrument", "loops"}}},
          {"scene", {{"name", "made-up"}, {"file", "m.toml"}, {"hash", "abc"}, {"source", ""}}},
          {"machine", json::object()},
          {"openmp_environment", json::object()},
          {"reference", {{"state_digest", "00"}, {"scheduler", "static@blocks"}, {"threads", 1}}},
          {"rows", json::array()}};
}

TEST(SweepPartialRows, OnlyTheCountedReferenceRunIsMarkedAndItMustBe) {
  using clothbench::harness::validate_sweep_document;
  MeasuredRun reference_run = made_up_run(7.0, false, false);
  reference_run.reference = true;
  const MeasuredRun other = made_up_run(8.0, false, false);
  const MeasuredRun timed = made_up_run(9.0, true, false);
  auto reference_row = [&](int threads, const MeasuredRun& first) {
    json row = row_of({first, other}, {timed});
    row["threads"] = threads;
    return row;
  };

  // Counted: the reference row's first run is marked, as a finished row and as a partial one.
  json counted = made_up_document();
  counted["reference"]["counted_in_row"] = true;
  counted["rows"].push_back(reference_row(1, reference_run));
  EXPECT_TRUE(validate_sweep_document(counted).empty());
  json counted_partial = made_up_document();
  counted_partial["reference"]["counted_in_row"] = true;
  clothbench::harness::store_partial_row(counted_partial, {"static@blocks", 1}, {reference_run}, {});
  EXPECT_TRUE(validate_sweep_document(counted_partial).empty());

  // Counted but not marked.
  json unmarked = made_up_document();
  unmarked["reference"]["counted_in_row"] = true;
  unmarked["rows"].push_back(reference_row(1, other));
  auto problems = validate_sweep_document(unmarked);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_THAT(problems[0], HasSubstr("rows[0].disturbance.records[0].reference: reference.counted_in_row "
                                     "is true but the row's first run is not marked"));

  // Marked but not counted; marked in another row; an instrumented run marked.
  json not_counted = made_up_document();
  not_counted["reference"]["counted_in_row"] = false;
  not_counted["rows"].push_back(reference_row(1, reference_run));
  problems = validate_sweep_document(not_counted);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_THAT(problems[0], HasSubstr("rows[0].disturbance.records[0].reference: marks a run that is "
                                     "not the counted reference run (reference.counted_in_row is false)"));
  json elsewhere = counted;
  elsewhere["rows"].push_back(reference_row(2, reference_run));
  problems = validate_sweep_document(elsewhere);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_THAT(problems[0], HasSubstr("rows[1].disturbance.records[0].reference: marks a run"));
  json marked_timed = made_up_document();
  marked_timed["reference"]["counted_in_row"] = true;
  MeasuredRun timed_marked = timed;
  timed_marked.reference = true;
  clothbench::harness::store_partial_row(marked_timed, {"static@blocks", 1}, {reference_run},
                                         {timed_marked});
  problems = validate_sweep_document(marked_timed);
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_THAT(problems[0], HasSubstr("partial_rows[0].timed[0].reference: marks a run"));

  // A row written before runs were marked (no field) is not checked: a sweep begun by an
  // older build and finished by this one.
  json older = made_up_document();
  older["reference"]["counted_in_row"] = true;
  older["rows"].push_back(reference_row(1, other));
  for (json& record : older["rows"][0]["disturbance"]["records"]) record.erase("reference");
  EXPECT_TRUE(validate_sweep_document(older).empty());
}

TEST(SweepPartialRows, ValidatorNamesADamagedEntry) {
  json document = made_up_document();
  clothbench::harness::store_partial_row(document, {"static@blocks", 1},
                                         {made_up_run(7.0, false, false)}, {});
  EXPECT_TRUE(clothbench::harness::validate_sweep_document(document).empty());
  document["partial_rows"][0]["plain"][0].erase("state_digest");
  document["partial_rows"][0]["timed"] = 3;
  document["partial_rows"][0]["core_round_trip_before_ns"] = "fast";
  const auto problems = clothbench::harness::validate_sweep_document(document);
  ASSERT_EQ(problems.size(), 3u);
  EXPECT_THAT(problems[0], HasSubstr("partial_rows[0].core_round_trip_before_ns: expected number"));
  EXPECT_THAT(problems[1], HasSubstr("partial_rows[0].plain[0]: run: missing key 'state_digest'"));
  EXPECT_THAT(problems[2], HasSubstr("partial_rows[0].timed: expected array"));

  // A row's memory block: checked when present (older rows have none).
  document.erase("partial_rows");
  document["rows"].push_back(
      row_of({made_up_run(7.0, false, false)}, {made_up_run(8.0, true, false)}));
  document["rows"].push_back(document["rows"][0]);
  document["rows"][1].erase("memory");
  document["rows"][1]["threads"] = 1;
  EXPECT_TRUE(clothbench::harness::validate_sweep_document(document).empty());
  document["rows"][0]["memory"]["peak_resident_bytes"] = "lots";
  document["rows"][0]["memory"].erase("runs_measured");
  const auto memory_problems = clothbench::harness::validate_sweep_document(document);
  ASSERT_EQ(memory_problems.size(), 2u);
  EXPECT_THAT(memory_problems[0], HasSubstr("rows[0].memory.peak_resident_bytes"));
  EXPECT_THAT(memory_problems[1], HasSubstr("rows[0].memory: missing key 'runs_measured'"));
}

}  // namespace
