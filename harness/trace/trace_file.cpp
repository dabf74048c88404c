// Writing and reading the per-chunk trace file (see trace_file.hpp).
#include "harness/trace/trace_file.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <iterator>
#include <stdexcept>

namespace clothbench::harness {

using nlohmann::json;

namespace {

constexpr const char* kMagic = "clothbench-trace 2";
/// Format 1: the same file with 40-byte loop records (no bytes_per_element).
constexpr const char* kMagicFormat1 = "clothbench-trace 1";
constexpr std::size_t kFormat1LoopBytes = 40;

const char* kind_name(int kind) {
  switch (kind) {
    case 0:
      return "particles";
    case 1:
      return "edges";
    case 2:
      return "triples";
    case 3:
      return "ghosts";
    default:
      return "index";
  }
}

/// Field layouts of the two records (name, numpy type), in file order.
json chunk_layout() {
  return json::array({{"instance", "<u4"},
                      {"thread", "<i4"},
                      {"begin", "<i4"},
                      {"end", "<i4"},
                      {"elements", "<i4"},
                      {"reserved", "<i4"},
                      {"start_ns", "<i8"},
                      {"end_ns", "<i8"}});
}
json loop_layout() {
  return json::array({{"instance", "<u4"},
                      {"step", "<i4"},
                      {"iteration", "<i4"},
                      {"site", "<i4"},
                      {"n", "<i8"},
                      {"entry_ns", "<i8"},
                      {"exit_ns", "<i8"},
                      {"bytes_per_element", "<f8"}});
}

}  // namespace

std::string loop_site_name(const kernels::TraceSite& site) {
  return fmt::format("{}:{}/{}", site.function, site.line, kind_name(site.kind));
}

std::string row_trace_file_name(const std::string& scheduler, int threads) {
  std::string name = scheduler;
  for (char& c : name) {
    if (c == ':' || c == '@') c = '_';
  }
  return fmt::format("{}-{}t.cbtrace", name, threads);
}

TraceDocument collect_trace(const kernels::ChunkTrace& trace, const json& context,
                            double record_seconds, double run_seconds) {
  TraceDocument document;
  document.loops = trace.loops();
  document.chunks.reserve(static_cast<std::size_t>(trace.chunk_count()));
  std::int64_t growths = 0;
  for (int t = 0; t < trace.thread_count(); ++t) {
    const auto& mine = trace.thread(t);
    document.chunks.insert(document.chunks.end(), mine.chunks.begin(), mine.chunks.end());
    growths += mine.growths;
  }
  std::sort(document.chunks.begin(), document.chunks.end(),
            [](const kernels::ChunkRecord& a, const kernels::ChunkRecord& b) {
              return a.instance != b.instance ? a.instance < b.instance : a.begin < b.begin;
            });
  json sites = json::array();
  for (std::size_t i = 0; i < trace.sites().size(); ++i) {
    const kernels::TraceSite& s = trace.sites()[i];
    sites.push_back({{"id", i},
                     {"name", loop_site_name(s)},
                     {"function", s.function},
                     {"line", s.line},
                     {"kind", kind_name(s.kind)}});
  }
  const auto chunks = static_cast<double>(document.chunks.size());
  json header = context;
  header["format"] = kMagic;
  header["time_unit"] = "ns since the start of the run (steady clock)";
  header["sites"] = sites;
  header["loop_count"] = document.loops.size();
  header["chunk_count"] = document.chunks.size();
  header["loop_record"] = loop_layout();
  header["chunk_record"] = chunk_layout();
  header["record_bytes"] = sizeof(kernels::ChunkRecord);
  header["loop_record_bytes"] = sizeof(kernels::LoopRecord);
  header["bytes_per_element"] =
      "per loop instance, the unavoidable bytes per element its LoopRunner call declares "
      "(reads + writes, kernels/loop_bytes.hpp)";
  // Tracing adds two clock reads and one record per chunk (and one span per loop and thread,
  // not counted): chunks x the measured cost of one record.
  header["cost"] = {{"record_seconds", record_seconds},
                    {"estimated_seconds", chunks * record_seconds},
                    {"run_seconds", run_seconds},
                    {"estimated_percent",
                     run_seconds > 0.0 ? 100.0 * chunks * record_seconds / run_seconds : 0.0},
                    {"buffer_growths", growths}};
  document.header = std::move(header);
  return document;
}

std::uintmax_t write_trace(const std::filesystem::path& file, const TraceDocument& document) {
  // Streamed to FILE.tmp and renamed over FILE: a reader never sees a torn trace, and a
  // trace of hundreds of MB is not copied once more in memory.
  if (!file.parent_path().empty()) std::filesystem::create_directories(file.parent_path());
  const std::filesystem::path temporary = file.string() + ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    const std::string head = std::string(kMagic) + "\n" + document.header.dump() + "\n";
    out.write(head.data(), static_cast<std::streamsize>(head.size()));
    out.write(reinterpret_cast<const char*>(document.loops.data()),
              static_cast<std::streamsize>(document.loops.size() * sizeof(kernels::LoopRecord)));
    out.write(reinterpret_cast<const char*>(document.chunks.data()),
              static_cast<std::streamsize>(document.chunks.size() * sizeof(kernels::ChunkRecord)));
    out.close();
    if (!out) {
      std::filesystem::remove(temporary);
      throw std::runtime_error(file.string() + ": could not write the trace");
    }
  }
  std::filesystem::rename(temporary, file);
  return std::filesystem::file_size(file);
}

TraceDocument read_trace(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw std::runtime_error(file.string() + ": cannot open the trace");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t first = bytes.find('\n');
  const bool format1 = first != std::string::npos && bytes.compare(0, first, kMagicFormat1) == 0;
  if (first == std::string::npos || (!format1 && bytes.compare(0, first, kMagic) != 0)) {
    throw std::runtime_error(file.string() + ": not a clothbench trace (first line)");
  }
  const std::size_t second = bytes.find('\n', first + 1);
  if (second == std::string::npos) throw std::runtime_error(file.string() + ": no header line");
  TraceDocument document;
  try {
    document.header = json::parse(bytes.substr(first + 1, second - first - 1));
  } catch (const json::exception& error) {
    throw std::runtime_error(file.string() + ": header: " + error.what());
  }
  const auto loops = document.header.at("loop_count").get<std::size_t>();
  const auto chunks = document.header.at("chunk_count").get<std::size_t>();
  const std::size_t head = second + 1;
  const std::size_t record = format1 ? kFormat1LoopBytes : sizeof(kernels::LoopRecord);
  const std::size_t loop_bytes = loops * record;
  const std::size_t chunk_bytes = chunks * sizeof(kernels::ChunkRecord);
  if (bytes.size() != head + loop_bytes + chunk_bytes) {
    throw std::runtime_error(fmt::format("{}: {} bytes, but the header announces {}", file.string(),
                                         bytes.size(), head + loop_bytes + chunk_bytes));
  }
  document.loops.resize(loops);
  document.chunks.resize(chunks);
  for (std::size_t i = 0; i < loops; ++i) {  // format 1's records are this one's first 40 bytes
    kernels::LoopRecord& loop = document.loops[i];
    loop.bytes_per_element = kernels::kBytesNotRecorded;
    std::memcpy(&loop, bytes.data() + head + i * record, record);
  }
  if (chunk_bytes > 0) {
    std::memcpy(document.chunks.data(), bytes.data() + head + loop_bytes, chunk_bytes);
  }
  return document;
}

}  // namespace clothbench::harness
