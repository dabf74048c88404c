// The real `clothbench` binary run as a child process on a tiny scene: the sweep document's
// schema, the table command, the accounting identity on real runs, resume after the process
// is killed mid-sweep, oversubscribed rows labelled in every output, the size classes and the
// CLI's bad-input errors (exit code 2, clear messages). Stopping a sweep (Ctrl-C, SIGTERM, a
// stop inside a row): integration_sweep_stop.cpp.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <string>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include "harness/sweep/sweep_document.hpp"
#include "tests/harness/clothbench_process.hpp"
#include "tests/harness/sanitizer_build.hpp"
#include "tests/harness/sweep_binary.hpp"

namespace {

using namespace clothbench_test;  // the child-process helpers and the sweep fixture
using nlohmann::json;

TEST_F(SweepBinary, DocumentSchemaTableAndAccountingIdentity) {
  const fs::path out = fresh_dir("schema");
  const Outcome o = run("sweep " + quote(kScene.string()) +
                        " --schedulers static,dynamic:1,guided:1,active-lists --threads 1,2 "
                        "--repeat 2 --retries 0 --no-plots --quiet --out " + quote(out.string()));
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const json d = read_json(out / "sweep.json");
  const auto problems = clothbench::harness::validate_sweep_document(d);
  EXPECT_TRUE(problems.empty()) << problems.front();
  EXPECT_TRUE(d["complete"].get<bool>());
  EXPECT_EQ(d["rows"].size(), 8u);
  EXPECT_TRUE(std::regex_match(d["created_utc"].get<std::string>(),
                               std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ)")));
  EXPECT_TRUE(std::regex_match(d["scene"]["hash"].get<std::string>(), std::regex("[0-9a-f]{16}")));
  EXPECT_TRUE(d["openmp_environment"].contains("OMP_NUM_THREADS"));
  EXPECT_TRUE(d["machine"].contains("cpu"));

  for (const json& row : d["rows"]) {
    const std::string where = row["scheduler_canonical"].get<std::string>() + " x " +
                              std::to_string(row["threads"].get<int>());
    EXPECT_TRUE(row["verification"]["passed"].get<bool>()) << where;
    EXPECT_TRUE(row["verification"]["bit_identical"].get<bool>()) << where;
    EXPECT_EQ(row["verification"]["state_digest"], d["reference"]["state_digest"]) << where;
    EXPECT_EQ(row["binding"]["threads"].size(), row["threads"].get<std::size_t>()) << where;
    // Each run's peak resident memory is its own (the high-water mark reset at its start,
    // Linux 4.0+), and the row's is the highest of them: at least a simulation's worth.
    EXPECT_EQ(row["memory"]["scope"], "run") << where;
    EXPECT_EQ(row["memory"]["runs_measured"], row["verification"]["runs"]) << where;
    EXPECT_EQ(row["memory"]["runs"], row["verification"]["runs"]) << where;
    EXPECT_GT(row["memory"]["peak_resident_bytes"].get<double>(), 1 << 20) << where;
    // Rows of 2 threads record where the host had put the cores, before and after the row
    // (harness/run/core_round_trip.hpp: 0 only on a machine of 1 hardware thread).
    if (row["threads"] == 1) {
      EXPECT_FALSE(row.contains("core_round_trip_ns")) << where;
    } else {
      ASSERT_TRUE(row["core_round_trip_ns"].is_object()) << where;
      for (const char* when : {"before", "after"}) {
        const double ns = row["core_round_trip_ns"][when].get<double>();
        EXPECT_TRUE(std::isfinite(ns) && ns >= 0.0) << where << " " << when;
        if (clothbench_test::hardware_threads() >= 2) {
          EXPECT_GT(ns, 0.0) << where << " " << when;
        }
      }
    }
    // Accounting identity: the four components add up to the steps' time (an identity of the
    // recorded clocks, to rounding), and the steps' time plus what lies outside the steps is
    // the wall time. No speed is asserted.
    const json& a = row["accounting"];
    ASSERT_TRUE(a.is_object()) << where;
    const double wall = a["wall_seconds"];
    const double step = a["step_seconds"];
    const double parts = a["sequential_overhead_seconds"].get<double>() +
                         a["parallel_overhead_seconds"].get<double>() +
                         a["load_imbalance_seconds"].get<double>() +
                         a["parallel_work_seconds"].get<double>();
    EXPECT_NEAR(parts, step, 1e-12 + 1e-12 * wall) << where;
    EXPECT_NEAR(step + a["unaccounted_seconds"].get<double>(), wall, 1e-12 + 1e-12 * wall) << where;
    EXPECT_GE(a["unaccounted_seconds"].get<double>(), 0.0) << where;
    // Thread 0 times a loop from its own entry; a thread that enters before it (thread 0 still
    // finishing the previous loop's bookkeeping) counts that lead as work, so the busiest
    // thread can exceed the loop's wall by it: about a microsecond a loop, ten under a
    // sanitizer on a loaded machine. Newton's V-cycle runs thousands of short loops a run.
    const double per_loop = clothbench_test::kSanitized ? 10e-6 : 1e-6;
    const double tolerance = 0.02 * wall + 50e-6 * row["steps"].get<double>() +
                             per_loop * a["loops"].get<double>();
    // Every component is a time: non-negative up to the same tolerance.
    for (const char* k : {"sequential_overhead_seconds", "parallel_overhead_seconds",
                          "load_imbalance_seconds", "parallel_work_seconds"}) {
      EXPECT_GE(a[k].get<double>(), -tolerance) << where << " " << k;
    }
    // Mean thread work computed per loop equals the per-thread totals' mean.
    double total = 0.0;
    for (const json& w : a["thread_work_seconds"]) total += w.get<double>();
    EXPECT_NEAR(total / row["threads"].get<double>(), a["parallel_work_seconds"].get<double>(),
                1e-9 + 1e-9 * wall)
        << where;
    if (row["threads"] == 1) {
      // A row disturbed by other work on the machine (ctest -j, a shared CI node) has none.
      if (!row["disturbance"]["disturbed"].get<bool>()) {
        EXPECT_DOUBLE_EQ(row["derived"]["speedup"].get<double>(), 1.0) << where;
      } else {
        EXPECT_TRUE(row["derived"]["speedup"].is_null()) << where;
      }
      EXPECT_NEAR(a["load_imbalance_seconds"].get<double>(), 0.0, 1e-12) << where;
    }
  }

  const Outcome md = run("table " + quote((out / "sweep.json").string()));
  ASSERT_EQ(md.exit_code, 0) << md.output;
  // The Time cell carries a dagger when the instrumented run's overheads add up to more than
  // the timed runs' median, which a loaded machine (ctest -j beside a build) can bring about.
  EXPECT_TRUE(std::regex_search(
      md.output, std::regex(R"(\n\| 2 \| [-0-9.e]+ \| [-0-9.e]+ \| [-0-9.e]+ \| [-0-9.]+ \| [0-9.e-]+( †)? \| )"
                            R"([0-9.e-]+-[0-9.e-]+ \| (\d+\.\d\d|-) \| (\d+\.\d\d|-) \| (\d+\.\d\d|-) \| )"
                            R"(PASSED \| (clean|DISTURBED \(\d+ of \d+ runs\)) \|\n)")))
      << md.output;
  for (const char* heading : {"## static@blocks", "## dynamic:1@blocks", "## guided:1@blocks",
                              "## active-lists@active"}) {
    EXPECT_NE(md.output.find(heading), std::string::npos) << heading;
  }
  const Outcome csv = run("table --format csv " + quote((out / "sweep.json").string()));
  ASSERT_EQ(csv.exit_code, 0) << csv.output;
  EXPECT_EQ(std::count(csv.output.begin(), csv.output.end(), '\n'), 9);
  fs::remove_all(out);
}

TEST_F(SweepBinary, ResumeAfterKillMatchesUninterruptedSweep) {
  const fs::path killed = fresh_dir("killed"), whole = fresh_dir("whole");
  const std::vector<std::string> grid = {"--schedulers", "static,dynamic:2,guided:1,active-lists",
                                         "--threads", "1,2", "--repeat", kSanitized ? "2" : "12",
                                         "--retries", "0", "--no-plots", "--quiet", "--out"};
  std::vector<std::string> args = {binary().string(), "sweep", kScene.string()};
  args.insert(args.end(), grid.begin(), grid.end());
  args.push_back(killed.string());
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t child = 0;
  ASSERT_EQ(posix_spawn(&child, argv[0], nullptr, nullptr, argv.data(), environ), 0);

  // Kill it once two rows are on disk (and well before the last of the 8).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(kWaitSeconds);
  std::size_t rows_before_kill = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    try {
      if (fs::exists(killed / "sweep.json")) rows_before_kill = read_json(killed / "sweep.json")["rows"].size();
    } catch (const json::exception&) {
      ADD_FAILURE() << "sweep.json was torn: writes must be atomic";
    }
    if (rows_before_kill >= 2) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  kill(child, SIGKILL);
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the sweep finished before it could be killed";
  const json partial = read_json(killed / "sweep.json");
  EXPECT_FALSE(partial["complete"].get<bool>());
  EXPECT_GE(partial["rows"].size(), 2u);
  EXPECT_LT(partial["rows"].size(), 8u);
  const auto kept = row_keys(partial);

  std::string grid_text;
  for (const auto& g : grid) grid_text += quote(g) + " ";
  const Outcome resumed = run("sweep " + quote(kScene.string()) + " " + grid_text +
                              quote(killed.string()) + " --resume");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.output;
  const json after = read_json(killed / "sweep.json");
  EXPECT_TRUE(after["complete"].get<bool>());
  EXPECT_EQ(after["rows"].size(), 8u);
  for (std::size_t i = 0; i < partial["rows"].size(); ++i) {  // finished rows are kept as they were
    EXPECT_EQ(after["rows"][i]["time_seconds"], partial["rows"][i]["time_seconds"]);
  }
  const auto all = row_keys(after);
  for (const auto& k : kept) EXPECT_TRUE(all.count(k));
  // The resume compared its rows with the reference state the killed sweep stored, without
  // running the reference again, and says so per session.
  ASSERT_TRUE(after["sessions"].is_array());
  ASSERT_EQ(after["sessions"].size(), 2u);
  EXPECT_EQ(after["sessions"][0]["reference"], "run");
  EXPECT_EQ(after["sessions"][1]["reference"], "stored");
  EXPECT_EQ(after["sessions"][1]["rows_at_start"], partial["rows"].size());
  EXPECT_EQ(after["machine"], partial["machine"]) << "the first session's machine is kept";
  for (const json& row : after["rows"]) {
    EXPECT_TRUE(row["verification"]["bit_identical"].get<bool>()) << row.dump();
  }
  const auto problems = clothbench::harness::validate_sweep_document(after);
  EXPECT_TRUE(problems.empty()) << problems.front();

  // A stored state that is not the reference's is not trusted, and a missing one (a sweep
  // continued from a copy of its sweep.json) is not needed: the reference does not run again,
  // the rows are compared with its digest in sweep.json.
  auto drop_last_row = [&] {
    json d = read_json(killed / "sweep.json");
    d["rows"].erase(d["rows"].size() - 1);
    d["complete"] = false;
    std::ofstream(killed / "sweep.json") << d.dump(2);
  };
  drop_last_row();
  std::ofstream(killed / "reference-state.bin", std::ios::app) << 'x';
  const Outcome by_digest = run("sweep " + quote(kScene.string()) + " " + grid_text +
                                quote(killed.string()) + " --resume");
  ASSERT_EQ(by_digest.exit_code, 0) << by_digest.output;
  const json third = read_json(killed / "sweep.json");
  ASSERT_EQ(third["sessions"].size(), 3u);
  EXPECT_EQ(third["sessions"][2]["reference"], "digest");
  EXPECT_EQ(third["reference"], after["reference"]) << "the reference entry is the first run's";
  EXPECT_EQ(third["rows"].size(), 8u);
  EXPECT_TRUE(third["rows"][7]["verification"]["bit_identical"].get<bool>());
  EXPECT_TRUE(clothbench::harness::validate_sweep_document(third).empty());

  drop_last_row();
  fs::remove(killed / "reference-state.bin");
  {  // a digest that is not the state's: the resumed row fails, and says how it compared
    json d = read_json(killed / "sweep.json");
    d["reference"]["state_digest"] = "0123456789abcdef";
    std::ofstream(killed / "sweep.json") << d.dump(2);
  }
  const Outcome wrong_digest = run("sweep " + quote(kScene.string()) + " " + grid_text +
                                   quote(killed.string()) + " --resume");
  EXPECT_EQ(wrong_digest.exit_code, 1) << wrong_digest.output;
  const json fourth = read_json(killed / "sweep.json");
  ASSERT_EQ(fourth["rows"].size(), 8u);
  const json& failed = fourth["rows"][7]["verification"];
  EXPECT_FALSE(failed["bit_identical"].get<bool>());
  ASSERT_FALSE(failed["failures"].empty());
  EXPECT_NE(failed["failures"][0].get<std::string>().find("compared by digest"), std::string::npos)
      << failed.dump();
  EXPECT_EQ(fourth["sessions"][3]["reference"], "digest");
  {  // the right digest again for what follows
    json d = read_json(killed / "sweep.json");
    d["reference"]["state_digest"] = after["reference"]["state_digest"];
    std::ofstream(killed / "sweep.json") << d.dump(2);
  }

  // Rows from another machine or build are never mixed into one table.
  drop_last_row();
  json moved = read_json(killed / "sweep.json");
  moved["machine"]["cpu"]["model"] = "Some Other CPU";
  std::ofstream(killed / "sweep.json") << moved.dump(2);
  const Outcome elsewhere = run("sweep " + quote(kScene.string()) + " " + grid_text +
                                quote(killed.string()) + " --resume");
  EXPECT_EQ(elsewhere.exit_code, 2) << elsewhere.output;
  EXPECT_NE(elsewhere.output.find("machine.cpu.model = \"Some Other CPU\""), std::string::npos)
      << elsewhere.output;
  EXPECT_EQ(read_json(killed / "sweep.json")["rows"].size(), 7u) << "nothing is lost";
  // A VM's processor name can be the same on two generations: the caches tell them apart.
  moved["machine"]["cpu"]["model"] = partial["machine"]["cpu"]["model"];
  moved["machine"]["cpu"]["caches"]["L3"] = nullptr;
  std::ofstream(killed / "sweep.json") << moved.dump(2);
  const Outcome other_caches = run("sweep " + quote(kScene.string()) + " " + grid_text +
                                   quote(killed.string()) + " --resume");
  EXPECT_EQ(other_caches.exit_code, 2) << other_caches.output;
  EXPECT_NE(other_caches.output.find("machine.cpu.caches = "), std::string::npos)
      << other_caches.output;
  EXPECT_EQ(read_json(killed / "sweep.json")["rows"].size(), 7u) << "nothing is lost";
  // Nor can its caches always: "AMD EPYC" with 32 MiB of L3 has come with and without AVX-512.
  // The family, model number, stepping and the vector kernel's lanes do.
  moved["machine"]["cpu"]["caches"] = partial["machine"]["cpu"]["caches"];
  for (const char* field : {"family", "model_number", "stepping", "vector_isa"}) {
    json other = moved;
    other["machine"]["cpu"][field] =
        other["machine"]["cpu"][field].is_string() ? json("sse4") : json(1000);
    std::ofstream(killed / "sweep.json") << other.dump(2);
    const Outcome other_processor = run("sweep " + quote(kScene.string()) + " " + grid_text +
                                        quote(killed.string()) + " --resume");
    EXPECT_EQ(other_processor.exit_code, 2) << other_processor.output;
    EXPECT_NE(other_processor.output.find(std::string("machine.cpu.") + field + " = "),
              std::string::npos)
        << other_processor.output;
    EXPECT_EQ(read_json(killed / "sweep.json")["rows"].size(), 7u) << "nothing is lost";
  }
  // Nor rows measured another way: here fewer repetitions a row.
  std::ofstream(killed / "sweep.json") << moved.dump(2);
  const Outcome fewer = run("sweep " + quote(kScene.string()) +
                            " --schedulers static,dynamic:2,guided:1,active-lists --threads 1,2"
                            " --repeat 1 --retries 0 --no-plots --quiet --resume --out " +
                            quote(killed.string()));
  EXPECT_EQ(fewer.exit_code, 2) << fewer.output;
  EXPECT_NE(fewer.output.find("settings.repeat = "), std::string::npos) << fewer.output;
  EXPECT_EQ(read_json(killed / "sweep.json")["rows"].size(), 7u) << "nothing is lost";

  const Outcome uninterrupted =
      run("sweep " + quote(kScene.string()) + " " + grid_text + quote(whole.string()));
  ASSERT_EQ(uninterrupted.exit_code, 0) << uninterrupted.output;
  EXPECT_EQ(row_keys(read_json(whole / "sweep.json")), all);

  // Resume refuses a result made with other settings.
  const Outcome mismatch = run("sweep " + quote(kScene.string()) + " --steps 3 --retries 0 --quiet --no-plots "
                               "--resume --out " + quote(killed.string()));
  EXPECT_EQ(mismatch.exit_code, 2) << mismatch.output;
  EXPECT_NE(mismatch.output.find("--resume"), std::string::npos) << mismatch.output;
  fs::remove_all(killed);
  fs::remove_all(whole);
}

TEST_F(SweepBinary, WithoutAWarmUpTheReferenceRunIsItsRowsFirstRun) {
  const fs::path out = fresh_dir("counted");
  const std::string common = "sweep " + quote(kScene.string()) +
                             " --schedulers active-lists,static --threads 2,1 --repeat 1 "
                             "--retries 0 --no-plots --quiet --out " + quote(out.string());
  const Outcome o = run(common + " --warmup-steps 0 --count-reference-after 0");
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const json d = read_json(out / "sweep.json");
  EXPECT_TRUE(clothbench::harness::validate_sweep_document(d).empty());
  EXPECT_FALSE(d.contains("partial_rows"));
  const json& reference = d["reference"];
  EXPECT_EQ(reference["threads"], 1);
  // A reference run that other work disturbed (ctest -j) is not counted: the row measures its
  // own first run, which the sweep may re-run when disturbed. Which of the two happens depends
  // on the machine's load; the decision itself is tested on every condition without a clock
  // (SweepOptions.TheReferenceRunCountsInItsRowOnlyWhenMeasuredAsTheRowsRunsAre). Here either
  // outcome must show in the row: its one uninstrumented run is the reference run (marked so
  // in its run record, with the reference's clock reading as its sample) or a run of its own
  // (not marked); no other run of the sweep is marked.
  const bool counted = reference["counted_in_row"].get<bool>();
  EXPECT_EQ(counted, !reference["disturbed"].get<bool>());
  ASSERT_EQ(d["rows"].size(), 4u);
  int reference_rows = 0, marked_runs = 0;
  for (const json& row : d["rows"]) {
    EXPECT_EQ(row["verification"]["runs"], 2) << row["scheduler_canonical"];
    for (const json& record : row["disturbance"]["records"]) {
      marked_runs += record["reference"].get<bool>() ? 1 : 0;
    }
    if (row["scheduler_canonical"] != reference["scheduler"] || row["threads"] != 1) continue;
    ++reference_rows;
    ASSERT_EQ(row["time_seconds"]["samples"].size(), 1u);
    const json& first = row["disturbance"]["records"][0];
    EXPECT_FALSE(first["instrumented"].get<bool>());
    EXPECT_EQ(first["reference"].get<bool>(), counted);
    if (counted) {
      EXPECT_EQ(row["time_seconds"]["samples"][0], reference["wall_seconds"]);
    }
  }
  EXPECT_EQ(reference_rows, 1);
  EXPECT_EQ(marked_runs, counted ? 1 : 0);
  fs::remove_all(out);

  // With a warm-up the row's runs follow its warm-up run, which the reference did not have
  // (checked with the default threshold, 60 s); and a reference shorter than
  // --count-reference-after would bring the process's start-up into the row (checked with a
  // threshold no run of this scene reaches, so the outcome does not depend on the machine's
  // speed).
  const std::vector<std::pair<std::string, double>> not_counted = {
      {" --warmup-steps 1", 60.0}, {" --warmup-steps 0 --count-reference-after 1e9", 1e9}};
  for (const auto& [other, threshold] : not_counted) {
    const Outcome warm = run(common + other);
    ASSERT_EQ(warm.exit_code, 0) << warm.output;
    const json w = read_json(out / "sweep.json");
    EXPECT_FALSE(w["reference"]["counted_in_row"].get<bool>()) << other;
    EXPECT_EQ(w["settings"]["count_reference_after_seconds"].get<double>(), threshold) << other;
    fs::remove_all(out);
  }
}

TEST_F(SweepBinary, OversubscribedRowsNeedTheFlagAndAreLabelledEverywhere) {
  const int hardware = clothbench_test::hardware_threads();
  const std::string over = std::to_string(hardware + 1);
  const fs::path out = fresh_dir("oversubscribed");
  const std::string common = "sweep " + quote(kScene.string()) +
                             " --schedulers static --repeat 1 --retries 0 --warmup-steps 0 --no-plots "
                             "--threads 1," + over + " --out " + quote(out.string());
  const Outcome refused = run(common);
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_NE(refused.output.find("--threads: " + over + " threads requested but this machine has " +
                                std::to_string(hardware) + " hardware threads"),
            std::string::npos)
      << refused.output;
  EXPECT_NE(refused.output.find("--oversubscribe"), std::string::npos) << refused.output;
  EXPECT_FALSE(fs::exists(out / "sweep.json")) << "nothing runs before the input is checked";

  const Outcome o = run(common + " --oversubscribe");
  ASSERT_EQ(o.exit_code, 0) << o.output;
  // The per-row line, sweep.json, table.md and table.csv all say so.
  EXPECT_NE(o.output.find(over + " threads (oversubscribed)"), std::string::npos) << o.output;
  EXPECT_EQ(o.output.find(" 1 threads (oversubscribed)"), std::string::npos) << o.output;
  const json d = read_json(out / "sweep.json");
  EXPECT_TRUE(d["settings"]["oversubscribe"].get<bool>());
  ASSERT_EQ(d["rows"].size(), 2u);
  for (const json& row : d["rows"]) {
    EXPECT_EQ(row["oversubscribed"].get<bool>(), row["threads"].get<int>() > hardware) << row;
  }
  const std::string md = clothbench_test::read_text(out / "table.md");
  EXPECT_NE(md.find("| " + over + " (oversubscribed) |"), std::string::npos) << md;
  EXPECT_NE(md.find("| 1 |"), std::string::npos) << md;
  const std::string csv = clothbench_test::read_text(out / "table.csv");
  EXPECT_NE(csv.find("," + over + ",true,"), std::string::npos) << csv;
  EXPECT_NE(csv.find(",1,false,"), std::string::npos) << csv;
  fs::remove_all(out);
}

TEST_F(SweepBinary, BadInputExitsWithCodeTwoAndSaysWhy) {
  const std::string out = " --quiet --no-plots --out " + quote(fresh_dir("bad").string());
  const Outcome unknown =
      run("sweep " + quote(kScene.string()) + " --schedulers static,dynamc:2" + out);
  EXPECT_EQ(unknown.exit_code, 2) << unknown.output;
  EXPECT_NE(unknown.output.find("dynamc"), std::string::npos) << unknown.output;
  EXPECT_NE(unknown.output.find("--schedulers"), std::string::npos) << unknown.output;

  const Outcome zero = run("sweep " + quote(kScene.string()) + " --threads 0,1" + out);
  EXPECT_EQ(zero.exit_code, 2) << zero.output;
  EXPECT_NE(zero.output.find("--threads: '0'"), std::string::npos) << zero.output;

  const Outcome too_many = run("sweep " + quote(kScene.string()) + " --threads 100000" + out);
  EXPECT_EQ(too_many.exit_code, 2) << too_many.output;
  EXPECT_NE(too_many.output.find("--oversubscribe"), std::string::npos) << too_many.output;

  const Outcome missing = run("sweep /nonexistent/scene.toml" + out);
  EXPECT_EQ(missing.exit_code, 2) << missing.output;
  EXPECT_NE(missing.output.find("/nonexistent/scene.toml"), std::string::npos) << missing.output;

  const Outcome directory = run("sweep " + quote(CLOTHBENCH_SOURCE_DIR) + out);
  EXPECT_EQ(directory.exit_code, 2) << directory.output;

  const Outcome not_sweep = run("table " + quote(kScene.string()));
  EXPECT_EQ(not_sweep.exit_code, 2) << not_sweep.output;
  EXPECT_NE(not_sweep.output.find("not JSON"), std::string::npos) << not_sweep.output;

  const Outcome bad_format = run("table x.json --format html");
  EXPECT_EQ(bad_format.exit_code, 2) << bad_format.output;

  const Outcome no_scene = run("sweep" + out);
  EXPECT_EQ(no_scene.exit_code, 2) << no_scene.output;
  EXPECT_NE(no_scene.output.find("--class"), std::string::npos) << no_scene.output;

  const Outcome bad_class = run("sweep --class Q" + out);
  EXPECT_EQ(bad_class.exit_code, 2) << bad_class.output;
  EXPECT_NE(bad_class.output.find("--class: unknown size class 'Q'"), std::string::npos)
      << bad_class.output;

  const Outcome both = run("sweep " + quote(kScene.string()) + " --class S" + out);
  EXPECT_EQ(both.exit_code, 2) << both.output;
  EXPECT_NE(both.output.find("either SCENE or --class"), std::string::npos) << both.output;
}

// --class picks the class's scene and its settings where the command line gives none, and the
// record says which class ran.
TEST_F(SweepBinary, SizeClassPicksItsSceneAndSettingsAndIsRecorded) {
  const fs::path out = fresh_dir("class-s");
  const Outcome o =
      run("sweep --class S --steps 1 --threads 1 --schedulers static --repeat 1 "
          "--retries 0 --no-plots --quiet --out " +
          quote(out.string()));
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const json d = read_json(out / "sweep.json");
  EXPECT_EQ(d["settings"]["size_class"], "S");
  EXPECT_EQ(d["settings"]["repeat"], 1);        // given: the command line wins
  EXPECT_EQ(d["settings"]["warmup_steps"], 2);  // not given: the class's
  EXPECT_EQ(fs::path(d["scene"]["file"].get<std::string>()).filename(), "box-49-drape.toml");
  EXPECT_TRUE(d["complete"].get<bool>());

  const fs::path plain = fresh_dir("class-none");
  const Outcome p = run("sweep " + quote(kScene.string()) +
                        " --steps 1 --threads 1 "
                        "--schedulers static --repeat 1 --warmup-steps 0 --retries 0 --no-plots "
                        "--quiet --out " +
                        quote(plain.string()));
  ASSERT_EQ(p.exit_code, 0) << p.output;
  EXPECT_TRUE(read_json(plain / "sweep.json")["settings"]["size_class"].is_null());
}

// --instrument-only: only the named schedulers' rows get instrumented runs (the paper's Table 2
// decomposes Active-Lists' time alone); the others are timed uninstrumented, and every output
// says which is which. A resume that changes the list, or a list outside --schedulers, is
// refused with exit code 2.
TEST_F(SweepBinary, InstrumentOnlyInstrumentsTheNamedSchedulersRows) {
  const fs::path out = fresh_dir("instrument-only");
  const std::string grid = " --schedulers static,active-lists --threads 1,2 --steps 2 --repeat 2 "
                           "--retries 0 --no-plots --quiet --out " + quote(out.string());
  const Outcome o = run("sweep " + quote(kScene.string()) + grid + " --instrument-only active-lists");
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const json d = read_json(out / "sweep.json");
  const auto problems = clothbench::harness::validate_sweep_document(d);
  EXPECT_TRUE(problems.empty()) << problems.front();
  EXPECT_EQ(d["settings"]["instrument"], "loops");
  EXPECT_EQ(d["settings"]["instrument_only"], json::array({"active-lists@active"}));
  ASSERT_EQ(d["rows"].size(), 4u);
  for (const json& row : d["rows"]) {
    const bool timed = row["scheduler_canonical"] == "active-lists@active";
    const std::string where = row["scheduler_canonical"].get<std::string>() + " x " +
                              std::to_string(row["threads"].get<int>());
    EXPECT_TRUE(row["verification"]["passed"].get<bool>()) << where;
    EXPECT_EQ(row["verification"]["runs"].get<int>(), timed ? 4 : 2) << where;
    EXPECT_EQ(row["instrumented"]["level"], timed ? "loops" : "off") << where;
    EXPECT_EQ(row["time_seconds"]["samples"].size(), 2u) << where;
    if (timed) {
      EXPECT_EQ(row["instrumented"]["time_seconds"]["samples"].size(), 2u) << where;
      EXPECT_TRUE(row["accounting"].contains("identity")) << where;
    } else {
      EXPECT_TRUE(row["instrumented"]["time_seconds"].is_null()) << where;
      EXPECT_TRUE(row["accounting"].is_null()) << where;
    }
  }
  const std::string table = read_text(out / "table.md");
  EXPECT_NE(table.find("instrumentation `loops` for `active-lists@active` only"), std::string::npos)
      << table;
  // static's rows: Table 2's overhead columns are `-`, and there is no accounting table.
  const std::size_t static_at = table.find("## static@blocks");
  const std::size_t lists_at = table.find("## active-lists@active");
  ASSERT_NE(static_at, std::string::npos) << table;
  ASSERT_NE(lists_at, std::string::npos) << table;
  const std::string static_part = table.substr(static_at, lists_at - static_at);
  EXPECT_NE(static_part.find("| 1 | - | - | - | - |"), std::string::npos) << static_part;
  EXPECT_NE(static_part.find("| 2 | - | - | - | - |"), std::string::npos) << static_part;
  EXPECT_EQ(static_part.find("Where the time went"), std::string::npos) << static_part;
  EXPECT_NE(table.find("Where the time went", lists_at), std::string::npos) << table;

  // A resume with another list (here: every row) would mix two ways of measuring.
  const Outcome resumed = run("sweep " + quote(kScene.string()) + grid + " --resume");
  EXPECT_EQ(resumed.exit_code, 2) << resumed.output;
  EXPECT_NE(resumed.output.find("settings.instrument_only = [\"active-lists@active\"]"),
            std::string::npos)
      << resumed.output;
  // The same list spelled another way is the same sweep: nothing left to run.
  const Outcome same = run("sweep " + quote(kScene.string()) + grid +
                           " --instrument-only active-lists@active --resume");
  EXPECT_EQ(same.exit_code, 0) << same.output;

  const std::string bad_out = " --out " + quote(fresh_dir("instrument-only-bad").string());
  const Outcome outside = run("sweep " + quote(kScene.string()) +
                              " --schedulers static --threads 1 --instrument-only guided:1" +
                              bad_out);
  EXPECT_EQ(outside.exit_code, 2) << outside.output;
  EXPECT_NE(outside.output.find("--instrument-only: 'guided:1'"), std::string::npos)
      << outside.output;
  EXPECT_NE(outside.output.find("is not one of --schedulers"), std::string::npos) << outside.output;
  const Outcome off = run("sweep " + quote(kScene.string()) +
                          " --schedulers static --threads 1 --instrument off "
                          "--instrument-only static" + bad_out);
  EXPECT_EQ(off.exit_code, 2) << off.output;
  EXPECT_NE(off.output.find("--instrument-only: needs --instrument loops or chunks"),
            std::string::npos)
      << off.output;
}

}  // namespace
