// Pinning the OpenMP team to cores (hwloc) and recording where every thread actually ran.
#pragma once

#include <nlohmann/json.hpp>

#include "harness/sweep/sweep_options.hpp"

namespace clothbench::harness {

/// An hwloc topology loaded once per sweep; binds and inspects OpenMP threads.
class ThreadBinder {
 public:
  ThreadBinder();
  ThreadBinder(const ThreadBinder&) = delete;
  ThreadBinder& operator=(const ThreadBinder&) = delete;
  ~ThreadBinder();

  /// Physical cores (hwloc), >= 1.
  [[nodiscard]] int cores() const;

  /// With BindMode::core, opens a parallel region of omp_get_max_threads() threads in which
  /// thread k binds itself to core k mod cores(). Returns false when the OS refused a
  /// binding (the run then proceeds unbound and the record says so). BindMode::none: no-op.
  bool bind_team(BindMode mode) const;

  /// Inside a parallel region of omp_get_max_threads() threads, every thread reports its
  /// binding (hwloc_get_cpubind, HWLOC_CPUBIND_THREAD) and the PU it last ran on
  /// (hwloc_get_last_cpu_location): [{thread, cpuset, last_pu}], cpusets as lists "0-1".
  [[nodiscard]] nlohmann::json record_team() const;

 private:
  struct Topology;
  Topology* topology_;
};

/// OMP_NUM_THREADS, OMP_PROC_BIND, OMP_PLACES, OMP_SCHEDULE, OMP_DYNAMIC, OMP_WAIT_POLICY,
/// GOMP_SPINCOUNT, KMP_AFFINITY as set in the environment (null when unset), plus the
/// effective omp_get_schedule() (what the `runtime` scheduler uses) and omp_get_proc_bind().
nlohmann::json openmp_environment();

}  // namespace clothbench::harness
