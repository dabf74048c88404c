// Machine context: hwloc topology, uname, compiler/build, OpenMP runtime and settings.
#include "harness/machine/machine_context.hpp"

#include "harness/machine/allocator.hpp"
#include "harness/machine/git_revision.hpp"
#include "kernels/vector/element_lanes.hpp"

#include <fmt/format.h>
#include <hwloc.h>
#include <link.h>
#include <omp.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <array>
#include <charconv>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <map>
#include <memory>
#include <string_view>
#include <thread>

extern char** environ;  // POSIX; declared by <unistd.h> only with _GNU_SOURCE

namespace clothbench::harness {
namespace {

// An hwloc topology of this machine, or none when hwloc cannot load it.
class Topology {
 public:
  Topology() {
    if (hwloc_topology_init(&topology_) != 0) {
      topology_ = nullptr;
      return;
    }
    if (hwloc_topology_load(topology_) != 0) {
      hwloc_topology_destroy(topology_);
      topology_ = nullptr;
    }
  }
  ~Topology() {
    if (topology_ != nullptr) hwloc_topology_destroy(topology_);
  }
  Topology(const Topology&) = delete;
  Topology& operator=(const Topology&) = delete;

  bool loaded() const { return topology_ != nullptr; }
  int count(hwloc_obj_type_t type) const {
    return loaded() ? std::max(0, hwloc_get_nbobjs_by_type(topology_, type)) : 0;
  }
  hwloc_obj_t object(hwloc_obj_type_t type, unsigned index) const {
    return loaded() ? hwloc_get_obj_by_type(topology_, type, index) : nullptr;
  }
  std::uint64_t total_memory() const {
    return loaded() ? hwloc_get_root_obj(topology_)->total_memory : 0;
  }

 private:
  hwloc_topology_t topology_ = nullptr;
};

std::uint64_t sysconf_memory() {
  const long pages = sysconf(_SC_PHYS_PAGES);
  const long page_size = sysconf(_SC_PAGESIZE);
  return pages > 0 && page_size > 0
             ? static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(page_size)
             : 0;
}

/// The "key : value" lines of /proc/cpuinfo's first processor block (empty where there is none).
std::map<std::string, std::string> cpuinfo_fields() {
  std::map<std::string, std::string> fields;
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string line;
  while (std::getline(cpuinfo, line) && !line.empty()) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    const auto key_end = line.find_last_not_of(" \t", colon == 0 ? 0 : colon - 1);
    const auto start = line.find_first_not_of(" \t", colon + 1);
    fields.emplace(key_end == std::string::npos ? "" : line.substr(0, key_end + 1),
                   start == std::string::npos ? "" : line.substr(start));
  }
  return fields;
}

std::string cpu_model(const Topology& topology, const std::map<std::string, std::string>& cpuinfo) {
  if (hwloc_obj_t package = topology.object(HWLOC_OBJ_PACKAGE, 0)) {
    if (const char* model = hwloc_obj_get_info_by_name(package, "CPUModel")) return model;
  }
  const auto model = cpuinfo.find("model name");
  return model != cpuinfo.end() ? model->second : "unknown";
}

/// The processor's family, model number and stepping (x86: CPUID's; hwloc's package infos, else
/// /proc/cpuinfo), -1 where neither says. Two processor generations can share a model name and
/// cache sizes on a VM ("AMD EPYC", L3 32 MiB: Zen 3 without AVX-512 and Zen 4 with it); these
/// numbers tell them apart.
struct CpuIdentity {
  std::string vendor = "unknown";
  int family = -1, model_number = -1, stepping = -1;
};

CpuIdentity cpu_identity(const Topology& topology,
                         const std::map<std::string, std::string>& cpuinfo) {
  hwloc_obj_t package = topology.object(HWLOC_OBJ_PACKAGE, 0);
  // hwloc's info by name, else /proc/cpuinfo's key; nullptr when neither has it.
  auto text = [&](const char* hwloc_name, const char* cpuinfo_key) -> const char* {
    if (package != nullptr) {
      if (const char* value = hwloc_obj_get_info_by_name(package, hwloc_name)) return value;
    }
    const auto entry = cpuinfo.find(cpuinfo_key);
    return entry != cpuinfo.end() && !entry->second.empty() ? entry->second.c_str() : nullptr;
  };
  auto number = [&](const char* hwloc_name, const char* cpuinfo_key) {
    const char* value = text(hwloc_name, cpuinfo_key);
    int parsed = -1;
    if (value == nullptr) return parsed;
    const char* end = value + std::strlen(value);
    const auto [rest, error] = std::from_chars(value, end, parsed);
    return error == std::errc() && rest == end ? parsed : -1;
  };
  CpuIdentity identity;
  if (const char* vendor = text("CPUVendor", "vendor_id")) identity.vendor = vendor;
  identity.family = number("CPUFamilyNumber", "cpu family");
  identity.model_number = number("CPUModelNumber", "model");
  identity.stepping = number("CPUStepping", "stepping");
  return identity;
}

nlohmann::json cache(const Topology& topology, hwloc_obj_type_t type) {
  const int count = topology.count(type);
  std::uint64_t size = 0;
  if (hwloc_obj_t first = topology.object(type, 0); first != nullptr && first->attr != nullptr) {
    size = first->attr->cache.size;
  }
  return {{"size_bytes", size}, {"count", count}};
}

std::string utc_now_iso8601() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  std::array<char, 32> text{};
  std::strftime(text.data(), text.size(), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text.data();
}

nlohmann::json compiler() {
#if defined(__clang__)
  return {
      {"id", "clang"},
      {"version", fmt::format("{}.{}.{}", __clang_major__, __clang_minor__, __clang_patchlevel__)}};
#elif defined(__GNUC__)
  return {{"id", "gcc"},
          {"version", fmt::format("{}.{}.{}", __GNUC__, __GNUC_MINOR__, __GNUC_PATCHLEVEL__)}};
#else
  return {{"id", "unknown"}, {"version", "unknown"}};
#endif
}

// The first loaded OpenMP runtime among the known ones (GNU, LLVM, Intel).
int find_openmp_runtime(dl_phdr_info* info, std::size_t, void* data) {
  auto* found = static_cast<nlohmann::json*>(data);
  if (info->dlpi_name == nullptr) return 0;
  const std::string_view path(info->dlpi_name);
  const std::string_view file =
      path.substr(path.rfind('/') == std::string_view::npos ? 0 : path.rfind('/') + 1);
  for (const char* name : {"libgomp", "libiomp5", "libomp"}) {
    if (file.rfind(name, 0) == 0) {
      *found = {{"name", name}, {"path", std::string(path)}};
      return 1;
    }
  }
  return 0;
}

nlohmann::json openmp_schedule() {
  omp_sched_t kind{};
  int chunk = 0;
  omp_get_schedule(&kind, &chunk);
  const auto bits = static_cast<unsigned>(kind);
  const bool monotonic = (bits & static_cast<unsigned>(omp_sched_monotonic)) != 0;
  const char* name = "unknown";
  switch (static_cast<omp_sched_t>(bits & ~static_cast<unsigned>(omp_sched_monotonic))) {
    case omp_sched_static:
      name = "static";
      break;
    case omp_sched_dynamic:
      name = "dynamic";
      break;
    case omp_sched_guided:
      name = "guided";
      break;
    case omp_sched_auto:
      name = "auto";
      break;
    default:
      break;
  }
  return {{"kind", name}, {"chunk", chunk}, {"monotonic", monotonic}};
}

const char* proc_bind_name(omp_proc_bind_t bind) {
  switch (bind) {
    case omp_proc_bind_false:
      return "false";
    case omp_proc_bind_true:
      return "true";
    case omp_proc_bind_master:
      return "primary";
    case omp_proc_bind_close:
      return "close";
    case omp_proc_bind_spread:
      return "spread";
    default:
      return "unknown";
  }
}

nlohmann::json openmp_environment() {
  nlohmann::json variables = nlohmann::json::object();
  for (char** entry = environ; entry != nullptr && *entry != nullptr; ++entry) {
    const std::string_view text(*entry);
    const auto equals = text.find('=');
    if (equals == std::string_view::npos) continue;
    const std::string_view name = text.substr(0, equals);
    for (const std::string_view prefix : {"OMP_", "GOMP_", "KMP_"}) {
      if (name.substr(0, prefix.size()) == prefix) {
        variables[std::string(name)] = std::string(text.substr(equals + 1));
        break;
      }
    }
  }
  return variables;
}

}  // namespace

int hardware_threads() {
  const Topology topology;
  const int pus = topology.count(HWLOC_OBJ_PU);
  if (pus > 0) return pus;
  return std::max(1u, std::thread::hardware_concurrency());
}

int physical_cores() {
  const Topology topology;
  const int cores = topology.count(HWLOC_OBJ_CORE);
  return cores > 0 ? cores : hardware_threads();
}

std::uint64_t total_memory_bytes() {
  // The kernel's count of physical pages is the memory a run can have; hwloc's NUMA figure can
  // be smaller on virtual machines (seen: 5.85 GB of 24 GB) and is only the fallback. A cgroup
  // limit, when set, caps it.
  std::uint64_t bytes = sysconf_memory();
  if (bytes == 0) bytes = Topology().total_memory();
  std::ifstream limit("/sys/fs/cgroup/memory.max");
  std::uint64_t cap = 0;
  if (limit >> cap && cap > 0 && cap < bytes) bytes = cap;
  return bytes;
}

nlohmann::json machine_context() {
  const Topology topology;
  nlohmann::json context;
  context["schema_version"] = kMachineContextSchemaVersion;
  context["date_utc"] = utc_now_iso8601();

  std::array<char, 256> host{};
  context["hostname"] =
      gethostname(host.data(), host.size() - 1) == 0 ? std::string(host.data()) : "unknown";
  utsname names{};
  if (uname(&names) == 0) {
    context["os"] = {{"sysname", names.sysname},
                     {"release", names.release},
                     {"version", names.version},
                     {"machine", names.machine}};
  } else {
    context["os"] = {{"sysname", "unknown"}, {"release", ""}, {"version", ""}, {"machine", ""}};
  }

  const int pus = topology.loaded() ? topology.count(HWLOC_OBJ_PU) : hardware_threads();
  const int cores = topology.loaded() ? topology.count(HWLOC_OBJ_CORE) : pus;
  const unsigned api = hwloc_get_api_version();
  const std::map<std::string, std::string> cpuinfo = cpuinfo_fields();
  const CpuIdentity identity = cpu_identity(topology, cpuinfo);
  context["cpu"] = {
      {"model", cpu_model(topology, cpuinfo)},
      {"vendor", identity.vendor},
      {"family", identity.family},
      {"model_number", identity.model_number},
      {"stepping", identity.stepping},
      {"vector_isa", kernels::vector::element_lanes_kernels().isa},
      {"packages", std::max(1, topology.count(HWLOC_OBJ_PACKAGE))},
      {"cores", std::max(1, cores)},
      {"pus", std::max(1, pus)},
      {"numa_nodes", std::max(1, topology.count(HWLOC_OBJ_NUMANODE))},
      {"caches",
       {{"L1d", cache(topology, HWLOC_OBJ_L1CACHE)},
        {"L2", cache(topology, HWLOC_OBJ_L2CACHE)},
        {"L3", cache(topology, HWLOC_OBJ_L3CACHE)}}},
      {"hwloc_api_version", fmt::format("{}.{}.{}", api >> 16, (api >> 8) & 0xff, api & 0xff)},
  };
  const std::uint64_t memory = topology.total_memory();
  context["memory"] = {{"total_bytes", total_memory_bytes()},
                       {"hwloc_numa_bytes", memory},
                       {"allocator", to_json(allocator_policy())}};
  std::array<double, 3> load{};
  context["load_average"] =
      getloadavg(load.data(), 3) == 3 ? nlohmann::json(load) : nlohmann::json::array();

  context["compiler"] = compiler();
  context["build"] = {{"type", CLOTHBENCH_BUILD_TYPE},
                      {"flags", CLOTHBENCH_CXX_FLAGS},
                      {"git_revision", git_revision()}};

  nlohmann::json runtime = {{"name", "unknown"}, {"path", ""}};
  dl_iterate_phdr(find_openmp_runtime, &runtime);
  context["openmp"] = {
#ifdef _OPENMP
      {"version", _OPENMP},
#else
      {"version", 0},
#endif
      {"runtime", runtime},
      {"max_threads", omp_get_max_threads()},
      {"num_procs", omp_get_num_procs()},
      {"dynamic", omp_get_dynamic() != 0},
      {"proc_bind", proc_bind_name(omp_get_proc_bind())},
      {"schedule", openmp_schedule()},
      {"environment", openmp_environment()},
  };
  return context;
}

std::string version_string() {
  const auto id = compiler();
  return fmt::format("clothbench revision {} ({} build, {} {})", git_revision(),
                     CLOTHBENCH_BUILD_TYPE, id.at("id").get<std::string>(),
                     id.at("version").get<std::string>());
}

std::string machine_summary(const nlohmann::json& c) {
  const auto& cpu = c.at("cpu");
  const auto& caches = cpu.at("caches");
  auto cache_text = [&](const char* level) {
    const auto& entry = caches.at(level);
    const auto count = entry.at("count").get<int>();
    if (count == 0) return fmt::format("{} none", level);
    return fmt::format("{} {} KiB x {}", level, entry.at("size_bytes").get<std::uint64_t>() / 1024,
                       count);
  };
  // Stored contexts from before the processor's identity was recorded have none.
  const std::string identity =
      cpu.contains("family")
          ? fmt::format(" ({}, family {} model {} stepping {}; vector lanes {})",
                        cpu.at("vendor").get<std::string>(), cpu.at("family").get<int>(),
                        cpu.at("model_number").get<int>(), cpu.at("stepping").get<int>(),
                        cpu.at("vector_isa").get<std::string>())
          : std::string();
  const auto& omp = c.at("openmp");
  const auto& schedule = omp.at("schedule");
  // Stored contexts from before the allocator was recorded have no "allocator".
  std::string allocator;
  if (const auto& memory = c.at("memory"); memory.contains("allocator")) {
    const auto& a = memory.at("allocator");
    allocator = a.at("mmap_threshold_bytes").is_null()
                    ? fmt::format("; allocator {}, its own mmap threshold",
                                  a.at("library").get<std::string>())
                    : fmt::format("; allocator {}, blocks >= {} KiB mapped ({})",
                                  a.at("library").get<std::string>(),
                                  a.at("mmap_threshold_bytes").get<std::int64_t>() / 1024,
                                  a.at("source").get<std::string>());
  }
  std::string environment;
  for (const auto& [name, value] : omp.at("environment").items()) {
    environment += fmt::format(" {}={}", name, value.get<std::string>());
  }
  return fmt::format(
      "host      {} ({} {} {})\n"
      "cpu       {}{}\n"
      "topology  {} package(s), {} core(s), {} PU(s), {} NUMA node(s)\n"
      "caches    {}, {}, {}\n"
      "memory    {:.1f} GiB{}\n"
      "compiler  {} {}, {} build, revision {}\n"
      "openmp    {} ({}), _OPENMP {}, max threads {}, procs {}, schedule {}{},{} proc_bind {}\n"
      "env      {}\n"
      "date      {}\n",
      c.at("hostname").get<std::string>(), c.at("os").at("sysname").get<std::string>(),
      c.at("os").at("release").get<std::string>(), c.at("os").at("machine").get<std::string>(),
      cpu.at("model").get<std::string>(), identity, cpu.at("packages").get<int>(),
      cpu.at("cores").get<int>(), cpu.at("pus").get<int>(), cpu.at("numa_nodes").get<int>(),
      cache_text("L1d"), cache_text("L2"), cache_text("L3"),
      static_cast<double>(c.at("memory").at("total_bytes").get<std::uint64_t>()) /
          (1024.0 * 1024.0 * 1024.0),
      allocator, c.at("compiler").at("id").get<std::string>(),
      c.at("compiler").at("version").get<std::string>(),
      c.at("build").at("type").get<std::string>(),
      c.at("build").at("git_revision").get<std::string>(),
      omp.at("runtime").at("name").get<std::string>(),
      omp.at("runtime").at("path").get<std::string>(), omp.at("version").get<int>(),
      omp.at("max_threads").get<int>(), omp.at("num_procs").get<int>(),
      schedule.at("monotonic").get<bool>() ? "monotonic:" : "",
      schedule.at("kind").get<std::string>(), schedule.at("chunk").get<int>(),
      omp.at("proc_bind").get<std::string>(),
      environment.empty() ? " (no OMP_*, GOMP_*, KMP_* variables)" : environment,
      c.at("date_utc").get<std::string>());
}

}  // namespace clothbench::harness
