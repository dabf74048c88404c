// clothbench-micro: Google Benchmark entry point for the micro-benchmarks in this folder.
// CLOTHBENCH_MICRO_SMOKE=1 (smoke.hpp) runs every benchmark at a tiny size; the run's context
// then says so, in the console header and in the JSON.
#include <benchmark/benchmark.h>

#include "harness/machine/allocator.hpp"
#include "harness/machine/machine_context.hpp"
#include "harness/micro/smoke.hpp"
#include "harness/run/disturbance.hpp"

int main(int argc, char** argv) {
  // The policy `clothbench run` has, recorded as its machine context records it.
  const clothbench::harness::AllocatorPolicy allocator = clothbench::harness::configure_allocator();
  benchmark::AddCustomContext("allocator", clothbench::harness::to_json(allocator).dump());
  if (clothbench::micro::smoke()) {
    benchmark::AddCustomContext("clothbench_micro_smoke",
                                "tiny sizes (CLOTHBENCH_MICRO_SMOKE=1): not measurements");
  }
  // The scheduling costs depend on it (threads that sleep at a barrier take tens of us to wake):
  // the predictor's overhead model records it (harness/predict/overhead_model.hpp).
  benchmark::AddCustomContext("omp_wait_policy", clothbench::harness::omp_wait_policy());
  // What the figures were measured with: the machine context every clothbench result stores
  // (CPU model, caches, compiler, build flags and code revision, OpenMP runtime), as JSON.
  benchmark::AddCustomContext("clothbench_machine", clothbench::harness::machine_context().dump());
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
