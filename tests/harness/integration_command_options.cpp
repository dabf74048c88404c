// README features of the command line that no other test runs, each through the real binary on
// the tiny sweep scene (tests/data/scenes/sweep-tiny.toml, 2 steps: seconds per test):
//  - `sweep --bind core`: every thread of a row is pinned to its own core, and the settings,
//    the rows' binding records and table.md say so; `--bind none` leaves every thread on the
//    same (whole) set; a bad value is refused naming --bind;
//  - `sweep --instrument chunks`: the overhead columns are filled and chunks are counted (finer
//    schedules hand out more); `--instrument off`: no accounting, empty overhead columns in
//    table.md and table.csv, and no overhead figure;
//  - the sweep's figures (fig12.png, overhead.png, cloth.png) are PNG files of the sizes the
//    plot scripts set, with real content (when gnuplot is installed; under CI=true it must be);
//  - `run --gradient numeric` reaches the kernel (header, summary.json, a result near but not
//    bitwise the analytic one) and a bad value is refused naming --gradient;
//  - `run --newton-log FILE` writes one CSV row per Newton iteration of every step (as many as
//    summary.json counts, each step's residuals chained from one iteration to the next) and
//    is refused, naming the flag, under nonlinear CG;
//  - `experiment time-error --scene FILE` runs on that scene (its path, size and step count in
//    time_error.json; tests/data/scenes/time-error-tiny.toml), and the other experiments refuse
//    --scene.
// No timing is asserted.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "harness/report/sweep_plots.hpp"
#include "kernels/simulation_config.hpp"
#include "kernels/vcycle_preconditioner.hpp"
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
using testing::HasSubstr;

const fs::path kScene = fs::path(CLOTHBENCH_SOURCE_DIR) / "tests/data/scenes/sweep-tiny.toml";
const fs::path kTimeErrorScene =
    fs::path(CLOTHBENCH_SOURCE_DIR) / "tests/data/scenes/time-error-tiny.toml";

/// A sweep of the tiny scene over 2 steps, one run per row, no warm-up, with `options`.
Outcome tiny_sweep(const fs::path& out, const std::string& options) {
  return run("sweep " + quote(kScene.string()) +
             " --steps 2 --repeat 1 --retries 0 --warmup-steps 0 --quiet --out " + quote(out.string()) + " " +
             options);
}

/// Thread counts of the sweeps: 1 and 2 where the machine has two hardware threads.
int two_or_fewer() { return std::min(2, clothbench_test::hardware_threads()); }

std::string thread_list() { return two_or_fewer() > 1 ? "1,2" : "1"; }

/// Removes a test's output directory when the test ends (also when it is skipped).
struct RemoveAtExit {
  fs::path dir;
  ~RemoveAtExit() { fs::remove_all(dir); }
};

/// Without gnuplot the figures are not checked: the test is skipped, or fails under CI=true
/// (scripts/setup installs gnuplot, so CI must check them).
#define SKIP_WITHOUT_GNUPLOT()                                                                   \
  do {                                                                                           \
    if (!clothbench::harness::gnuplot_available()) {                                             \
      const char* ci = std::getenv("CI");                                                        \
      if (ci != nullptr && std::string(ci) == "true") FAIL() << "gnuplot missing under CI=true"; \
      GTEST_SKIP() << "gnuplot is not installed: no figures to check";                           \
    }                                                                                            \
  } while (false)

struct PngHeader {
  bool signature = false;  ///< the 8-byte PNG signature, then an IHDR chunk
  std::uint32_t width = 0, height = 0;
};

std::uint32_t big_endian(const unsigned char* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}

/// The signature and IHDR size of a PNG file (all false / 0 when it is not one).
PngHeader read_png_header(const fs::path& file) {
  unsigned char bytes[24] = {};
  std::ifstream in(file, std::ios::binary);
  in.read(reinterpret_cast<char*>(bytes), sizeof bytes);
  PngHeader h;
  const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (in.gcount() != sizeof bytes || !std::equal(signature, signature + 8, bytes) ||
      std::string(reinterpret_cast<const char*>(bytes + 12), 4) != "IHDR") {
    return h;
  }
  h.signature = true;
  h.width = big_endian(bytes + 16);
  h.height = big_endian(bytes + 20);
  return h;
}

/// `name` in `dir` is a PNG of width x height with real content: a pngcairo image of that size
/// holding only axes and titles is 6-13 kB (measured with gnuplot 5.4); these figures are
/// 30-100 kB.
/// With `output` (the sweep's, not --quiet), the sweep also said it wrote the file.
void expect_figure(const fs::path& dir, const std::string& name, std::uint32_t width,
                   std::uint32_t height, const std::string& output) {
  const fs::path file = dir / name;
  ASSERT_TRUE(fs::exists(file)) << name << " missing\n" << output;
  const PngHeader h = read_png_header(file);
  EXPECT_TRUE(h.signature) << name << " is not a PNG file";
  EXPECT_EQ(h.width, width) << name;
  EXPECT_EQ(h.height, height) << name;
  EXPECT_GT(fs::file_size(file), 20'000u) << name << ": too small for a drawn figure";
  if (!output.empty()) {
    EXPECT_THAT(output, HasSubstr("  wrote " + file.string() + "\n"));
  }
}

class CommandOptions : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(clothbench_test::binary()))
        << "clothbench binary not built: " << clothbench_test::binary();
  }
};

TEST_F(CommandOptions, SweepBindCorePinsEachThreadToItsOwnCoreAndRecordsIt) {
  const fs::path out = fresh_dir("bind-core");
  const Outcome o = run("sweep " + quote(kScene.string()) +
                        " --steps 2 --repeat 1 --retries 0 --warmup-steps 0 --no-plots --schedulers static "
                        "--instrument off --bind core --threads " +
                        thread_list() + " --out " + quote(out.string()));
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_THAT(o.output, HasSubstr(", bind core\n"));
  const json d = read_json(out / "sweep.json");
  EXPECT_EQ(d["settings"]["bind"], "core");
  EXPECT_THAT(read_text(out / "table.md"), HasSubstr("binding `core`"));
  ASSERT_EQ(d["rows"].size(), static_cast<std::size_t>(two_or_fewer()));
  for (const json& row : d["rows"]) {
    const json& b = row["binding"];
    EXPECT_EQ(b["mode"], "core") << b.dump();
    EXPECT_TRUE(b["bound"].get<bool>()) << "hwloc could not bind: " << b.dump();
    ASSERT_EQ(b["threads"].size(), row["threads"].get<std::size_t>()) << b.dump();
    std::set<std::string> cpusets;
    for (const json& t : b["threads"]) {
      EXPECT_FALSE(t["cpuset"].get<std::string>().empty()) << b.dump();
      cpusets.insert(t["cpuset"].get<std::string>());
    }
    EXPECT_EQ(cpusets.size(), b["threads"].size()) << "threads share a core: " << b.dump();
    // Thread 0 is on core 0 whatever the team size.
    EXPECT_EQ(b["threads"][0]["cpuset"], d["rows"][0]["binding"]["threads"][0]["cpuset"]);
  }
  fs::remove_all(out);
}

TEST_F(CommandOptions, SweepRefusesABadBindValueNamingTheFlag) {
  const fs::path out = fresh_dir("bind-bad");
  const Outcome o = tiny_sweep(out, "--no-plots --schedulers static --threads 1 --bind socket");
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_THAT(o.output, HasSubstr("--bind"));
  EXPECT_THAT(o.output, HasSubstr("socket"));
  EXPECT_FALSE(fs::exists(out / "sweep.json"));
  fs::remove_all(out);
}

TEST_F(CommandOptions, SweepInstrumentChunksFillsTheOverheadColumnsAndCountsChunks) {
  const fs::path out = fresh_dir("instrument-chunks");
  const Outcome o = tiny_sweep(out,
                               "--no-plots --schedulers static,dynamic:2 --instrument chunks "
                               "--threads " +
                                   thread_list());
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const json d = read_json(out / "sweep.json");
  EXPECT_EQ(d["settings"]["instrument"], "chunks");
  ASSERT_EQ(d["rows"].size(), 2u * static_cast<std::size_t>(two_or_fewer()));
  std::vector<std::int64_t> static_chunks, dynamic_chunks;
  for (const json& row : d["rows"]) {
    const std::string where = row["scheduler_canonical"].get<std::string>() + " x " +
                              std::to_string(row["threads"].get<int>());
    EXPECT_EQ(row["instrumented"]["level"], "chunks") << where;
    EXPECT_TRUE(row["instrumented"]["time_seconds"].is_object()) << where;
    const json& a = row["accounting"];
    ASSERT_TRUE(a.is_object()) << where;
    for (const char* k : {"sequential_overhead_seconds", "parallel_overhead_seconds",
                          "load_imbalance_seconds", "parallel_work_seconds"}) {
      EXPECT_TRUE(a[k].is_number()) << where << " " << k;
    }
    const auto loops = a["loops"].get<std::int64_t>(), chunks = a["chunks"].get<std::int64_t>();
    EXPECT_GT(loops, 0) << where;
    EXPECT_GE(chunks, loops) << where << ": every loop hands out at least one chunk";
    (row["scheduler_canonical"] == "static@blocks" ? static_chunks : dynamic_chunks)
        .push_back(chunks);
  }
  // 16 blocks per loop: dynamic:2 hands out 8 chunks of a full loop, static one per thread.
  ASSERT_EQ(static_chunks.size(), dynamic_chunks.size());
  for (std::size_t k = 0; k < static_chunks.size(); ++k) {
    EXPECT_GT(dynamic_chunks[k], 2 * static_chunks[k]);
  }
  // Filled columns: no "-" in the overhead columns of table.md, numbers in table.csv.
  const std::string md = read_text(out / "table.md");
  EXPECT_THAT(md, HasSubstr("instrumentation `chunks`"));
  EXPECT_THAT(md, testing::Not(HasSubstr("| - | - | - | - |")));
  EXPECT_THAT(read_text(out / "table.csv"),
              testing::ContainsRegex("\nstatic,static@blocks,1,false,[-0-9.e]+,[-0-9.e]+,[-0-9.e]+,"
                                     "[-0-9.e]+,[-0-9.e]+,[-0-9.e]+,[-0-9.e]+,"));
  fs::remove_all(out);
}

TEST_F(CommandOptions, SweepInstrumentOffLeavesTheOverheadColumnsEmptyAndDrawsNoOverheadFigure) {
  const fs::path out = fresh_dir("instrument-off");
  const int threads = two_or_fewer();
  const Outcome o = tiny_sweep(out, "--schedulers static --instrument off --threads " +
                                        std::to_string(threads));  // plots on, bind none
  ASSERT_EQ(o.exit_code, 0) << o.output;
  const json d = read_json(out / "sweep.json");
  EXPECT_EQ(d["settings"]["instrument"], "off");
  EXPECT_EQ(d["settings"]["bind"], "none");
  ASSERT_EQ(d["rows"].size(), 1u);
  const json& row = d["rows"][0];
  EXPECT_TRUE(row["accounting"].is_null()) << row["accounting"].dump();
  EXPECT_EQ(row["instrumented"]["level"], "off");
  EXPECT_TRUE(row["instrumented"]["time_seconds"].is_null());
  EXPECT_TRUE(row["verification"]["passed"].get<bool>());
  // Unbound: every thread may run on the same (whole) set of PUs.
  const json& b = row["binding"];
  EXPECT_EQ(b["mode"], "none");
  EXPECT_FALSE(b["bound"].get<bool>());
  ASSERT_EQ(b["threads"].size(), static_cast<std::size_t>(threads));
  for (const json& t : b["threads"]) EXPECT_EQ(t["cpuset"], b["threads"][0]["cpuset"]) << b.dump();
  // Empty overhead columns: "-" in table.md, nothing between the commas in table.csv.
  EXPECT_THAT(
      read_text(out / "table.md"),
      testing::ContainsRegex("\n\\| " + std::to_string(threads) + " \\| - \\| - \\| - \\| - \\| "));
  EXPECT_THAT(read_text(out / "table.csv"),
              testing::ContainsRegex("\nstatic,static@blocks," + std::to_string(threads) +
                                     ",false,[-0-9.e]+,[-0-9.e]+,[-0-9.e]+,,,,,,,,off,"));
  const RemoveAtExit remove{out};
  SKIP_WITHOUT_GNUPLOT();
  EXPECT_FALSE(fs::exists(out / "overhead.png")) << "no accounting, no overhead figure";
  EXPECT_FALSE(fs::exists(out / "overhead.dat"));
  expect_figure(out, "fig12.png", 1400, 580, "");
}

TEST_F(CommandOptions, SweepFiguresArePngsOfTheirSizesWithContent) {
  const fs::path out = fresh_dir("figures");
  // Not --quiet: the sweep lists the figures it wrote.
  const RemoveAtExit remove{out};
  const Outcome o = run("sweep " + quote(kScene.string()) +
                        " --steps 2 --repeat 1 --retries 0 --warmup-steps 0 --schedulers static,dynamic:2 "
                        "--threads " +
                        thread_list() + " --out " + quote(out.string()));
  ASSERT_EQ(o.exit_code, 0) << o.output;
  SKIP_WITHOUT_GNUPLOT();
  EXPECT_THAT(o.output, testing::Not(HasSubstr("gnuplot failed"))) << o.output;
  expect_figure(out, "fig12.png", 1400, 580, o.output);
  expect_figure(out, "overhead.png", 1500, 650, o.output);
  expect_figure(out, "cloth.png", 1100, 850, o.output);
}

/// summary.json of a 2-step run of the tiny scene with `options`.
json tiny_run(const fs::path& out, const std::string& options, Outcome& o) {
  o = run("run " + quote(kScene.string()) + " --steps 2 --no-vtk --out " + quote(out.string()) +
              " " + options,
          "OMP_NUM_THREADS=1");
  if (o.exit_code != 0) return json();
  return read_json(out / "sweep-tiny" / "summary.json");
}

TEST_F(CommandOptions, RunSummaryRecordsTheMinimisersSettingsWithDefaultsResolved) {
  Outcome newton_run, cg_run;
  const json newton = tiny_run(fresh_dir("settings-newton"), "", newton_run);
  const json cg = tiny_run(fresh_dir("settings-cg"), "--method nonlinear-cg", cg_run);
  ASSERT_EQ(newton_run.exit_code, 0) << newton_run.output;
  ASSERT_EQ(cg_run.exit_code, 0) << cg_run.output;
  // The scene names only nonlinear CG's cap (20); the rest are this revision's defaults.
  const json& n = newton["solver"]["settings"];
  EXPECT_EQ(newton["solver"]["preconditioner"], "v-cycle") << newton["solver"].dump();
  EXPECT_EQ(n["vcycle_after"], clothbench::kernels::kDefaultVcycleAfter) << n.dump();
  EXPECT_EQ(n["smoothing_sweeps"], clothbench::kernels::kDefaultSmoothingSweeps);
  EXPECT_EQ(n["model_refinements"], clothbench::kernels::kDefaultModelRefinements);
  EXPECT_EQ(n["coarsest_nodes"], clothbench::kernels::VcyclePreconditioner::kCoarsestNodes);
  EXPECT_FALSE(n.contains("max_iterations"));
  const json& c = cg["solver"]["settings"];
  EXPECT_EQ(c["max_iterations"], 20) << c.dump();
  EXPECT_FALSE(c.contains("vcycle_after"));
  EXPECT_FALSE(c.contains("smoothing_sweeps"));
  EXPECT_EQ(c["tolerance"], n["tolerance"]);
}

TEST_F(CommandOptions, RunNewtonLogWritesEveryNewtonIterationOfEveryStep) {
  const fs::path out = fresh_dir("newton-log");
  const fs::path log = out / "logs" / "newton.csv";  // its directory is made
  Outcome o;
  const json summary = tiny_run(out, "--newton-log " + quote(log.string()), o);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_THAT(o.output, HasSubstr("wrote " + log.string()));
  std::ifstream in(log);
  std::string line;
  ASSERT_TRUE(std::getline(in, line)) << "empty " << log;
  EXPECT_EQ(line,
            "step,attempt,dt_s,iteration,rms,forcing,linear_iterations,linear_relative_residual,"
            "refinements,alpha,line_search_evaluations,rms_after_line_search,"
            "smoothed_particles,rms_after,edges_slack,edges_loading,edges_plateau,"
            "edges_unloading,edges_changed");
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line)) {
    std::vector<double> fields;
    std::stringstream cells(line);
    std::string cell;
    while (std::getline(cells, cell, ',')) fields.push_back(std::stod(cell));
    ASSERT_EQ(fields.size(), 19u) << line;
    for (const double f : fields) EXPECT_TRUE(std::isfinite(f)) << line;
    rows.push_back(fields);
  }
  // As many rows as Newton iterations, per step; each step's iterations numbered from 0 and
  // chained: an iteration starts from where the one before it ended.
  ASSERT_EQ(summary["steps"].size(), 2u);
  std::size_t row = 0;
  for (const json& step : summary["steps"]) {
    const int iterations = step["iterations"];
    EXPECT_GT(iterations, 0) << step.dump();
    int linear = 0;
    for (int k = 0; k < iterations; ++k, ++row) {
      ASSERT_LT(row, rows.size());
      const std::vector<double>& r = rows[row];
      EXPECT_EQ(r[0], step["step"].get<double>());
      EXPECT_EQ(r[1], 0.0) << "no step of this scene is halved";
      EXPECT_EQ(r[2], 0.01) << "the scene's step";
      EXPECT_EQ(r[3], k);
      EXPECT_GT(r[9], 0.0) << "alpha";
      EXPECT_LE(r[9], 1.0) << "alpha";
      EXPECT_GE(r[10], 1.0) << "line-search evaluations";
      if (k > 0) {
        EXPECT_EQ(r[4], rows[row - 1][13]) << "row " << row;
      }
      // Every active edge on one branch (the tiny cloth keeps its 2 x 21 x 20 edges), and
      // no more changes than edges.
      EXPECT_EQ(r[14] + r[15] + r[16] + r[17], 2.0 * 21 * 20) << "row " << row;
      EXPECT_LE(r[18], 2.0 * 21 * 20) << "row " << row;
      linear += static_cast<int>(r[6]);
    }
    EXPECT_EQ(linear, step["linear_iterations"].get<int>()) << step.dump();
    EXPECT_LE(rows[row - 1][13], summary["solver"]["settings"]["tolerance"].get<double>())
        << "the last iteration ends converged";
  }
  EXPECT_EQ(row, rows.size());
}

TEST_F(CommandOptions, RunSummaryRecordsEachStepsResidentMemory) {
  Outcome o;
  const json summary = tiny_run(fresh_dir("step-memory"), "", o);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  ASSERT_EQ(summary["steps"].size(), 2u);
  constexpr std::uint64_t kCounterSlack = 1u << 20;
  std::uint64_t peak_before = 0;
  for (const json& step : summary["steps"]) {
    // This machine has /proc: every figure is known. The high-water mark is at least the
    // resident set of the same reading and does not fall (up to the kernel's per-CPU counters,
    // which are approximate by a few hundred KiB); the simulation holds at least its cloth's
    // positions (21 x 21 particles, 3 doubles each).
    ASSERT_TRUE(step["resident_bytes"].is_number_unsigned()) << step.dump();
    ASSERT_TRUE(step["peak_resident_bytes"].is_number_unsigned()) << step.dump();
    const auto resident = step["resident_bytes"].get<std::uint64_t>();
    const auto peak = step["peak_resident_bytes"].get<std::uint64_t>();
    EXPECT_GT(resident, 0u) << step.dump();
    EXPECT_GE(peak, resident) << step.dump();
    EXPECT_GE(peak + kCounterSlack, peak_before) << step.dump();
    EXPECT_GE(step["simulation_bytes"].get<std::uint64_t>(), 21u * 21u * 3u * 8u) << step.dump();
    // The parts add up to the whole; the state and the mesh are never empty.
    const json& parts = step["simulation_bytes_by_part"];
    std::uint64_t sum = 0;
    for (const char* part : {"mesh", "state", "lists", "amrc", "solver", "vcycle"}) {
      ASSERT_TRUE(parts[part].is_number_unsigned()) << part << ": " << step.dump();
      sum += parts[part].get<std::uint64_t>();
    }
    EXPECT_EQ(sum, step["simulation_bytes"].get<std::uint64_t>()) << step.dump();
    EXPECT_GE(parts["state"].get<std::uint64_t>(), 21u * 21u * 3u * 8u) << step.dump();
    EXPECT_GT(parts["mesh"].get<std::uint64_t>(), 0u) << step.dump();
    peak_before = peak;
  }
  // The run's peak is taken after its last step.
  EXPECT_GE(summary["memory"]["peak_resident_bytes"].get<std::uint64_t>() + kCounterSlack,
            peak_before);
}

TEST_F(CommandOptions, RunNewtonLogIsRefusedUnderNonlinearCg) {
  const fs::path out = fresh_dir("newton-log-cg");
  Outcome o;
  tiny_run(out, "--method nonlinear-cg --newton-log " + quote((out / "n.csv").string()), o);
  EXPECT_EQ(o.exit_code, 2) << o.output;
  EXPECT_THAT(o.output, HasSubstr("--newton-log"));
  EXPECT_THAT(o.output, HasSubstr("nonlinear-cg"));
  EXPECT_FALSE(fs::exists(out / "n.csv"));
}

TEST_F(CommandOptions, RunGradientNumericReachesTheKernel) {
  const fs::path numeric_out = fresh_dir("gradient-numeric"),
                 analytic_out = fresh_dir("gradient-analytic");
  Outcome numeric_run, analytic_run;
  // Nonlinear CG stops near its tolerance, where both gradients' residuals are comparable
  // (Newton's end at rounding level on this scene).
  const json numeric = tiny_run(numeric_out, "--method nonlinear-cg --gradient numeric", numeric_run);
  const json analytic = tiny_run(analytic_out, "--method nonlinear-cg", analytic_run);
  ASSERT_EQ(numeric_run.exit_code, 0) << numeric_run.output;
  ASSERT_EQ(analytic_run.exit_code, 0) << analytic_run.output;
  EXPECT_THAT(numeric_run.output, HasSubstr(", gradient numeric,"));
  EXPECT_THAT(analytic_run.output, HasSubstr(", gradient analytic,"));
  EXPECT_THAT(numeric_run.output, HasSubstr("\nVerification: PASSED"));
  EXPECT_EQ(numeric["solver"]["gradient"], "numeric") << numeric["solver"].dump();
  EXPECT_EQ(analytic["solver"]["gradient"], "analytic") << analytic["solver"].dump();
  EXPECT_TRUE(numeric["verification"]["passed"].get<bool>());
  // Finite differences are not the analytic gradient bit for bit, but the same physics: each
  // step's residual differs in its last digits and agrees to 1 %.
  ASSERT_EQ(numeric["steps"].size(), 2u);
  ASSERT_EQ(analytic["steps"].size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    const double n = numeric["steps"][k]["residual_rms"], a = analytic["steps"][k]["residual_rms"];
    EXPECT_NE(n, a) << "step " << k + 1 << ": the numeric gradient was not used";
    EXPECT_NEAR(n, a, 0.01 * a) << "step " << k + 1;
  }
  const Outcome bad = run("run " + quote(kScene.string()) + " --steps 1 --no-vtk --gradient exact");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_THAT(bad.output, HasSubstr("--gradient"));
  fs::remove_all(numeric_out);
  fs::remove_all(analytic_out);
}

TEST_F(CommandOptions, RunWithTheTiltedPlateauVerifiesAndRecordsTheModel) {
  const fs::path out = fresh_dir("tilted-plateau");
  const RemoveAtExit remove{out};
  // The tiny scene with the opt-in tilted tension plateau added as a [fabric] override.
  std::ifstream in(kScene);
  std::stringstream text;
  text << in.rdbuf() << "\n[fabric]\ntension_plateau_slope = 1e-3\n";
  fs::create_directories(out);
  const fs::path scene = out / "tiny-tilted.toml";
  std::ofstream(scene) << text.str();
  const Outcome o = run("run " + quote(scene.string()) + " --steps 4 --no-vtk --out " +
                            quote((out / "runs").string()),
                        "OMP_NUM_THREADS=1");
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_THAT(o.output, HasSubstr("\nVerification: PASSED"));
  const json tilted = read_json(out / "runs" / "tiny-tilted" / "summary.json");
  EXPECT_EQ(tilted["model"]["tension_plateau_slope"], 1e-3) << tilted["model"].dump();
  EXPECT_TRUE(tilted["verification"]["passed"].get<bool>());
  Outcome flat_run;
  const json flat = tiny_run(out / "flat", "", flat_run);
  ASSERT_EQ(flat_run.exit_code, 0) << flat_run.output;
  EXPECT_EQ(flat["model"]["tension_plateau_slope"], 0.0) << flat["model"].dump();
  // A located error for a combination the kernel cannot run, before anything is written.
  const Outcome bad = run("run " + quote(scene.string()) + " --steps 1 --no-vtk --kernel vector --out " +
                          quote((out / "bad").string()));
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_THAT(bad.output, HasSubstr("tiny-tilted.toml: fabric.tension_plateau_slope: the vector "
                                    "element kernel implements the flat plateau"))
      << bad.output;
  EXPECT_FALSE(fs::exists(out / "bad"));
}

TEST_F(CommandOptions, ExperimentTimeErrorRunsOnTheGivenScene) {
  const fs::path out = fresh_dir("experiment-scene");
  // 9 x 9 particles, 3 steps (the tiny size's own base: 21 x 21, 40 steps). The scene's own
  // step count is used: no --steps.
  const Outcome o =
      run("experiment time-error --size tiny --threads 1 --quiet --no-plots --scene " +
          quote(kTimeErrorScene.string()) + " --out " + quote(out.string()));
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_THAT(o.output, HasSubstr("Verification: PASSED"));
  const fs::path dir = out / "time-error-tiny";
  const json d = read_json(dir / "time_error.json");
  EXPECT_EQ(fs::path(d["base_scene"].get<std::string>()), kTimeErrorScene);
  EXPECT_EQ(d["steps"], 3);
  EXPECT_EQ(d["base_particles"], 9);
  const json* base = nullptr;
  for (const json& r : d["runs"]) {
    if (r["label"] == "base") base = &r;
    EXPECT_TRUE(r["passed"].get<bool>()) << r.dump();
  }
  ASSERT_NE(base, nullptr);
  EXPECT_EQ(base->at("particles_start"), 9 * 9);
  EXPECT_THAT(read_text(dir / "time_error.md"), HasSubstr(kTimeErrorScene.string()));
  fs::remove_all(out);

  // The other experiments run their own scenes: --scene is refused, not ignored.
  const Outcome refused = run("experiment table1 --size tiny --quiet --no-plots --scene " +
                              quote(kTimeErrorScene.string()) + " --out " + quote(out.string()));
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_THAT(refused.output, HasSubstr("--scene"));
  EXPECT_FALSE(fs::exists(out / "table1-tiny"));
  fs::remove_all(out);
}

}  // namespace
