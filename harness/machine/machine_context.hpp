// Where a result was measured: hardware topology (hwloc), OS, compiler and build, OpenMP
// runtime and its settings. Stored with every result (CONVENTIONS.md, after Google
// Benchmark's context block).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

namespace clothbench::harness {

/// Version of the layout of machine_context(); bump when keys change meaning or move.
inline constexpr int kMachineContextSchemaVersion = 1;

/// The machine context as JSON. Keys (all always present):
/// schema_version (int), date_utc (ISO-8601 "YYYY-MM-DDTHH:MM:SSZ"), hostname,
/// os {sysname, release, version, machine},
/// cpu {model, vendor, family, model_number, stepping (CPUID's numbers; -1 where the system
///      does not say), vector_isa (the instruction set of the vector kernel's lanes on this CPU:
///      "avx512f" | "avx2+fma" | "sse2"), packages, cores, pus, numa_nodes,
///      caches {L1d, L2, L3: {size_bytes (of one cache, 0 if none), count}},
///      hwloc_api_version},
/// memory {total_bytes, hwloc_numa_bytes, allocator (allocator.hpp: {library,
///         mmap_threshold_bytes, source})}, load_average [1, 5, 15 min] (empty if unavailable),
/// compiler {id ("gcc" | "clang" | "unknown"), version},
/// build {type, flags, git_revision},
/// openmp {version (the _OPENMP date, e.g. 201511), runtime {name, path},
///         max_threads, num_procs, dynamic, proc_bind,
///         schedule {kind, chunk, monotonic}, environment {OMP_* / GOMP_* / KMP_* variables}}.
nlohmann::json machine_context();

/// A few human-readable lines summarising machine_context() (`clothbench info`).
std::string machine_summary(const nlohmann::json& context);

/// "clothbench revision <git> (<build type> build, <compiler> <version>)" for --version.
std::string version_string();

/// Hardware threads (hwloc PUs; std::thread::hardware_concurrency if hwloc fails), >= 1.
int hardware_threads();

/// Physical cores (hwloc; hardware_threads() if hwloc finds none), >= 1.
int physical_cores();

/// Installed memory in bytes (hwloc; sysconf if hwloc fails).
std::uint64_t total_memory_bytes();

}  // namespace clothbench::harness
