// hwloc thread binding and the per-thread binding record (see thread_binding.hpp).
#include "harness/sweep/thread_binding.hpp"

#include <hwloc.h>
#include <omp.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "schedulers/openmp_runtime.hpp"

namespace clothbench::harness {

namespace {

/// "0-1,4" for a cpuset; "" for a null set.
std::string cpuset_text(hwloc_const_bitmap_t set) {
  char* text = nullptr;
  if (hwloc_bitmap_list_asprintf(&text, set) < 0 || text == nullptr) return "";
  std::string out(text);
  std::free(text);  // NOLINT: allocated by hwloc with malloc
  return out;
}

const char* proc_bind_text(omp_proc_bind_t bind) {
  switch (bind) {
    case omp_proc_bind_false: return "false";
    case omp_proc_bind_true: return "true";
    case omp_proc_bind_master: return "primary";
    case omp_proc_bind_close: return "close";
    case omp_proc_bind_spread: return "spread";
  }
  return "unknown";
}

}  // namespace

struct ThreadBinder::Topology {
  hwloc_topology_t handle = nullptr;
  int cores = 1;
};

ThreadBinder::ThreadBinder() : topology_(new Topology) {
  if (hwloc_topology_init(&topology_->handle) == 0 && hwloc_topology_load(topology_->handle) == 0) {
    const int cores = hwloc_get_nbobjs_by_type(topology_->handle, HWLOC_OBJ_CORE);
    topology_->cores = cores > 0 ? cores : 1;
  } else if (topology_->handle != nullptr) {
    hwloc_topology_destroy(topology_->handle);
    topology_->handle = nullptr;
  }
}

ThreadBinder::~ThreadBinder() {
  if (topology_->handle != nullptr) hwloc_topology_destroy(topology_->handle);
  delete topology_;
}

int ThreadBinder::cores() const { return topology_->cores; }

bool ThreadBinder::bind_team(BindMode mode) const {
  if (mode == BindMode::none) return true;
  if (topology_->handle == nullptr) return false;
  bool all_bound = true;
#pragma omp parallel reduction(&& : all_bound)
  {
    const int core_index = omp_get_thread_num() % topology_->cores;
    hwloc_obj_t core =
        hwloc_get_obj_by_type(topology_->handle, HWLOC_OBJ_CORE, static_cast<unsigned>(core_index));
    all_bound = core != nullptr &&
                hwloc_set_cpubind(topology_->handle, core->cpuset, HWLOC_CPUBIND_THREAD) == 0;
  }
  return all_bound;
}

nlohmann::json ThreadBinder::record_team() const {
  const int team = omp_get_max_threads();
  std::vector<std::string> bound(static_cast<std::size_t>(team));
  std::vector<std::string> last(static_cast<std::size_t>(team));
  if (topology_->handle != nullptr) {
#pragma omp parallel num_threads(team)
    {
      const auto k = static_cast<std::size_t>(omp_get_thread_num());
      hwloc_bitmap_t set = hwloc_bitmap_alloc();
      if (hwloc_get_cpubind(topology_->handle, set, HWLOC_CPUBIND_THREAD) == 0) {
        bound[k] = cpuset_text(set);
      }
      if (hwloc_get_last_cpu_location(topology_->handle, set, HWLOC_CPUBIND_THREAD) == 0) {
        last[k] = cpuset_text(set);
      }
      hwloc_bitmap_free(set);
    }
  }
  nlohmann::json threads = nlohmann::json::array();
  for (int k = 0; k < team; ++k) {
    const auto i = static_cast<std::size_t>(k);
    threads.push_back({{"thread", k}, {"cpuset", bound[i]}, {"last_pu", last[i]}});
  }
  return threads;
}

nlohmann::json openmp_environment() {
  nlohmann::json env = nlohmann::json::object();
  for (const char* name : {"OMP_NUM_THREADS", "OMP_PROC_BIND", "OMP_PLACES", "OMP_SCHEDULE",
                           "OMP_DYNAMIC", "OMP_WAIT_POLICY", "GOMP_SPINCOUNT", "KMP_AFFINITY"}) {
    const char* value = std::getenv(name);  // NOLINT(concurrency-mt-unsafe): read-only use
    env[name] = value != nullptr ? nlohmann::json(value) : nlohmann::json(nullptr);
  }
  omp_sched_t kind{};
  int chunk = 0;
  omp_get_schedule(&kind, &chunk);
  env["effective_schedule"] = schedulers::schedule_text(kind, chunk);
  env["effective_proc_bind"] = proc_bind_text(omp_get_proc_bind());
  return env;
}

}  // namespace clothbench::harness
