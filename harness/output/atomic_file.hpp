// Crash-safe file replacement: readers see the old file or the new one, never a torn one.
#pragma once

#include <filesystem>
#include <string_view>

namespace clothbench::harness {

/// Replaces `path` with `content`: writes a temporary file in the same directory, fsyncs
/// it, renames it over `path` and fsyncs the directory. Creates missing parent
/// directories. On any failure the temporary file is removed, the old `path` (if any) is
/// untouched, and a std::system_error whose what() names `path` is thrown.
void write_file_atomically(const std::filesystem::path& path, std::string_view content);

}  // namespace clothbench::harness
