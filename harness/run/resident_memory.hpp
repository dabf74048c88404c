// Resident memory of this process, and the peak of one run apart from what the process did
// before it. Linux keeps a high-water mark of the resident set (VmHWM in /proc/self/status)
// that a process may reset to its current resident set by writing "5" to
// /proc/self/clear_refs (proc(5), Linux 4.0 and later). A sweep makes many runs in one process,
// so getrusage's ru_maxrss (the process's peak since it started) says nothing about the runs
// after the largest one; with the reset each run gets its own peak.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

namespace clothbench::harness {

/// The resident set now and its high-water mark (bytes).
struct ResidentMemory {
  std::uint64_t current_bytes = 0;  ///< VmRSS
  std::uint64_t peak_bytes = 0;     ///< VmHWM
};

/// Reads VmRSS and VmHWM from `status_text` (the text of /proc/<pid>/status, "kB" units);
/// nullopt when either line is missing or malformed.
std::optional<ResidentMemory> parse_proc_status_memory(const std::string& status_text);

/// This process's resident memory from /proc/self/status; nullopt where there is none.
std::optional<ResidentMemory> read_resident_memory();

/// Resets this process's high-water mark to its current resident set; false when the kernel
/// does not offer it (no /proc, a kernel before 4.0, no permission).
bool reset_resident_peak();

/// How far a run's peak is its own: "run" (the high-water mark was reset at its start),
/// "process" (it could not be: the process's peak so far, which may come from an earlier
/// run) or "unknown" (no /proc; also read from documents written before memory was measured).
struct RunMemory {
  std::uint64_t start_bytes = 0;  ///< resident set when the run started
  std::uint64_t peak_bytes = 0;   ///< highest resident set until it ended
  std::string scope = "unknown";
};

/// Measures one run's memory: construct it right before the run's set-up, call finish() after
/// its last step.
class RunMemoryProbe {
 public:
  RunMemoryProbe();
  [[nodiscard]] RunMemory finish() const;

 private:
  RunMemory start_;
};

}  // namespace clothbench::harness
