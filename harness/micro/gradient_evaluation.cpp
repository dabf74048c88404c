// Gradient evaluation of the cloth kernel at 101^2, 301^2 and 1001^2 particles, with a
// STREAM-style triad in the same binary so the roofline is measured in the same run. The triad
// runs at every thread count from 1 to the machine's physical cores: its JSON is what
// `clothbench predict --bandwidth` and `run|sweep --trace-bandwidth` read for the predictor's
// memory-bandwidth ceiling (harness/predict/bandwidth_model.hpp). Two
// variants: `potential` (the scalar reference element loops) and `potential_vector`
// (ElementKernel::vector, SIMD lanes of the widest instruction set of this CPU, named in the
// label); compare them as a ratio of ns_per_element within one run.
//
// Counters: elements/s (active particles + edges + triples per second) and two bandwidths:
// `unavoidable_bytes_per_second` counts only what any implementation of the potential gradient
// must move (read x, x~, the previous element forces; write the gradient: 104 B per particle),
// `moved_bytes_per_second` counts every array this implementation touches per evaluation.
#include <benchmark/benchmark.h>
#include <omp.h>

#include <string>
#include <vector>

#include "harness/machine/machine_context.hpp"
#include "harness/micro/box_scene.hpp"
#include "harness/micro/smoke.hpp"
#include "kernels/simulation.hpp"
#include "kernels/vector/element_lanes.hpp"
#include "schedulers/static_driver.hpp"

namespace {

using clothbench::kernels::ElementKernel;
using clothbench::kernels::Formulation;
using clothbench::kernels::Simulation;
using clothbench::kernels::SimulationConfig;

void gradient(benchmark::State& state, Formulation formulation, ElementKernel kernel) {
  const int n = static_cast<int>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  omp_set_num_threads(threads);
  Simulation* sim = &clothbench::micro::draped_box(n, formulation, kernel);
  std::string label = kernel == ElementKernel::vector
                          ? std::string(clothbench::kernels::vector::element_lanes_kernels().isa)
                          : std::string("scalar");
  if (clothbench::micro::smoke()) label += " smoke";
  state.SetLabel(label);
  clothbench::schedulers::OmpStaticDriver driver;
  sim->evaluate(driver, true);
  for (auto _ : state) {
    benchmark::DoNotOptimize(sim->evaluate(driver, false).value);
  }
  const double evaluations = static_cast<double>(state.iterations());
  const double particles = static_cast<double>(n) * n;
  clothbench::micro::set_element_counters(
      state, evaluations * static_cast<double>(sim->active_elements()));
  state.counters["unavoidable_bytes_per_second"] =
      benchmark::Counter(evaluations * particles * 104.0, benchmark::Counter::kIsRate,
                         benchmark::Counter::kIs1024);
  // Particles: x, x~, x^n, direction, g_old (read), g (write), preconditioner, mass, flags,
  // contact force; per element id (4 per particle): neighbours, flags, geometry, force, scratch.
  const double moved = 6 * 24 + 24 + 8 + 1 + 8 + 2 * (8 + 2 + 16 + 16 + 8 + 8) + 2 * 48;
  state.counters["moved_bytes_per_second"] = benchmark::Counter(
      evaluations * particles * moved, benchmark::Counter::kIsRate, benchmark::Counter::kIs1024);
  state.counters["threads"] = threads;
}

/// a[i] = b[i] + s c[i] over three arrays of n doubles (far larger than the caches unless
/// CLOTHBENCH_MICRO_SMOKE) at `threads` threads: bytes_per_second counts 24 B per element, as
/// STREAM does (no write-allocate traffic).
void triad(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  omp_set_num_threads(threads);
  std::vector<double> a(n), b(n, 1.0), c(n, 2.0);
  const double s = 3.0;
  for (auto _ : state) {
#pragma omp parallel for schedule(static)
    for (std::size_t i = 0; i < n; ++i) a[i] = b[i] + s * c[i];
    benchmark::ClobberMemory();
  }
  state.counters["bytes_per_second"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * 3.0 * 8.0 * static_cast<double>(n),
                         benchmark::Counter::kIsRate, benchmark::Counter::kIs1024);
  state.counters["threads"] = threads;
}

BENCHMARK_CAPTURE(gradient, potential, Formulation::potential, ElementKernel::reference)
    ->Apply(clothbench::micro::box_sizes);
BENCHMARK_CAPTURE(gradient, potential_vector, Formulation::potential, ElementKernel::vector)
    ->Apply(clothbench::micro::box_sizes);

/// The triad at every thread count from 1 to the physical cores (the predictor's B(P)).
void triad_threads(benchmark::internal::Benchmark* b) {
  const std::int64_t n = clothbench::micro::scaled(1 << 24, 1 << 12);
  const int cores = clothbench::harness::physical_cores();
  for (int threads = 1; threads <= cores; ++threads) b->Args({n, threads});
  b->UseRealTime()->Unit(benchmark::kMillisecond);
}
BENCHMARK(triad)->Apply(triad_threads);

}  // namespace
