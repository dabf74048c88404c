// Scheduling overhead of every registered backend, by the method of EPCC schedbench.
//
// Test: a parallel region of P threads (P = 1, and P = omp_get_max_threads() when that is
// more: two results per scheduler, `scheduling_overhead/SPEC/threads:P`) runs `inner`
// consecutive loops of P x iterations_per_thread iterations through the driver, along the
// path the cloth kernel takes (kernels/loop_runner.hpp): one virtual for_range per loop, one
// RangeBody call per range the scheduler hands out, and the per-iteration work inlined inside
// the range. Every
// iteration is a delay (a floating-point chain) of about 100 ns. Reference: one thread runs the
// same range body over one thread's share, once per loop, with no scheduling. Both are measured
// in every outer repetition, one right after the other (so a repetition's pair shares the
// machine's state), and overhead per loop = (test - reference) / inner. The delay is calibrated
// by timing the reference itself at the length it is used, not by extrapolating a shorter run.
// Each Google Benchmark iteration is one outer repetition; the counters give the mean with
// mean +- 1.96 sigma, the median, the outlier count (overhead_statistics.hpp), and the
// overhead per chunk: per-loop overhead / (ranges the scheduler handed out per loop / P),
// where ranges are counted exactly in every test loop. OpenMP timing uses real time.
//
// scheduling_overhead_dynamic_k measures dynamic:1, 2 and 4 interleaved in every repetition and
// prints whether the per-loop overhead falls with k as the chunk count does (PASSED/FAILED, a
// run-time verdict with machine context, never asserted by a test; not judged when the run was
// disturbed). Every result says whether other work took the cores meanwhile (the sweep's
// criteria: preemptions, CPU share, load average) and whether it was oversubscribed.
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <exception>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include "harness/machine/machine_context.hpp"
#include "harness/micro/overhead_statistics.hpp"
#include "harness/micro/smoke.hpp"
#include "harness/run/core_round_trip.hpp"
#include "harness/run/disturbance.hpp"
#include "schedulers/loop_driver.hpp"
#include "schedulers/registry.hpp"

namespace {

using Clock = std::chrono::steady_clock;
using clothbench::schedulers::LoopDriver;
using clothbench::schedulers::RangeBody;

constexpr std::int64_t iterations_per_thread = 1024;  // loop length per thread
constexpr double delay_target_ns = 100.0;             // work of one iteration
constexpr double sample_target_seconds = 0.01;        // test time of one outer repetition
constexpr int outer_repetitions = 30;                 // samples (EPCC: >= 20)

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// How the delays of one thread relate. `chained`: all delays of one body form one dependency
// chain through `sum` and the chain's value is stored after every range, as element work that
// writes its results does, so neither the compiler nor the processor can overlap one delay with
// the next or with the next dispatch: each costs its full length whether iterations come one
// per range (dynamic:1) or all in one (the reference). `independent`: EPCC schedbench's own
// delay(): every iteration a chain of its own whose value only feeds a branch that is never
// taken, so the processor may run the next dispatch (and the next delay) while a delay's chain
// is still in flight: what EPCC's figures measure.
enum class DelayKind { chained, independent };

// The range body of test and reference: per iteration a delay (a chain of `length`
// floating-point additions), inlined as the kernel's element work is, and a count of the ranges.
template <DelayKind kind>
struct DelayRanges {
  std::int64_t length;
  double sum = 0.0;
  std::int64_t ranges = 0;
  std::int64_t negative = 0;  // never counts: it keeps the independent chains alive
  void operator()(std::int64_t begin, std::int64_t end) {
    if constexpr (kind == DelayKind::chained) {
      double accumulator = sum;
      for (std::int64_t i = begin; i < end; ++i) {
        for (std::int64_t j = 0; j < length; ++j) accumulator += static_cast<double>(j);
      }
      benchmark::DoNotOptimize(accumulator);
      sum = accumulator;
    } else {
      for (std::int64_t i = begin; i < end; ++i) {
        double accumulator = 0.0;
        for (std::int64_t j = 0; j < length; ++j) accumulator += static_cast<double>(j);
        if (accumulator < 0.0) ++negative;
      }
    }
    ++ranges;
  }
};

// Reference: `inner` loops of one thread's share through the same body, unscheduled (s).
template <DelayKind kind>
double reference_seconds(std::int64_t length, int inner) {
  DelayRanges<kind> body{length};
  const RangeBody range(body);
  const Clock::time_point start = Clock::now();
  for (int loop = 0; loop < inner; ++loop) range(0, iterations_per_thread);
  const double seconds = seconds_since(start);
  benchmark::DoNotOptimize(body.sum);
  benchmark::DoNotOptimize(body.negative);
  return seconds;
}

// One test: `inner` loops of P x iterations_per_thread through the driver.
struct TestTime {
  double seconds = 0.0;
  std::int64_t ranges = 0;  // body calls, summed over threads and loops
};

template <DelayKind kind>
TestTime test_time(LoopDriver& driver, int threads, std::int64_t length, int inner) {
  const std::int64_t n = iterations_per_thread * threads;
  std::int64_t ranges = 0;
  const Clock::time_point start = Clock::now();
#pragma omp parallel num_threads(threads) reduction(+ : ranges)
  {
    DelayRanges<kind> body{length};
    for (int loop = 0; loop < inner; ++loop) driver.for_range(n, body);
    ranges += body.ranges;
    benchmark::DoNotOptimize(body.sum);
    benchmark::DoNotOptimize(body.negative);
  }
  return {seconds_since(start), ranges};
}

// The delay length whose measured time per iteration, in the reference loop, is within 5% of
// `target_ns` (at most 8 refinements; else the last length tried), and that measured time.
struct Delay {
  std::int64_t length = 1;
  double nanoseconds = 0.0;
};

template <DelayKind kind>
Delay calibrate_delay(double target_ns) {
  Delay delay{64, 0.0};
  constexpr int loops = 10;
  for (int attempt = 0;; ++attempt) {
    double best = 1e30;
    for (int repeat = 0; repeat < 3; ++repeat) {
      best = std::min(best, reference_seconds<kind>(delay.length, loops));
    }
    delay.nanoseconds = best * 1e9 / (loops * static_cast<double>(iterations_per_thread));
    // The time returned is always the one measured at the length returned.
    if (std::abs(delay.nanoseconds - target_ns) < 0.05 * target_ns || attempt == 8) break;
    delay.length = std::max<std::int64_t>(
        1, std::llround(static_cast<double>(delay.length) * target_ns / delay.nanoseconds));
  }
  return delay;
}

// Loops per repetition: a test of about sample_target_seconds (one loop in a smoke run).
int inner_loops(const Delay& delay) {
  if (clothbench::micro::smoke()) return 1;
  const double loop_seconds = static_cast<double>(iterations_per_thread) * delay.nanoseconds * 1e-9;
  return std::max(1, static_cast<int>(std::lround(sample_target_seconds / loop_seconds)));
}

// " (OVERSUBSCRIBED: P threads on H hardware threads)" when P > H, else "".
std::string oversubscription_label(int threads) {
  const int hardware = clothbench::harness::hardware_threads();
  return threads > hardware ? fmt::format(" (OVERSUBSCRIBED: {} threads on {} hardware threads)",
                                          threads, hardware)
                            : std::string();
}

// Whether other work took the cores during the repetitions since `before` (the sweep's
// criteria, harness/run/disturbance.hpp): 1/0 in the counter `disturbed`, and the text
// " DISTURBED (reasons)" for the label when it did.
std::string disturbance_label(benchmark::State& state,
                              const clothbench::harness::ResourceSample& before, int threads) {
  namespace h = clothbench::harness;
  const h::Disturbance d = h::assess_disturbance(before, h::sample_resources(), threads,
                                                 h::hardware_threads(), h::omp_wait_policy());
  state.counters["disturbed"] = d.disturbed ? 1 : 0;
  state.counters["load_before"] = d.load_before;
  state.counters["load_after"] = d.load_after;
  if (!d.disturbed) return {};
  std::string text = " DISTURBED (";
  for (std::size_t i = 0; i < d.reasons.size(); ++i) text += (i > 0 ? "; " : "") + d.reasons[i];
  return text + ")";
}

// The median round trip (ns) of a cache line bounced between threads 0 and 1 of a 2-thread
// team (harness/run/core_round_trip.hpp), over 11 samples of 1000 round trips each (3 of 50 in
// a smoke run): machine context for the dispatch costs, which on this VM change from run to
// run (README, "Scheduling overhead"). 0 with fewer than 2 threads.
double core_round_trip_ns(int threads) {
  if (threads < 2) return 0.0;
  // A smoke run (tests, beside other tests on the same cores) bounces far less.
  return clothbench::harness::core_round_trip_ns(clothbench::micro::smoke() ? 50 : 1000,
                                                 clothbench::micro::smoke() ? 3 : 11);
}

// Samples of one driver: per-loop overhead (us) of every repetition, and its ranges per loop.
struct DriverSamples {
  std::vector<double> overhead_us;
  std::int64_t ranges_per_loop = 0;
  bool ranges_constant = true;  // every loop of every repetition had the same range count
  void add(const TestTime& test, double reference, int inner) {
    overhead_us.push_back((test.seconds - reference) / inner * 1e6);
    const std::int64_t per_loop = test.ranges / inner;
    if (test.ranges % inner != 0 || (ranges_per_loop != 0 && per_loop != ranges_per_loop)) {
      ranges_constant = false;
    }
    ranges_per_loop = std::max(ranges_per_loop, per_loop);
  }
};

// `threads`: the team size of the test (the reference always runs on one thread).
template <DelayKind kind>
void scheduling_overhead(benchmark::State& state, const std::string& spec, int threads) {
  std::unique_ptr<LoopDriver> driver;
  try {
    driver = clothbench::schedulers::make_driver(spec);
  } catch (const std::exception& error) {
    state.SkipWithError(error.what());
    return;
  }
  const Delay delay = calibrate_delay<kind>(delay_target_ns);
  const int inner = inner_loops(delay);
  DriverSamples samples;
  double reference_sum = 0.0;
  const double round_trip_before = core_round_trip_ns(threads);
  const clothbench::harness::ResourceSample before = clothbench::harness::sample_resources();
  for (auto _ : state) {
    const double reference = reference_seconds<kind>(delay.length, inner);
    samples.add(test_time<kind>(*driver, threads, delay.length, inner), reference, inner);
    reference_sum += reference;
  }
  const clothbench::micro::OverheadSummary s =
      clothbench::micro::summarize_overheads(samples.overhead_us);
  const std::int64_t chunks = std::max<std::int64_t>(1, samples.ranges_per_loop);
  const double per_chunk_ns = clothbench::micro::per_chunk_overhead(s.mean, chunks, threads) * 1e3;
  const double per_chunk_median_ns =
      clothbench::micro::per_chunk_overhead(s.median, chunks, threads) * 1e3;
  const double repetitions = static_cast<double>(s.samples);
  state.counters["threads"] = threads;
  state.counters["oversubscribed"] = threads > clothbench::harness::hardware_threads() ? 1 : 0;
  state.counters["iterations_per_loop"] = static_cast<double>(iterations_per_thread * threads);
  state.counters["loops_per_repetition"] = inner;
  state.counters["outer_repetitions"] = repetitions;
  state.counters["delay_ns"] = delay.nanoseconds;
  state.counters["delay_ns_in_reference"] =
      reference_sum / (repetitions * inner * static_cast<double>(iterations_per_thread)) * 1e9;
  state.counters["reference_loop_us"] = reference_sum / (repetitions * inner) * 1e6;
  state.counters["chunks_per_loop"] = static_cast<double>(samples.ranges_per_loop);
  state.counters["chunk_count_constant"] = samples.ranges_constant ? 1 : 0;
  state.counters["overhead_loop_us"] = s.mean;
  state.counters["overhead_loop_us_low95"] = s.low95;
  state.counters["overhead_loop_us_high95"] = s.high95;
  state.counters["overhead_loop_us_median"] = s.median;
  state.counters["overhead_loop_us_sigma"] = s.sigma;
  state.counters["outliers"] = s.outliers;
  state.counters["overhead_chunk_ns"] = per_chunk_ns;
  state.counters["overhead_chunk_ns_median"] = per_chunk_median_ns;
  std::string label = driver->note().empty() ? spec : spec + " (" + driver->note() + ")";
  if (kind == DelayKind::independent) label += " [EPCC's independent delays]";
  label += fmt::format(
      ": per loop {:.3f} us (95% {:.3f}..{:.3f}, median {:.3f}, {} outlier{} of {}), "
      "{} chunks/loop, per chunk {:.1f} ns (median {:.1f})",
      s.mean, s.low95, s.high95, s.median, s.outliers, s.outliers == 1 ? "" : "s", s.samples,
      samples.ranges_per_loop, per_chunk_ns, per_chunk_median_ns);
  const double round_trip_after = core_round_trip_ns(threads);
  state.counters["core_round_trip_ns_before"] = round_trip_before;
  state.counters["core_round_trip_ns_after"] = round_trip_after;
  if (threads >= 2) {
    label += fmt::format(", core round trip {:.0f}/{:.0f} ns before/after", round_trip_before,
                         round_trip_after);
  }
  label += oversubscription_label(threads);
  label += disturbance_label(state, before, threads);
  if (clothbench::micro::smoke()) label += " [smoke]";
  state.SetLabel(label);
}

// dynamic:1, 2 and 4 measured side by side, each repetition running the reference and all
// three tests. Verdict on the medians: PASSED when the per-loop overhead falls with k, FAILED
// when the chunk counts are not n/k or a larger k costs more by over 1.96 standard errors of
// the two means, else not resolved (a dispatch below the noise, as at 1 thread).
void scheduling_overhead_dynamic_k(benchmark::State& state) {
  const std::vector<int> chunk_sizes{1, 2, 4};
  std::vector<std::unique_ptr<LoopDriver>> drivers;
  for (int k : chunk_sizes)
    drivers.push_back(clothbench::schedulers::make_driver(fmt::format("dynamic:{}", k)));
  const int threads = omp_get_max_threads();
  const Delay delay = calibrate_delay<DelayKind::chained>(delay_target_ns);
  const int inner = inner_loops(delay);
  std::vector<DriverSamples> samples(drivers.size());
  const clothbench::harness::ResourceSample before = clothbench::harness::sample_resources();
  for (auto _ : state) {
    const double reference = reference_seconds<DelayKind::chained>(delay.length, inner);
    for (std::size_t d = 0; d < drivers.size(); ++d) {
      samples[d].add(test_time<DelayKind::chained>(*drivers[d], threads, delay.length, inner),
                     reference, inner);
    }
  }
  const std::int64_t n = iterations_per_thread * threads;
  bool chunks_exact = true;
  bool falls = true;   // every median below the one of the next smaller k
  bool rises = false;  // some median above it by more than 1.96 standard errors of the means
  double previous = 0.0;
  double previous_error2 = 0.0;
  std::string figures;
  for (std::size_t d = 0; d < drivers.size(); ++d) {
    const int k = chunk_sizes[d];
    const clothbench::micro::OverheadSummary s =
        clothbench::micro::summarize_overheads(samples[d].overhead_us);
    if (samples[d].ranges_per_loop != (n + k - 1) / k || !samples[d].ranges_constant)
      chunks_exact = false;
    const double error2 = s.sigma * s.sigma / s.samples;  // squared standard error of the mean
    if (d > 0 && !(s.median < previous)) falls = false;
    if (d > 0 && s.median - previous >
                     clothbench::micro::kInterval95Sigmas * std::sqrt(error2 + previous_error2)) {
      rises = true;
    }
    previous = s.median;
    previous_error2 = error2;
    state.counters[fmt::format("overhead_loop_us_median_dynamic{}", k)] = s.median;
    state.counters[fmt::format("chunks_per_loop_dynamic{}", k)] =
        static_cast<double>(samples[d].ranges_per_loop);
    figures += fmt::format("{}dynamic:{} {:.3f} us/loop ({} chunks)", d > 0 ? ", " : "", k,
                           s.median, samples[d].ranges_per_loop);
  }
  state.counters["threads"] = threads;
  state.counters["oversubscribed"] = threads > clothbench::harness::hardware_threads() ? 1 : 0;
  state.counters["chunk_counts_exact"] = chunks_exact ? 1 : 0;
  const std::string disturbed = disturbance_label(state, before, threads);
  const char* verdict = clothbench::micro::smoke() ? "not judged (smoke)"
                        : !disturbed.empty()       ? "not judged (disturbed run)"
                        : !chunks_exact || rises   ? "FAILED"
                        : falls                    ? "PASSED"
                                                   : "not resolved (within the noise)";
  state.counters["falls_with_k"] = falls ? 1 : 0;
  state.SetLabel(fmt::format(
      "per-loop overhead falls with k as chunks do: {} (medians: {}; chunk "
      "counts {}){}{}",
      verdict, figures, chunks_exact ? "exact" : "NOT n/k", oversubscription_label(threads),
      disturbed, clothbench::micro::smoke() ? " [smoke]" : ""));
}

[[maybe_unused]] const bool scheduling_overhead_registered = [] {
  const int repetitions = clothbench::micro::scaled(outer_repetitions, 3);
  // Every scheduler at 1 thread and at the machine's team size P (OMP_NUM_THREADS or all
  // hardware threads): `clothbench predict --overheads` adds what P threads cost beyond 1
  // thread, because a trace's times already hold the 1-thread costs.
  const int team = omp_get_max_threads();
  std::vector<int> team_sizes{1};
  if (team > 1) team_sizes.push_back(team);
  for (const std::string& spec : clothbench::schedulers::available_schedulers()) {
    for (int threads : team_sizes) {
      benchmark::RegisterBenchmark(
          fmt::format("scheduling_overhead/{}/threads:{}", spec, threads).c_str(),
          scheduling_overhead<DelayKind::chained>, spec, threads)
          ->UseRealTime()
          ->Unit(benchmark::kMillisecond)
          ->Iterations(repetitions);
    }
  }
  // The schedules EPCC schedbench was compared with, with its own body (DelayKind), at P.
  for (const std::string spec : {"static", "static:4", "dynamic:1", "dynamic:2", "guided:1"}) {
    benchmark::RegisterBenchmark(("scheduling_overhead_epcc_body/" + spec).c_str(),
                                 scheduling_overhead<DelayKind::independent>, spec, team)
        ->UseRealTime()
        ->Unit(benchmark::kMillisecond)
        ->Iterations(repetitions);
  }
  benchmark::RegisterBenchmark("scheduling_overhead_dynamic_k/falls_with_k",
                               scheduling_overhead_dynamic_k)
      ->UseRealTime()
      ->Unit(benchmark::kMillisecond)
      ->Iterations(repetitions);
  return true;
}();

}  // namespace
