// EPCC schedbench-style scheduling overhead of every registered backend.
//
// Test: a parallel region of omp_get_max_threads() threads runs `inner` consecutive loops
// of P x iterations_per_thread iterations through the driver; each iteration is a
// calibrated delay (EPCC `delay()`). Reference: one thread runs inner x
// iterations_per_thread delays without any scheduling: the ideal time of one thread's
// share. Overhead per loop = (test - reference) / inner, in microseconds. Each benchmark
// iteration gives one sample; the counters report the median and the 2.5 / 97.5
// percentiles (a 95% interval) of the samples; Google Benchmark's repetitions add the
// spread across runs. OpenMP timing uses real time (UseRealTime).
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <exception>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "harness/micro/smoke.hpp"
#include "schedulers/loop_driver.hpp"
#include "schedulers/registry.hpp"

namespace {

using Clock = std::chrono::steady_clock;

constexpr std::int64_t iterations_per_thread = 1024;  // loop length per thread
constexpr double delay_microseconds = 0.1;            // work of one iteration
constexpr double sample_target_seconds = 0.02;        // test time of one sample
constexpr int samples_per_run = 15;                   // benchmark iterations per run
// (a smoke run, smoke.hpp: 3 samples of one run each)
constexpr int runs = 3;                               // Google Benchmark repetitions

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// EPCC delay(): a floating-point chain the compiler must execute. Not inlined, so the
// reference and every backend run the very same machine code.
[[gnu::noinline]] void delay(std::int64_t length) {
  double accumulator = 0.0;
  for (std::int64_t i = 0; i < length; ++i) accumulator += static_cast<double>(i);
  benchmark::DoNotOptimize(accumulator);
}

// Delay length whose run time is about `microseconds`.
std::int64_t calibrate_delay(double microseconds) {
  std::int64_t length = 1024;
  double elapsed = 0.0;
  for (;;) {
    const Clock::time_point start = Clock::now();
    for (int repeat = 0; repeat < 100; ++repeat) delay(length);
    elapsed = seconds_since(start) / 100.0;
    if (elapsed > 1e-4 || length > (std::int64_t{1} << 40)) break;
    length *= 2;
  }
  return std::max<std::int64_t>(
      1, std::llround(static_cast<double>(length) * microseconds * 1e-6 / elapsed));
}

// Reference time of `inner` loops of one thread's share, without scheduling (median of 5).
double reference_seconds(std::int64_t delay_length, int inner) {
  std::vector<double> times;
  for (int repeat = 0; repeat < 5; ++repeat) {
    const Clock::time_point start = Clock::now();
    for (int loop = 0; loop < inner; ++loop) {
      for (std::int64_t i = 0; i < iterations_per_thread; ++i) delay(delay_length);
    }
    times.push_back(seconds_since(start));
  }
  std::sort(times.begin(), times.end());
  return times[times.size() / 2];
}

// Nearest-rank percentile of sorted samples, fraction in [0, 1].
double percentile(const std::vector<double>& sorted, double fraction) {
  const auto rank =
      static_cast<std::size_t>(std::lround(fraction * static_cast<double>(sorted.size() - 1)));
  return sorted[rank];
}

void scheduling_overhead(benchmark::State& state, const std::string& spec) {
  std::unique_ptr<clothbench::schedulers::LoopDriver> driver;
  try {
    driver = clothbench::schedulers::make_driver(spec);
  } catch (const std::exception& error) {
    state.SkipWithError(error.what());
    return;
  }
  const int threads = omp_get_max_threads();
  const std::int64_t n = iterations_per_thread * threads;
  const std::int64_t delay_length = calibrate_delay(delay_microseconds);
  const int inner = std::max(
      1, static_cast<int>(sample_target_seconds / (static_cast<double>(iterations_per_thread) *
                                                   delay_microseconds * 1e-6)));
  const double reference = reference_seconds(delay_length, inner);
  auto body = [delay_length](std::int64_t begin, std::int64_t end) {
    for (std::int64_t i = begin; i < end; ++i) delay(delay_length);
  };
  std::vector<double> overheads;
  overheads.reserve(samples_per_run);
  for (auto _ : state) {
    const Clock::time_point start = Clock::now();
#pragma omp parallel num_threads(threads)
    for (int loop = 0; loop < inner; ++loop) driver->for_range(n, body);
    overheads.push_back((seconds_since(start) - reference) / inner * 1e6);
  }
  std::sort(overheads.begin(), overheads.end());
  state.counters["overhead_us"] = percentile(overheads, 0.5);
  state.counters["overhead_us_low95"] = percentile(overheads, 0.025);
  state.counters["overhead_us_high95"] = percentile(overheads, 0.975);
  state.counters["reference_us"] = reference / inner * 1e6;
  state.counters["threads"] = threads;
  state.counters["loops_per_sample"] = inner;
  state.SetLabel(driver->note().empty() ? spec : spec + " (" + driver->note() + ")");
}

[[maybe_unused]] const bool scheduling_overhead_registered = [] {
  for (const std::string& spec : clothbench::schedulers::available_schedulers()) {
    benchmark::RegisterBenchmark(("scheduling_overhead/" + spec).c_str(), scheduling_overhead, spec)
        ->UseRealTime()
        ->Unit(benchmark::kMillisecond)
        ->Iterations(clothbench::micro::scaled(samples_per_run, 3))
        ->Repetitions(clothbench::micro::scaled(runs, 1));
  }
  return true;
}();

}  // namespace
