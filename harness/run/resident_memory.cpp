// Resident memory of this process and of one run (see resident_memory.hpp).
#include "harness/run/resident_memory.hpp"

#include <fstream>
#include <sstream>

namespace clothbench::harness {

namespace {

/// The value in kB of the line "`key`:   N kB" of `text`, in bytes.
std::optional<std::uint64_t> status_kib(const std::string& text, const std::string& key) {
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.compare(0, key.size() + 1, key + ":") != 0) continue;
    std::istringstream fields(line.substr(key.size() + 1));
    std::uint64_t kib = 0;
    std::string unit;
    if (!(fields >> kib >> unit) || unit != "kB") return std::nullopt;
    return kib * 1024u;
  }
  return std::nullopt;
}

}  // namespace

std::optional<ResidentMemory> parse_proc_status_memory(const std::string& status_text) {
  const auto current = status_kib(status_text, "VmRSS");
  const auto peak = status_kib(status_text, "VmHWM");
  if (!current || !peak) return std::nullopt;
  return ResidentMemory{*current, *peak};
}

std::optional<ResidentMemory> read_resident_memory() {
  std::ifstream in("/proc/self/status");
  if (!in) return std::nullopt;
  std::ostringstream text;
  text << in.rdbuf();
  return parse_proc_status_memory(text.str());
}

bool reset_resident_peak() {
  std::ofstream out("/proc/self/clear_refs");
  if (!out) return false;
  out << "5";
  out.flush();
  return static_cast<bool>(out);
}

RunMemoryProbe::RunMemoryProbe() {
  const bool reset = reset_resident_peak();
  if (const auto now = read_resident_memory()) {
    start_.start_bytes = now->current_bytes;
    start_.scope = reset ? "run" : "process";
  }
}

RunMemory RunMemoryProbe::finish() const {
  RunMemory m = start_;
  if (m.scope == "unknown") return m;
  if (const auto now = read_resident_memory()) {
    m.peak_bytes = now->peak_bytes;
  } else {
    m.scope = "unknown";
  }
  return m;
}

}  // namespace clothbench::harness
