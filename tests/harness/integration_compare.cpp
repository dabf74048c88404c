// `clothbench compare A.json B.json` run as a process on synthetic sweep documents made from
// the committed reference sweep (results/reference/box-101-amrc/sweep.json) with known
// differences: verdicts, flags, the fewer-than-9-repetitions warning, FAILED / DISTURBED /
// unmatched rows, the different-scene warning, the JSON output and the exit codes (0, 1
// regression, 2 bad input).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "tests/harness/clothbench_process.hpp"

namespace {

namespace fs = std::filesystem;
using clothbench_test::Outcome;
using clothbench_test::quote;
using nlohmann::json;

const fs::path kReference =
    fs::path(CLOTHBENCH_SOURCE_DIR) / "results/reference/box-101-amrc/sweep.json";

/// The reference sweep with `repetitions` timed samples per row: the row's median times
/// 1, 1.01, 0.99, 1.02, ... (distinct values), all multiplied by `factor`.
json synthetic(int repetitions, double factor) {
  json d = clothbench_test::read_json(kReference);
  for (json& row : d["rows"]) {
    const double base = row["time_seconds"]["median"].get<double>();
    json samples = json::array();
    for (int k = 0; k < repetitions; ++k) {
      const double step = 0.01 * ((k + 1) / 2) * (k % 2 == 1 ? 1.0 : -1.0);
      samples.push_back(factor * base * (1.0 + step));
    }
    double lo = samples[0], hi = samples[0];
    for (const json& s : samples)
      lo = std::min(lo, s.get<double>()), hi = std::max(hi, s.get<double>());
    row["time_seconds"] = {
        {"median", factor * base}, {"min", lo}, {"max", hi}, {"samples", samples}};
  }
  return d;
}

class Compare : public ::testing::Test {
 protected:
  void SetUp() override { fs::create_directories(dir_); }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path write(const std::string& name, const json& document) {
    const fs::path file = dir_ / name;
    std::ofstream(file) << document.dump();
    return file;
  }
  static Outcome compare(const fs::path& a, const fs::path& b, const std::string& extra = {}) {
    return clothbench_test::run("compare " + quote(a.string()) + " " + quote(b.string()) + " " +
                                extra);
  }
  /// The table line of a row (starts with "| scheduler | threads |").
  static std::string line_of(const std::string& output, const std::string& scheduler, int threads) {
    const std::string start = "| " + scheduler + " | " + std::to_string(threads) + " |";
    const std::size_t at = output.find(start);
    if (at == std::string::npos) return {};
    return output.substr(at, output.find('\n', at) - at);
  }

  fs::path dir_ = clothbench_test::fresh_dir("compare");
};

TEST_F(Compare, IdenticalDocumentsAreTheSame) {
  const fs::path a = write("a.json", synthetic(10, 1.0));
  const Outcome out = compare(a, a, "--json " + quote((dir_ / "c.json").string()));
  EXPECT_EQ(out.exit_code, 0) << out.output;
  const json c = clothbench_test::read_json(dir_ / "c.json");
  EXPECT_EQ(c["schema"], "clothbench.compare");
  ASSERT_EQ(c["rows"].size(), 12u);
  for (const json& row : c["rows"]) {
    EXPECT_EQ(row["verdict"], "same") << row.dump();
    EXPECT_DOUBLE_EQ(row["ratio"].get<double>(), 1.0);
    EXPECT_DOUBLE_EQ(row["mann_whitney"]["p_value"].get<double>(), 1.0);
    EXPECT_FALSE(row["few_repetitions"].get<bool>());
    EXPECT_LE(row["interval"]["low"].get<double>(), 1.0);
    EXPECT_GE(row["interval"]["high"].get<double>(), 1.0);
  }
  EXPECT_EQ(c["regressions"], 0);
  EXPECT_EQ(out.output.find("fewer than 9"), std::string::npos) << out.output;
}

TEST_F(Compare, SlowdownOfHalfIsASignificantRegression) {
  const fs::path a = write("a.json", synthetic(10, 1.0));
  const fs::path b = write("b.json", synthetic(10, 1.5));
  const Outcome out = compare(a, b, "--json " + quote((dir_ / "c.json").string()));
  EXPECT_EQ(out.exit_code, 1) << out.output;
  const json c = clothbench_test::read_json(dir_ / "c.json");
  for (const json& row : c["rows"]) {
    EXPECT_EQ(row["verdict"], "slower") << row.dump();
    EXPECT_TRUE(row["regression"].get<bool>());
    EXPECT_NEAR(row["ratio"].get<double>(), 1.5, 1e-9);
    EXPECT_EQ(row["mann_whitney"]["method"], "exact");
    EXPECT_NEAR(row["mann_whitney"]["p_value"].get<double>(), 2.0 / 184756.0, 1e-15);
    EXPECT_LT(row["interval"]["low"].get<double>(), 1.5);
    EXPECT_GT(row["interval"]["high"].get<double>(), 1.5);
  }
  EXPECT_EQ(c["regressions"], 12);
  EXPECT_NE(line_of(out.output, "static@blocks", 2).find("slower !"), std::string::npos)
      << out.output;
  EXPECT_NE(out.output.find("12 regression(s) beyond 5.0 %"), std::string::npos) << out.output;

  // Beyond a 60 % threshold the same slow-down is reported but passes; B faster than A too.
  const Outcome lenient = compare(a, b, "--threshold 0.6");
  EXPECT_EQ(lenient.exit_code, 0) << lenient.output;
  EXPECT_NE(line_of(lenient.output, "static@blocks", 2).find("| slower |"), std::string::npos);
  const Outcome faster = compare(b, a);
  EXPECT_EQ(faster.exit_code, 0) << faster.output;
  EXPECT_NE(line_of(faster.output, "static@blocks", 2).find("| faster |"), std::string::npos);
}

TEST_F(Compare, FewRepetitionsAreFlagged) {
  // The committed reference has 3 repetitions per row.
  const Outcome out = compare(kReference, kReference);
  EXPECT_EQ(out.exit_code, 0) << out.output;
  const std::string line = line_of(out.output, "dynamic:2@blocks", 2);
  EXPECT_NE(line.find("3 / 3 repetitions: fewer than 9"), std::string::npos) << out.output;
  EXPECT_NE(line.find("| same |"), std::string::npos) << line;
  // LB4OMP's imbalance of the 2-thread static row's per-thread work [13.229, 5.184] s:
  // (13.229 - 9.207) / 13.229 x 2 x 100 = 60.8 %; at 1 thread it is undefined ("-").
  EXPECT_NE(line_of(out.output, "static@blocks", 2).find("| 60.8 / 60.8 |"), std::string::npos)
      << out.output;
  EXPECT_NE(line_of(out.output, "static@blocks", 1).find("| - / - |"), std::string::npos)
      << out.output;
}

TEST_F(Compare, FailedDisturbedAndUnmatchedRowsAreNotJudged) {
  const json a = synthetic(10, 1.0);
  json b = synthetic(10, 1.5);
  // Row 0 (static, 1 thread) failed verification, row 1 (static, 2) was disturbed, every
  // other row is the same as in A except the last, which B lacks; B has one row A lacks.
  for (std::size_t i = 2; i < b["rows"].size(); ++i) b["rows"][i] = a["rows"][i];
  b["rows"][0]["verification"]["passed"] = false;
  b["rows"][1]["disturbance"] = {{"disturbed", true},
                                 {"disturbed_runs", 1},
                                 {"runs", 10},
                                 {"reruns", 2},
                                 {"records", json::array()}};
  b["rows"].erase(b["rows"].size() - 1);
  json extra = a["rows"][0];
  extra["threads"] = 7;
  b["rows"].push_back(extra);
  b["scene"]["hash"] = "0123456789abcdef";
  const fs::path fa = write("a.json", a), fb = write("b.json", b);
  const Outcome out = compare(fa, fb, "--json " + quote((dir_ / "c.json").string()));
  EXPECT_EQ(out.exit_code, 0) << out.output;  // the slow rows are FAILED or DISTURBED
  const json c = clothbench_test::read_json(dir_ / "c.json");
  ASSERT_EQ(c["rows"].size(), 13u);
  EXPECT_EQ(c["rows"][0]["verdict"], "FAILED");
  EXPECT_TRUE(c["rows"][0]["ratio"].is_null());
  EXPECT_TRUE(c["rows"][0]["mann_whitney"].is_null());
  EXPECT_EQ(c["rows"][1]["verdict"], "DISTURBED");
  EXPECT_NEAR(c["rows"][1]["ratio"].get<double>(), 1.5, 1e-9);  // shown, not judged
  EXPECT_FALSE(c["rows"][1]["regression"].get<bool>());
  EXPECT_EQ(c["rows"][11]["verdict"], "only in A");
  EXPECT_EQ(c["rows"][12]["verdict"], "only in B");
  EXPECT_EQ(c["rows"][12]["threads"], 7);
  EXPECT_NE(line_of(out.output, "static@blocks", 1).find("FAILED verification in B"),
            std::string::npos)
      << out.output;
  EXPECT_NE(line_of(out.output, "static@blocks", 2).find("DISTURBED in B"), std::string::npos)
      << out.output;
  EXPECT_NE(out.output.find("warning: the documents are of different scenes"), std::string::npos)
      << out.output;
  EXPECT_EQ(c["warnings"].size(), 1u);
}

TEST_F(Compare, BadInputIsNamedAndExitsTwo) {
  const fs::path a = write("a.json", synthetic(10, 1.0));
  const fs::path missing = dir_ / "missing.json";
  Outcome out = compare(a, missing);
  EXPECT_EQ(out.exit_code, 2);
  EXPECT_NE(out.output.find(missing.string() + ": cannot read the file"), std::string::npos)
      << out.output;

  const fs::path text = dir_ / "text.json";
  std::ofstream(text) << "not json {";
  out = compare(text, a);
  EXPECT_EQ(out.exit_code, 2);
  EXPECT_NE(out.output.find(text.string() + ": not JSON"), std::string::npos) << out.output;

  const fs::path other = write("other.json", json{{"schema", "clothbench.stress"}});
  out = compare(a, other);
  EXPECT_EQ(out.exit_code, 2);
  EXPECT_NE(out.output.find(other.string() + ": not a clothbench sweep document"),
            std::string::npos)
      << out.output;

  out = compare(a, a, "--threshold -0.1");
  EXPECT_EQ(out.exit_code, 2);
  EXPECT_NE(out.output.find("--threshold: must be a finite number >= 0"), std::string::npos)
      << out.output;
  out = compare(a, a, "--alpha 1.5");
  EXPECT_EQ(out.exit_code, 2);
  EXPECT_NE(out.output.find("--alpha: must be between 0 and 1"), std::string::npos) << out.output;
}

}  // namespace
