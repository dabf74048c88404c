// Checks of a resumed sweep against the document it continues (see sweep_resume.hpp).
#include "harness/sweep/sweep_resume.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <stdexcept>
#include <string>

#include "harness/report/sweep_table.hpp"
#include "harness/sweep/sweep_document.hpp"
#include "harness/sweep/thread_binding.hpp"

namespace clothbench::harness {

using nlohmann::json;

namespace {

/// Machine context fields (JSON pointers) that a resumed sweep must share with the rows it
/// continues: the build, the compiler, the processor (its caches, family, model number,
/// stepping and vector instruction set too: a VM's model name can be the same on two processor
/// generations, "Intel(R) Xeon(R) Processor", and so can its caches, "AMD EPYC" with 32 MiB of
/// L3 with and without AVX-512), the host, the OpenMP runtime and the allocator policy. Load,
/// date and kernel release may differ (each session's are recorded).
constexpr const char* kResumeMachineFields[] = {"/build/git_revision",
                                                "/build/type",
                                                "/build/flags",
                                                "/compiler",
                                                "/cpu/model",
                                                "/cpu/vendor",
                                                "/cpu/family",
                                                "/cpu/model_number",
                                                "/cpu/stepping",
                                                "/cpu/vector_isa",
                                                "/cpu/packages",
                                                "/cpu/cores",
                                                "/cpu/pus",
                                                "/cpu/caches",
                                                "/hostname",
                                                "/openmp/runtime/name",
                                                "/memory/allocator"};

/// The existing document of a resumed sweep, after checking it matches this sweep.
}  // namespace

json resumed_document(const std::filesystem::path& file, const Scene& scene, int steps,
                      const SweepOptions& options, const json& machine, const json& settings) {
  json old = load_sweep_document(file);
  auto refuse = [&](const std::string& what) {
    throw std::invalid_argument(fmt::format(
        "--resume: {} was made with {}; start a new sweep (another --out, or without --resume)",
        file.string(), what));
  };
  if (old["scene"]["hash"] != scene.source_sha256_or_fnv) refuse("a different scene file");
  if (old["settings"]["steps"] != steps) {
    refuse(fmt::format("{} steps, not {}", old["settings"]["steps"].dump(), steps));
  }
  if (old["settings"]["instrument"] != to_string(options.instrument)) {
    refuse(fmt::format("--instrument {}", old["settings"]["instrument"].get<std::string>()));
  }
  // A document without the key instrumented every row.
  const json old_only = old["settings"].value("instrument_only", json::array());
  if (old_only != settings["instrument_only"]) {
    refuse(fmt::format("settings.instrument_only = {} (this run: {}; [] is every row)",
                       old_only.dump(), settings["instrument_only"].dump()));
  }
  // Rows measured another way, by another build or on another machine would share one table
  // and one speed-up column without saying so. (Schedulers, thread counts, retries and
  // --oversubscribe may change: a resume may extend the grid, and rows carry their own labels.)
  for (const char* key : {"repeat", "warmup_steps", "bind", "omp_wait_policy"}) {
    if (!old["settings"].contains(key)) continue;  // older documents
    if (old["settings"][key] != settings[key]) {
      refuse(fmt::format("settings.{} = {} (this run: {})", key, old["settings"][key].dump(),
                         settings[key].dump()));
    }
  }
  auto without_thread_count = [](json environment) {
    if (environment.is_object()) environment.erase("OMP_NUM_THREADS");  // the sweep sets it
    return environment;
  };
  if (old.contains("openmp_environment") &&
      without_thread_count(old["openmp_environment"]) != without_thread_count(openmp_environment())) {
    refuse(fmt::format("the OpenMP environment {} (this run: {})",
                       old["openmp_environment"].dump(), openmp_environment().dump()));
  }
  for (const char* field : kResumeMachineFields) {
    const json::json_pointer at(field);
    const json before = old["machine"].contains(at) ? old["machine"][at] : json();
    const json now = machine.contains(at) ? machine[at] : json();
    if (before != now) {
      std::string name = field;
      std::replace(name.begin(), name.end(), '/', '.');
      refuse(fmt::format("machine{} = {} (this run: {})", name, before.dump(), now.dump()));
    }
  }
  return old;
}

}  // namespace clothbench::harness
