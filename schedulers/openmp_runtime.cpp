// Run-time identity of the OpenMP library (see openmp_runtime.hpp).
#include "schedulers/openmp_runtime.hpp"

#include <dlfcn.h>
#include <link.h>

#include <array>
#include <climits>
#include <cstdlib>
#include <string_view>
#include <utility>

#include "schedulers/text.hpp"

namespace clothbench::schedulers {
namespace {

// Collects the first loaded shared object whose file name names an OpenMP runtime.
struct LoadedRuntime {
  std::string library;
  std::string path;
};

int visit_loaded_object(dl_phdr_info* info, std::size_t /*size*/, void* data) {
  auto* found = static_cast<LoadedRuntime*>(data);
  const std::string_view path = info->dlpi_name != nullptr ? info->dlpi_name : "";
  const std::string_view file =
      path.substr(path.rfind('/') == std::string_view::npos ? 0 : path.rfind('/') + 1);
  if (file.starts_with("libgomp")) {
    *found = {"libgomp (GNU)", std::string(path)};
  } else if (file.starts_with("libomp") || file.starts_with("libiomp")) {
    *found = {"libomp (LLVM)", std::string(path)};
  } else {
    return 0;
  }
  return 1;  // stop at the first runtime found
}

std::string resolved(const std::string& path) {
  std::array<char, PATH_MAX> buffer{};
  return realpath(path.c_str(), buffer.data()) != nullptr ? std::string(buffer.data()) : path;
}

}  // namespace

std::string schedule_text(omp_sched_t kind, int chunk) {
  const auto bits = static_cast<unsigned>(kind);
  const auto monotonic_bit = static_cast<unsigned>(omp_sched_monotonic);
  std::string text = (bits & monotonic_bit) != 0 ? "monotonic:" : "";
  switch (static_cast<omp_sched_t>(bits & ~monotonic_bit)) {
    case omp_sched_static:
      text += "static";
      break;
    case omp_sched_dynamic:
      text += "dynamic";
      break;
    case omp_sched_guided:
      text += "guided";
      break;
    case omp_sched_auto:
      return text + "auto";
    default:
      return concat(text, "kind-", bits & ~monotonic_bit);
  }
  if (chunk >= 1) text += concat(",", chunk);
  return text;
}

std::string openmp_version_text(int openmp_macro) {
  constexpr std::array<std::pair<int, const char*>, 7> versions{{{200505, "2.5"},
                                                                 {200805, "3.0"},
                                                                 {201107, "3.1"},
                                                                 {201307, "4.0"},
                                                                 {201511, "4.5"},
                                                                 {201811, "5.0"},
                                                                 {202011, "5.1"}}};
  for (const auto& [macro, version] : versions) {
    if (macro == openmp_macro) return version;
  }
  return std::to_string(openmp_macro);
}

RuntimeInfo openmp_runtime_info() {
  RuntimeInfo info;
  info.openmp_macro = _OPENMP;
  info.openmp_version = openmp_version_text(_OPENMP);
  LoadedRuntime runtime;
  dl_iterate_phdr(visit_loaded_object, &runtime);
  if (runtime.library.empty()) {
    // Statically linked or renamed: tell the implementations apart by their entry points.
    const bool llvm = dlsym(RTLD_DEFAULT, "__kmpc_fork_call") != nullptr;
    const bool gnu = dlsym(RTLD_DEFAULT, "GOMP_parallel") != nullptr;
    runtime.library = llvm ? "libomp (LLVM)" : gnu ? "libgomp (GNU)" : "unknown";
  }
  info.library = runtime.library;
  info.library_path = runtime.path.empty() ? "" : resolved(runtime.path);
  omp_sched_t kind{};
  int chunk = 0;
  omp_get_schedule(&kind, &chunk);
  info.schedule = schedule_text(kind, chunk);
  info.max_threads = omp_get_max_threads();
  info.num_procs = omp_get_num_procs();
  info.thread_limit = omp_get_thread_limit();
  info.dynamic_threads = omp_get_dynamic() != 0;
  info.defects = detect_runtime_defects();
  return info;
}

}  // namespace clothbench::schedulers
