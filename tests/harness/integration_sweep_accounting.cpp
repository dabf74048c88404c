// The accounting identity on a real tiny sweep (issue 18, step 3): every row's overheads come
// from its median instrumented run, and sweep.json, table.md, table.csv and the per-row line
// all show that run's wall time as the sum of seq. overhead + parallel work + para. overhead +
// imbalance + residual. The assertions are identities and ratios within one run, never a
// speed: JSON to 1e-12 relative, the Markdown to the rounding of its printed decimals, the CSV
// to its 9 significant digits.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "harness/sweep/sweep_document.hpp"
#include "tests/harness/clothbench_process.hpp"

namespace {

namespace fs = std::filesystem;
using clothbench_test::fresh_dir;
using clothbench_test::Outcome;
using clothbench_test::quote;
using clothbench_test::read_json;
using clothbench_test::read_text;
using clothbench_test::run;
using nlohmann::json;

const fs::path kScene = fs::path(CLOTHBENCH_SOURCE_DIR) / "tests/data/scenes/sweep-tiny.toml";

/// The fields of one CSV line (no quoted commas before the note column, which comes last of
/// the fields read here).
std::vector<std::string> csv_fields(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  bool quoted = false;
  for (char c : line) {
    if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      fields.push_back(field);
      field.clear();
    } else {
      field += c;
    }
  }
  fields.push_back(field);
  return fields;
}

TEST(SweepAccounting, IdentityHoldsPerRowInSweepJsonTableAndCsv) {
  ASSERT_TRUE(fs::exists(clothbench_test::binary())) << clothbench_test::binary();
  const fs::path out = fresh_dir("accounting-identity");
  const std::string threads = std::min(2, clothbench_test::hardware_threads()) > 1 ? "1,2" : "1";
  const Outcome o =
      run("sweep " + quote(kScene.string()) + " --schedulers static,dynamic:1 --threads " +
          threads + " --repeat 3 --retries 0 --no-plots --out " + quote(out.string()));
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const json d = read_json(out / "sweep.json");
  const auto problems = clothbench::harness::validate_sweep_document(d);
  ASSERT_TRUE(problems.empty()) << problems.front();
  ASSERT_FALSE(d["rows"].empty());

  const std::string md = read_text(out / "table.md");
  std::istringstream csv(read_text(out / "table.csv"));
  std::string header_line;
  std::getline(csv, header_line);
  const std::vector<std::string> header = csv_fields(header_line);
  auto column = [&](const std::string& name) {
    const auto it = std::find(header.begin(), header.end(), name);
    EXPECT_NE(it, header.end()) << name;
    return static_cast<std::size_t>(it - header.begin());
  };
  std::vector<std::vector<std::string>> csv_rows;
  for (std::string line; std::getline(csv, line);) csv_rows.push_back(csv_fields(line));

  for (const json& row : d["rows"]) {
    const std::string scheduler = row["scheduler_canonical"];
    const int n = row["threads"];
    const std::string where = scheduler + " x " + std::to_string(n);
    const json& a = row["accounting"];
    ASSERT_TRUE(a.is_object()) << where;
    ASSERT_TRUE(a.contains("identity")) << where;
    const json& id = a["identity"];
    const double wall = a["wall_seconds"];
    const double seq = a["sequential_overhead_seconds"], work = a["parallel_work_seconds"];
    const double para = a["parallel_overhead_seconds"], imb = a["load_imbalance_seconds"];
    const double residual = id["residual_seconds"];

    // sweep.json: the run the overheads come from is the median of the instrumented runs,
    // and its wall time is the sum of the four parts and the residual.
    const json& instrumented = row["instrumented"]["time_seconds"];
    ASSERT_EQ(a["runs"], 3) << where;
    ASSERT_EQ(instrumented["samples"].size(), 3u) << where;
    EXPECT_EQ(instrumented["samples"][a["from_run"].get<std::size_t>()].get<double>(), wall)
        << where << ": the overheads come from the run whose wall is recorded";
    EXPECT_EQ(instrumented["median"].get<double>(), wall) << where << ": the median run";
    EXPECT_NEAR(seq + work + para + imb + residual, wall, 1e-12 * wall) << where;
    EXPECT_NEAR(id["wall_seconds"].get<double>(), wall, 1e-12 * wall) << where;
    EXPECT_NEAR(id["parts_seconds"].get<double>(), seq + work + para + imb, 1e-12 * wall) << where;
    // The residual is the time outside the kernel's step timer: the recorded unaccounted time.
    EXPECT_NEAR(residual, a["unaccounted_seconds"].get<double>(), 1e-12 * wall) << where;
    EXPECT_NEAR(id["overheads_seconds"].get<double>(), seq + para + imb, 1e-12 * wall) << where;
    const double time = row["time_seconds"]["median"];
    EXPECT_EQ(id["time_median_seconds"].get<double>(), time) << where;
    EXPECT_NEAR(id["wall_over_time"].get<double>(), wall / time, 1e-12) << where;
    EXPECT_NEAR(row["instrumented"]["cost_ratio"].get<double>(),
                instrumented["median"].get<double>() / time, 1e-12)
        << where;
    EXPECT_EQ(id["overheads_exceed_time"].get<bool>(), seq + para + imb > time) << where;
    EXPECT_EQ(id["note"].get<std::string>().empty(), !(seq + para + imb > time)) << where;

    // table.md: the row of the scheduler's accounting table, every number printed with the
    // same decimals, adds up to the printed wall within half a unit of the last decimal per
    // printed figure (6 figures).
    const std::regex row_pattern("\\n\\| " + std::to_string(n) +
                                 " \\| instr\\. run (\\d) of 3 \\(median\\) \\| ([-0-9.]+) \\| "
                                 "([-0-9.]+) \\| ([-0-9.]+) \\| ([-0-9.]+) \\| ([-0-9.]+) \\| "
                                 "([-0-9.]+) \\| ([0-9.]+)x( \u2020)? \\|\\n");
    const std::size_t section = md.find("## " + scheduler + "\n");
    ASSERT_NE(section, std::string::npos) << where;
    const std::size_t next = md.find("\n## ", section + 3);
    const std::string part =
        md.substr(section, next == std::string::npos ? std::string::npos : next - section);
    std::smatch m;
    ASSERT_TRUE(std::regex_search(part, m, row_pattern)) << where << "\n" << part;
    EXPECT_EQ(std::stoul(m[1]), a["from_run"].get<std::size_t>() + 1) << where;
    const std::string wall_text = m[2];
    const std::size_t decimals = wall_text.size() - wall_text.find('.') - 1;
    const double unit = std::pow(10.0, -static_cast<double>(decimals));
    double printed_parts = 0.0;
    for (int k = 3; k <= 7; ++k) {
      EXPECT_EQ(std::string(m[k]).size() - std::string(m[k]).find('.') - 1, decimals) << where;
      printed_parts += std::stod(m[k]);
    }
    EXPECT_NEAR(printed_parts, std::stod(wall_text), 3.0 * unit + 1e-12) << where << "\n" << m[0];
    EXPECT_NEAR(std::stod(wall_text), wall, 0.5 * unit + 1e-12) << where;
    EXPECT_NEAR(std::stod(m[8]), wall / time, 0.005 + 1e-9) << where;
    EXPECT_EQ(m[9].matched, id["overheads_exceed_time"].get<bool>()) << where;

    // table.csv: the same run and identity.
    const auto line = std::find_if(csv_rows.begin(), csv_rows.end(), [&](const auto& f) {
      return f.size() > 2 && f[1] == scheduler && f[2] == std::to_string(n);
    });
    ASSERT_NE(line, csv_rows.end()) << where;
    const auto& f = *line;
    ASSERT_EQ(f.size(), header.size()) << where;
    EXPECT_EQ(std::stoul(f[column("overheads_from_run")]), a["from_run"].get<std::size_t>())
        << where;
    EXPECT_EQ(f[column("instrumented_runs")], "3") << where;
    double csv_parts = 0.0;
    for (const char* k : {"sequential_overhead_s", "parallel_work_s", "parallel_overhead_s",
                          "load_imbalance_s", "unaccounted_s"}) {
      csv_parts += std::stod(f[column(k)]);
    }
    const double csv_wall = std::stod(f[column("instrumented_run_wall_s")]);
    EXPECT_NEAR(csv_parts, csv_wall, 1e-8 * csv_wall) << where;
    EXPECT_NEAR(csv_wall, wall, 1e-8 * wall) << where;
    EXPECT_EQ(f[column("overheads_exceed_time")],
              id["overheads_exceed_time"].get<bool>() ? "true" : "false")
        << where;

    // The per-row line printed by the sweep names the same run and its wall.
    EXPECT_THAT(o.output, testing::ContainsRegex(scheduler + " +" + std::to_string(n) +
                                                 " threads .*overheads from instr\\. run " +
                                                 std::to_string(a["from_run"].get<int>() + 1) +
                                                 " of 3 \\(median\\): wall [0-9.]+ = seq "))
        << where;
  }
  fs::remove_all(out);
}

}  // namespace
