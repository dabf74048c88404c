// `clothbench experiment` at the tiny size, run as a child process: every experiment writes
// its JSON and Markdown, every run is verified, and the orderings the model must show hold
// (Table 1: finer error < AMRC error < coarser error against the tight reference, AMRC does
// less element work than the finer mesh, the coarse mesh penetrates the box more; Table 3:
// AMRC removes particles; time-error: the Pareto front holds the fastest and the most
// accurate setting, a coarser mesh is less accurate than the base mesh).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/harness/clothbench_process.hpp"

namespace {

namespace fs = std::filesystem;
using clothbench_test::fresh_dir;
using clothbench_test::quote;
using clothbench_test::read_json;
using clothbench_test::read_text;
using clothbench_test::run;
using nlohmann::json;

const json* find_run(const json& runs, const std::string& label) {
  for (const json& r : runs) {
    if (r["label"] == label) return &r;
  }
  return nullptr;
}

// Fields every run record carries, finite where they are numbers.
void expect_run_fields(const json& r) {
  for (const char* key : {"label", "setting", "passed", "seconds", "particles_start",
                          "particles_end", "element_updates", "cg_iterations",
                          "average_minimised_cost", "max_surface_penetration_m"}) {
    EXPECT_TRUE(r.contains(key)) << key << " missing in " << r.dump();
  }
  EXPECT_TRUE(r["passed"].get<bool>()) << r.dump();
  EXPECT_GT(r["seconds"].get<double>(), 0.0);
}

// Common keys of every experiment document.
void expect_document(const json& doc, const std::string& schema) {
  EXPECT_EQ(doc["schema"], "clothbench.experiment." + schema);
  EXPECT_EQ(doc["schema_version"], 1);
  EXPECT_EQ(doc["size"], "tiny");
  EXPECT_TRUE(doc["complete"].get<bool>());
  EXPECT_TRUE(doc["machine"].is_object());
  EXPECT_TRUE(doc["machine"].contains("cpu"));
  EXPECT_TRUE(doc["threads"].is_number_integer());
}

TEST(ExperimentBinary, Table1OrderingsHoldAtTheTinySize) {
  const fs::path out = fresh_dir("experiment-table1");
  const auto outcome = run("experiment table1 --size tiny --threads 1 --quiet --out " + quote(out.string()));
  ASSERT_EQ(outcome.exit_code, 0) << outcome.output;
  EXPECT_NE(outcome.output.find("Verification: PASSED"), std::string::npos) << outcome.output;
  const json doc = read_json(out / "table1-tiny" / "table1.json");
  expect_document(doc, "table1");
  ASSERT_EQ(doc["runs"].size(), 4u);
  for (const json& r : doc["runs"]) expect_run_fields(r);
  const json& finer = *find_run(doc["runs"], "finer");
  const json& amrc = *find_run(doc["runs"], "amrc");
  const json& coarser = *find_run(doc["runs"], "coarser");
  EXPECT_EQ(find_run(doc["runs"], "reference")->at("error_rms_m"), 0.0);
  EXPECT_LT(finer["error_rms_m"].get<double>(), amrc["error_rms_m"].get<double>());
  EXPECT_LT(amrc["error_rms_m"].get<double>(), coarser["error_rms_m"].get<double>());
  EXPECT_LT(amrc["element_updates"].get<double>(), finer["element_updates"].get<double>());
  EXPECT_GT(coarser["max_surface_penetration_m"].get<double>(),
            finer["max_surface_penetration_m"].get<double>());
  EXPECT_LT(amrc["particles_end"].get<int>(), amrc["particles_start"].get<int>());
  EXPECT_EQ(coarser["particles_start"], coarser["particles_end"]);
  EXPECT_EQ(finer["paper"]["seconds"], 2940);
  EXPECT_TRUE(doc["orderings"]["error: finer < amrc < coarser"].get<bool>());
  const std::string md = read_text(out / "table1-tiny" / "table1.md");
  for (const char* text : {"| finer |", "| amrc |", "| coarser |", "| reference |", "2940", "PASSED"}) {
    EXPECT_NE(md.find(text), std::string::npos) << text << "\n" << md;
  }
}

TEST(ExperimentBinary, Table3ReportsEveryAmrcEvent) {
  const fs::path out = fresh_dir("experiment-table3");
  const auto outcome = run("experiment table3 --size tiny --threads 1 --quiet --out " + quote(out.string()));
  ASSERT_EQ(outcome.exit_code, 0) << outcome.output;
  const json doc = read_json(out / "table3-tiny" / "table3.json");
  expect_document(doc, "table3");
  ASSERT_EQ(doc["scenes"].size(), 2u);
  for (const json& scene : doc["scenes"]) {
    expect_run_fields(scene);
    ASSERT_FALSE(scene["events"].empty());
    EXPECT_EQ(scene["events"].back()["particles"], scene["particles_end"]);
    EXPECT_LT(scene["particles_end"].get<int>(), scene["particles_start"].get<int>());
    EXPECT_EQ(scene["paper"]["particles_start"], 1e6);
  }
  EXPECT_EQ(doc["scenes"][1]["paper"]["particles_end"], 32832);
}

// --only runs the reference, the base and the settings named, records the list, and refuses a
// label the study does not have (naming the ones it has) and any experiment but time-error.
TEST(ExperimentBinary, TimeErrorOnlyRunsTheNamedSettings) {
  const fs::path out = fresh_dir("experiment-time-error-only");
  const auto outcome = run("experiment time-error --size tiny --threads 1 --steps 10 --quiet "
                           "--only tol-x10,dt-x2 --no-plots --out " + quote(out.string()));
  ASSERT_EQ(outcome.exit_code, 0) << outcome.output;
  const json doc = read_json(out / "time-error-tiny" / "time_error.json");
  expect_document(doc, "time_error");
  EXPECT_EQ(doc["only"], json::array({"tol-x10", "dt-x2"}));
  std::vector<std::string> labels;
  for (const json& r : doc["runs"]) labels.push_back(r["label"].get<std::string>());
  EXPECT_EQ(labels, (std::vector<std::string>{"reference", "base", "tol-x10", "dt-x2"}));

  const auto unknown = run("experiment time-error --size tiny --threads 1 --only tol-x3 --out " +
                           quote(fresh_dir("experiment-only-unknown").string()));
  EXPECT_EQ(unknown.exit_code, 2) << unknown.output;
  EXPECT_NE(unknown.output.find("--only: no setting 'tol-x3' for this base (settings: base, "),
            std::string::npos)
      << unknown.output;
  EXPECT_NE(unknown.output.find("tol-x10"), std::string::npos) << unknown.output;
  const auto elsewhere = run("experiment table1 --size tiny --only base --out " +
                             quote(fresh_dir("experiment-only-table1").string()));
  EXPECT_EQ(elsewhere.exit_code, 2) << elsewhere.output;
  EXPECT_NE(elsewhere.output.find("--only: only time-error has settings"), std::string::npos)
      << elsewhere.output;
}

TEST(ExperimentBinary, TimeErrorMarksTheParetoFront) {
  const fs::path out = fresh_dir("experiment-time-error");
  const auto outcome =
      run("experiment time-error --size tiny --threads 1 --quiet --out " + quote(out.string()));
  ASSERT_EQ(outcome.exit_code, 0) << outcome.output;
  const fs::path dir = out / "time-error-tiny";
  const json doc = read_json(dir / "time_error.json");
  expect_document(doc, "time_error");
  const json& runs = doc["runs"];
  ASSERT_GE(runs.size(), 10u);
  EXPECT_EQ(runs[0]["label"], "reference");
  double fastest = 1e300, most_accurate = 1e300;
  std::string fastest_label, accurate_label;
  for (std::size_t k = 1; k < runs.size(); ++k) {
    expect_run_fields(runs[k]);
    EXPECT_TRUE(runs[k]["error_rms_m"].is_number());
    EXPECT_LE(runs[k]["error_rms_m"].get<double>(), runs[k]["error_max_m"].get<double>());
    if (runs[k]["seconds"].get<double>() < fastest) {
      fastest = runs[k]["seconds"];
      fastest_label = runs[k]["label"];
    }
    if (runs[k]["error_rms_m"].get<double>() < most_accurate) {
      most_accurate = runs[k]["error_rms_m"];
      accurate_label = runs[k]["label"];
    }
  }
  EXPECT_TRUE(find_run(runs, fastest_label)->at("pareto").get<bool>()) << fastest_label;
  EXPECT_TRUE(find_run(runs, accurate_label)->at("pareto").get<bool>()) << accurate_label;
  const json* base = find_run(runs, "base");
  const json* coarse = find_run(runs, "mesh-6");  // 21 x 21 base: 11 x 11 and 6 x 6
  ASSERT_NE(base, nullptr);
  ASSERT_NE(coarse, nullptr);
  EXPECT_LT(base->at("error_rms_m").get<double>(), coarse->at("error_rms_m").get<double>());
  ASSERT_NE(find_run(runs, "time-budget-50%"), nullptr);
  ASSERT_NE(find_run(runs, "numeric-gradient"), nullptr);
  const json* uncapped = find_run(runs, "cap-x10");  // the reference's cap, scene tolerance
  ASSERT_NE(uncapped, nullptr);
  EXPECT_LE(uncapped->at("rejected_steps").get<std::int64_t>(),
            base->at("rejected_steps").get<std::int64_t>());
  // The paper's nonlinear CG beside the default Newton; the line solves take CG fewer
  // iterations a step than block Jacobi.
  const json* paper = find_run(runs, "paper-cg");
  const json* lines = find_run(runs, "cg-line-solves");
  ASSERT_NE(paper, nullptr);
  ASSERT_NE(lines, nullptr);
  EXPECT_TRUE(paper->at("passed").get<bool>());
  EXPECT_TRUE(lines->at("passed").get<bool>());
  EXPECT_LT(lines->at("cg_iterations").get<std::int64_t>(),
            paper->at("cg_iterations").get<std::int64_t>());
  // Longer time steps over the same simulated time: a half and a quarter of the base's steps.
  for (const int factor : {2, 4}) {
    const json* longer = find_run(runs, "dt-x" + std::to_string(factor));
    ASSERT_NE(longer, nullptr) << factor;
    EXPECT_TRUE(longer->at("passed").get<bool>()) << factor;
    EXPECT_EQ(longer->at("steps").get<std::int64_t>() * factor,
              base->at("steps").get<std::int64_t>())
        << factor;
    EXPECT_TRUE(longer->at("error_rms_m").is_number()) << factor;
  }
  if (std::system("gnuplot --version > /dev/null 2>&1") == 0) {
    EXPECT_TRUE(fs::exists(dir / "time_error.png"));
    EXPECT_NE(read_text(dir / "time_error.gp").find("title 'Pareto front'"), std::string::npos);
  }
  const std::string md = read_text(dir / "time_error.md");
  EXPECT_NE(md.find("| Solver iterations | Rejected steps | Pareto |"), std::string::npos);
  EXPECT_NE(md.find("| * |"), std::string::npos);
  // Each row names the solver its iterations belong to.
  EXPECT_NE(md.find("| Newton " + std::to_string(base->at("cg_iterations").get<std::int64_t>()) +
                    " (PCG "),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| CG " + std::to_string(paper->at("cg_iterations").get<std::int64_t>()) +
                    " |"),
            std::string::npos)
      << md;
}

TEST(ExperimentBinary, Table2IsTheBoxSweep) {
  const fs::path out = fresh_dir("experiment-table2");
  const auto outcome = run("experiment table2 --size tiny --threads 1 --retries 0 --quiet --no-plots --out " +
                           quote(out.string()));
  ASSERT_EQ(outcome.exit_code, 0) << outcome.output;
  const json doc = read_json(out / "table2-tiny" / "sweep.json");
  ASSERT_EQ(doc["rows"].size(), 6u);  // the paper's six schedulers at one thread
  EXPECT_EQ(doc["settings"]["retries"].get<int>(), 0);  // --retries reaches the sweep
  for (const json& row : doc["rows"]) EXPECT_TRUE(row["verification"]["passed"].get<bool>());
  EXPECT_NE(read_text(out / "table2-tiny" / "table.md").find("## active-lists@active"),
            std::string::npos);
}

TEST(ExperimentBinary, BadNamesAndSizesAreExitTwo) {
  auto outcome = run("experiment table9 --size tiny");
  EXPECT_EQ(outcome.exit_code, 2) << outcome.output;
  EXPECT_NE(outcome.output.find("table9"), std::string::npos) << outcome.output;
  outcome = run("experiment table1 --size huge");
  EXPECT_EQ(outcome.exit_code, 2) << outcome.output;
  EXPECT_NE(outcome.output.find("--size"), std::string::npos) << outcome.output;
  outcome = run("experiment table1 --size tiny --scheduler dynamic:0 --out " +
                quote(fresh_dir("experiment-bad").string()));
  EXPECT_EQ(outcome.exit_code, 2) << outcome.output;
  EXPECT_NE(outcome.output.find("dynamic:0"), std::string::npos) << outcome.output;
  outcome = run("experiment table2 --size tiny --retries 101");
  EXPECT_EQ(outcome.exit_code, 2) << outcome.output;
  EXPECT_NE(outcome.output.find("--retries"), std::string::npos) << outcome.output;
  outcome = run("experiment table1 --size tiny --retries 0");
  EXPECT_EQ(outcome.exit_code, 2) << outcome.output;
  EXPECT_NE(outcome.output.find("only table2"), std::string::npos) << outcome.output;
}

}  // namespace
