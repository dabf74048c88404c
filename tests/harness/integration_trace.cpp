// Per-chunk traces (issue 17): on a 17 x 17 sheet with AMRC over a box, 3 steps, at 1 and 2
// threads, for the OpenMP clauses (static, dynamic:2, guided:1), our own counters (fac2, tss,
// gss), taskloop and the Active-Lists (and a dynamic clause over the lists, whose ranges are
// widened to whole tiles and may come out empty):
//  - the ranges of every loop instance tile [0, n) without overlap (every iteration in
//    exactly one chunk), thread ids are below the team size, chunk times lie within their
//    loop's span, and the chunks of one thread do not overlap in time;
//  - every schedule runs the same loop sequence (sites, steps, iterations) and visits the
//    same elements in each loop instance (over the lists: n itself); every non-empty loop
//    instance records the bytes per element its call declares (> 0), the same in every run;
//  - tracing changes no result: the final state's digest equals the untraced run's;
//  - the file round-trips (write_trace, read_trace), the timeline stays under its bar cap;
//  - `clothbench run --trace` writes the file (header with machine, scheduler, threads, cost)
//    and a bad --trace-step is refused naming the flag, exit 2; `sweep --trace DIR` writes one
//    trace per row, whose final state equals the sweep's reference.
// No timing is asserted.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include "harness/run/verify.hpp"
#include "harness/scene/scene.hpp"
#include "harness/trace/trace_file.hpp"
#include "harness/trace/trace_timeline.hpp"
#include "kernels/simulation.hpp"
#include "schedulers/registry.hpp"
#include "tests/harness/adaptive_sheet_scene.hpp"
#include "tests/harness/clothbench_process.hpp"

namespace clothbench {
namespace {

namespace fs = std::filesystem;
using clothbench_test::adaptive_sheet_on_box;
using ::testing::HasSubstr;

constexpr int kSteps = 3;

/// One run: the final state's digest and, when traced, the trace as the file holds it.
struct Traced {
  std::string digest;
  harness::TraceDocument trace;
};

Traced simulate(const std::string& scheduler, int threads, bool traced) {
  omp_set_num_threads(threads);
  kernels::Simulation simulation(adaptive_sheet_on_box());
  const auto driver = schedulers::make_driver(scheduler);
  kernels::ChunkTrace trace;
  trace.start(threads, 64);  // small: the buffers must grow at loop entry
  kernels::LoopTimes times;  // the chunk timing shares the trace's clock reads
  times.resize(threads);
  for (int k = 0; k < kSteps; ++k) {
    simulation.step(*driver, kernels::Instrumentation::chunks, &times, traced ? &trace : nullptr);
  }
  Traced out;
  out.digest = harness::fnv1a64_hex(harness::state_bytes(simulation));
  if (traced) out.trace = harness::collect_trace(trace, {{"scheduler", scheduler}}, 0.0, 0.0);
  return out;
}

/// The untraced reference (every schedule and thread count gives the same bits).
const std::string& reference_digest() {
  static const std::string digest = simulate("static", 1, false).digest;
  return digest;
}

/// The loop sequence of the first traced run: every other run must match it.
const harness::TraceDocument& first_trace() {
  static const harness::TraceDocument trace = simulate("static", 1, true).trace;
  return trace;
}

/// Elements visited per loop instance.
std::vector<std::int64_t> elements_per_loop(const harness::TraceDocument& t) {
  std::vector<std::int64_t> sum(t.loops.size(), 0);
  for (const auto& c : t.chunks) sum.at(c.instance) += c.elements;
  return sum;
}

struct Case {
  std::string scheduler;
  int threads;
};

void PrintTo(const Case& c, std::ostream* os) { *os << c.scheduler << " x " << c.threads; }

class TraceTest : public ::testing::TestWithParam<Case> {};

TEST_P(TraceTest, ChunksTileEveryLoopAndChangeNoResult) {
  const Case& param = GetParam();
  const Traced run = simulate(param.scheduler, param.threads, true);
  EXPECT_EQ(run.digest, reference_digest()) << "tracing or the schedule changed the result";
  const auto& loops = run.trace.loops;
  const auto& chunks = run.trace.chunks;
  ASSERT_FALSE(loops.empty());
  ASSERT_EQ(run.trace.header["chunk_count"].get<std::size_t>(), chunks.size());

  // Loops are numbered 0, 1, ... in order; chunks come sorted by (instance, begin).
  std::size_t next = 0;  // first chunk of the current loop
  for (std::size_t i = 0; i < loops.size(); ++i) {
    const kernels::LoopRecord& loop = loops[i];
    ASSERT_EQ(loop.instance, i);
    ASSERT_LE(loop.entry_ns, loop.exit_ns);
    std::int64_t covered = 0;  // [0, covered) tiled so far
    for (; next < chunks.size() && chunks[next].instance == i; ++next) {
      const kernels::ChunkRecord& c = chunks[next];
      ASSERT_EQ(c.begin, covered) << "loop " << i << ": gap or overlap at " << covered;
      ASSERT_LT(c.begin, c.end) << "loop " << i << ": empty range";
      covered = c.end;
      ASSERT_GE(c.thread, 0);
      ASSERT_LT(c.thread, param.threads);
      ASSERT_LE(loop.entry_ns, c.start_ns) << "loop " << i;
      ASSERT_LE(c.start_ns, c.end_ns) << "loop " << i;
      ASSERT_LE(c.end_ns, loop.exit_ns) << "loop " << i;
      ASSERT_GE(c.elements, 0);
    }
    ASSERT_EQ(covered, loop.n) << "loop " << i << " (site " << loop.site << ") not covered";
  }
  ASSERT_EQ(next, chunks.size()) << "chunks of no loop";

  // One thread runs one chunk at a time.
  std::vector<kernels::ChunkRecord> by_thread = chunks;
  std::sort(by_thread.begin(), by_thread.end(), [](const auto& a, const auto& b) {
    return a.thread != b.thread ? a.thread < b.thread : a.start_ns < b.start_ns;
  });
  for (std::size_t k = 1; k < by_thread.size(); ++k) {
    if (by_thread[k].thread != by_thread[k - 1].thread) continue;
    ASSERT_GE(by_thread[k].start_ns, by_thread[k - 1].end_ns) << "thread " << by_thread[k].thread;
  }

  // Same loops (site names, steps, iterations) and the same elements as the reference run.
  const harness::TraceDocument& first = first_trace();
  ASSERT_EQ(loops.size(), first.loops.size());
  const auto sum = elements_per_loop(run.trace);
  const auto first_sum = elements_per_loop(first);
  const bool lists = param.scheduler.find("active") != std::string::npos;
  for (std::size_t i = 0; i < loops.size(); ++i) {
    const auto& site = run.trace.header["sites"][static_cast<std::size_t>(loops[i].site)];
    const auto& first_site = first.header["sites"][static_cast<std::size_t>(first.loops[i].site)];
    ASSERT_EQ(site["name"], first_site["name"]) << "loop " << i;
    ASSERT_EQ(loops[i].step, first.loops[i].step) << "loop " << i;
    ASSERT_EQ(loops[i].iteration, first.loops[i].iteration) << "loop " << i;
    ASSERT_EQ(sum[i], first_sum[i]) << "loop " << i << " " << site["name"];
    ASSERT_TRUE(loops[i].bytes_per_element > 0.0 || loops[i].n == 0)
        << "loop " << i << " " << site["name"] << " declares no bytes per element";
    ASSERT_EQ(loops[i].bytes_per_element, first.loops[i].bytes_per_element)
        << "loop " << i << " " << site["name"];
    if (lists && site["kind"] != "index") {
      ASSERT_EQ(sum[i], loops[i].n) << "loop " << i;
    }
  }
  EXPECT_EQ(loops.back().step, kSteps);
}

INSTANTIATE_TEST_SUITE_P(
    Schedulers, TraceTest,
    ::testing::Values(Case{"static", 1}, Case{"static", 2}, Case{"dynamic:2", 1},
                      Case{"dynamic:2", 2}, Case{"guided:1", 2}, Case{"fac2", 2}, Case{"tss", 2},
                      Case{"gss", 2}, Case{"taskloop:2", 2}, Case{"active-lists", 1},
                      Case{"active-lists", 2}, Case{"dynamic:3@active", 2}),
    [](const auto& info) {
      std::string name = info.param.scheduler + "_" + std::to_string(info.param.threads);
      for (char& ch : name) {
        if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
      }
      return name;
    });

TEST(Trace, FileRoundTripsAndTimelineIsBounded) {
  const harness::TraceDocument& trace = first_trace();
  const fs::path dir = clothbench_test::fresh_dir("trace_round_trip");
  harness::write_trace(dir / "t.cbtrace", trace);
  const harness::TraceDocument back = harness::read_trace(dir / "t.cbtrace");
  EXPECT_EQ(back.header, trace.header);
  ASSERT_EQ(back.loops.size(), trace.loops.size());
  ASSERT_EQ(back.chunks.size(), trace.chunks.size());
  EXPECT_EQ(std::memcmp(back.chunks.data(), trace.chunks.data(),
                        trace.chunks.size() * sizeof(kernels::ChunkRecord)),
            0);
  EXPECT_EQ(std::memcmp(back.loops.data(), trace.loops.data(),
                        trace.loops.size() * sizeof(kernels::LoopRecord)),
            0);
  // A cut file is refused, naming it.
  fs::resize_file(dir / "t.cbtrace", fs::file_size(dir / "t.cbtrace") - 1);
  EXPECT_THROW(
      {
        try {
          harness::read_trace(dir / "t.cbtrace");
        } catch (const std::runtime_error& e) {
          EXPECT_THAT(e.what(), HasSubstr("t.cbtrace"));
          throw;
        }
      },
      std::runtime_error);

  const int step = harness::default_timeline_step(trace);
  EXPECT_GE(step, 1);
  const auto bars = harness::timeline_bars(trace, step, 40);
  EXPECT_LE(bars.size(), 40u);
  EXPECT_FALSE(bars.empty());
  fs::remove_all(dir);
}

TEST(Trace, RunWritesTheTraceAndRefusesABadStep) {
  const fs::path scene = fs::path(CLOTHBENCH_SOURCE_DIR) / "tests/data/scenes/sweep-tiny.toml";
  const fs::path dir = clothbench_test::fresh_dir("trace_run");
  const fs::path file = dir / "tiny.cbtrace";
  const auto ok = clothbench_test::run(
      "run " + clothbench_test::quote(scene.string()) + " --steps 1 --scheduler dynamic:2 " +
      "--quiet --no-vtk --out " + clothbench_test::quote(dir.string()) + " --trace " +
      clothbench_test::quote(file.string()));
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_THAT(ok.output, HasSubstr("chunks"));
  const harness::TraceDocument trace = harness::read_trace(file);
  EXPECT_EQ(trace.header["scheduler"], "dynamic:2@blocks");
  EXPECT_TRUE(trace.header["machine"].contains("cpu"));
  EXPECT_GT(trace.header["cost"]["record_seconds"].get<double>(), 0.0);
  EXPECT_FALSE(trace.chunks.empty());
  if (harness::gnuplot_available()) {
    EXPECT_TRUE(fs::exists(dir / "tiny-timeline.png"));
  }

  const auto bad = clothbench_test::run("run " + clothbench_test::quote(scene.string()) +
                                        " --steps 1 --quiet --no-vtk --trace-step 5 --trace " +
                                        clothbench_test::quote(file.string()));
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_THAT(bad.output, HasSubstr("--trace-step"));
  fs::remove_all(dir);
}

TEST(Trace, SweepTracesOneExtraRunPerRow) {
  const fs::path scene = fs::path(CLOTHBENCH_SOURCE_DIR) / "tests/data/scenes/sweep-tiny.toml";
  const fs::path dir = clothbench_test::fresh_dir("trace_sweep");
  const auto ok = clothbench_test::run(
      "sweep " + clothbench_test::quote(scene.string()) +
      " --schedulers static,active-lists --threads 1 --steps 1 --repeat 1 --retries 0 "
      "--warmup-steps 0 --instrument off --no-plots --quiet --out " +
      clothbench_test::quote((dir / "out").string()) + " --trace " +
      clothbench_test::quote((dir / "traces").string()));
  ASSERT_EQ(ok.exit_code, 0) << ok.output;
  for (const char* name : {"static_blocks-1t.cbtrace", "active-lists_active-1t.cbtrace"}) {
    const harness::TraceDocument trace = harness::read_trace(dir / "traces" / name);
    EXPECT_TRUE(trace.header["bit_identical_to_reference"].get<bool>()) << name;
    EXPECT_EQ(trace.header["threads"], 1) << name;
    EXPECT_FALSE(trace.chunks.empty()) << name;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace clothbench
