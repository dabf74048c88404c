// write_file_atomically: temp file + fsync + rename (POSIX).
#include "harness/output/atomic_file.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <system_error>

namespace clothbench::harness {
namespace {

[[noreturn]] void throw_errno(int error, std::string_view what, const std::filesystem::path& path) {
  throw std::system_error(error, std::generic_category(),
                          fmt::format("cannot write '{}': {}", path.string(), what));
}

// Closes a descriptor and removes the temporary file unless released.
struct TemporaryFile {
  std::filesystem::path path;
  int fd = -1;
  bool keep = false;
  ~TemporaryFile() {
    if (fd >= 0) ::close(fd);
    if (!keep) ::unlink(path.c_str());
  }
};

}  // namespace

void write_file_atomically(const std::filesystem::path& path, std::string_view content) {
  if (path.filename().empty()) throw_errno(EISDIR, "not a file name", path);
  const std::filesystem::path directory =
      path.parent_path().empty() ? std::filesystem::path(".") : path.parent_path();
  std::error_code ec;
  std::filesystem::create_directories(directory, ec);
  if (ec)
    throw_errno(ec.value(), fmt::format("cannot create directory '{}'", directory.string()), path);

  // Unique within the process (counter) and across processes (pid); O_EXCL guards the rest.
  static std::atomic<unsigned> counter{0};
  TemporaryFile temporary;
  temporary.path = directory / fmt::format(".{}.tmp.{}.{}", path.filename().string(), ::getpid(),
                                           counter.fetch_add(1));
  temporary.fd = ::open(temporary.path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (temporary.fd < 0) {
    temporary.keep = true;  // nothing was created, and another process may own that name
    throw_errno(errno, "cannot create a temporary file in its directory", path);
  }
  const char* data = content.data();
  std::size_t left = content.size();
  while (left > 0) {
    const ssize_t written = ::write(temporary.fd, data, left);
    if (written < 0) {
      if (errno == EINTR) continue;
      throw_errno(errno, "write failed", path);
    }
    data += written;
    left -= static_cast<std::size_t>(written);
  }
  if (::fsync(temporary.fd) != 0) throw_errno(errno, "fsync failed", path);
  const int fd = temporary.fd;
  temporary.fd = -1;
  if (::close(fd) != 0) throw_errno(errno, "close failed", path);
  if (::rename(temporary.path.c_str(), path.c_str()) != 0)
    throw_errno(errno, "rename failed", path);
  temporary.keep = true;
  // Make the rename itself durable; a failure here does not undo the (complete) new file.
  const int directory_fd = ::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (directory_fd >= 0) {
    (void)::fsync(directory_fd);
    ::close(directory_fd);
  }
}

}  // namespace clothbench::harness
