// clothbench-micro: Google Benchmark entry point for the micro-benchmarks in this folder.
#include <benchmark/benchmark.h>

BENCHMARK_MAIN();
