// Identity and settings of the OpenMP runtime the program actually runs on, for the
// machine-context block of every result (CONVENTIONS.md: Google Benchmark model).
#pragma once

#include <omp.h>

#include <string>
#include <vector>

#include "schedulers/self_test.hpp"

namespace clothbench::schedulers {

/// What the OpenMP implementation is and how it is configured right now.
struct RuntimeInfo {
  int openmp_macro = 0;                ///< `_OPENMP` at compile time, e.g. 201511
  std::string openmp_version;          ///< the spec version it names, e.g. "4.5", "5.0"
  std::string library;                 ///< "libgomp (GNU)", "libomp (LLVM)" or "unknown"
  std::string library_path;            ///< resolved path of the loaded runtime library
  std::string schedule;                ///< omp_get_schedule(), e.g. "monotonic:dynamic,2"
  int max_threads = 0;                 ///< omp_get_max_threads()
  int num_procs = 0;                   ///< omp_get_num_procs()
  int thread_limit = 0;                ///< omp_get_thread_limit()
  bool dynamic_threads = false;        ///< omp_get_dynamic()
  std::vector<RuntimeDefect> defects;  ///< detect_runtime_defects(): broken clauses
};

/// Queries the runtime (and probes it for known defects: a few tiny parallel loops).
/// Call outside parallel regions.
RuntimeInfo openmp_runtime_info();

/// Text of a run-sched-var value in OMP_SCHEDULE syntax, including the monotonic flag:
/// (omp_sched_dynamic | omp_sched_monotonic, 2) -> "monotonic:dynamic,2"; a chunk < 1
/// means the default and is left out.
std::string schedule_text(omp_sched_t kind, int chunk);

/// Spec version of an `_OPENMP` value: 201511 -> "4.5"; unknown values print as numbers.
std::string openmp_version_text(int openmp_macro);

}  // namespace clothbench::schedulers
