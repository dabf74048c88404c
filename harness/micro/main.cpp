// clothbench-micro: Google Benchmark entry point for the micro-benchmarks in this folder.
// CLOTHBENCH_MICRO_SMOKE=1 (smoke.hpp) runs every benchmark at a tiny size; the run's context
// then says so, in the console header and in the JSON.
#include <benchmark/benchmark.h>

#include "harness/micro/smoke.hpp"

int main(int argc, char** argv) {
  if (clothbench::micro::smoke()) {
    benchmark::AddCustomContext("clothbench_micro_smoke",
                                "tiny sizes (CLOTHBENCH_MICRO_SMOKE=1): not measurements");
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
