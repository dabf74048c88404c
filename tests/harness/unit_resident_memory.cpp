// The resident memory of the process and of one run (harness/run/resident_memory.hpp): the
// /proc status lines are read in bytes, malformed ones are refused, and the high-water mark
// can be reset so that a run's peak is its own and not an earlier run's of the same process
// (a sweep makes many runs in one process).
#include <gtest/gtest.h>
#include <sys/mman.h>

#include <cstddef>
#include <cstdint>
#include <cstring>

#include "harness/run/resident_memory.hpp"

namespace {

using clothbench::harness::parse_proc_status_memory;

/// Linux counts a thread's resident pages in batches before they reach the process's counters
/// (and its high-water mark), so the mark can trail a resident set read a moment earlier by a
/// few hundred kB: comparisons of the two allow this much.
constexpr std::uint64_t kCounterSlack = 1u << 20;

TEST(ResidentMemory, StatusLinesAreReadInBytes) {
  const auto m = parse_proc_status_memory(
      "Name:\tclothbench\nVmPeak:\t  900000 kB\nVmHWM:\t    2048 kB\nVmRSS:\t    1024 kB\n"
      "Threads:\t2\n");
  ASSERT_TRUE(m.has_value());
  EXPECT_EQ(m->current_bytes, 1024u * 1024u);
  EXPECT_EQ(m->peak_bytes, 2048u * 1024u);
  // Missing or malformed lines give nothing rather than a wrong figure.
  EXPECT_FALSE(parse_proc_status_memory("VmRSS:\t1024 kB\n").has_value());
  EXPECT_FALSE(parse_proc_status_memory("VmHWM:\t2048 kB\nVmRSS:\tmany kB\n").has_value());
  EXPECT_FALSE(parse_proc_status_memory("VmHWM:\t2048 MB\nVmRSS:\t1024 kB\n").has_value());
  // A key that only starts like another is not taken for it.
  EXPECT_FALSE(parse_proc_status_memory("VmHWMx:\t2048 kB\nVmRSS:\t1024 kB\n").has_value());
}

/// Maps and touches `bytes` of anonymous memory (resident until unmapped).
struct Touched {
  explicit Touched(std::size_t n) : bytes(n) {
    data = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (data != MAP_FAILED) std::memset(data, 1, bytes);
  }
  ~Touched() {
    if (data != MAP_FAILED) munmap(data, bytes);
  }
  Touched(const Touched&) = delete;
  Touched& operator=(const Touched&) = delete;
  std::size_t bytes;
  void* data;
};

TEST(ResidentMemory, ThePeakCanBeResetToTheCurrentResidentSet) {
  constexpr std::size_t kBlock = 64u << 20;
  const auto before = clothbench::harness::read_resident_memory();
  ASSERT_TRUE(before.has_value()) << "/proc/self/status has no VmRSS / VmHWM";
  EXPECT_GE(before->peak_bytes, before->current_bytes);
  std::uint64_t high = 0;
  {
    const Touched block(kBlock);
    ASSERT_NE(block.data, MAP_FAILED);
    const auto with_block = clothbench::harness::read_resident_memory();
    ASSERT_TRUE(with_block.has_value());
    EXPECT_GE(with_block->current_bytes, before->current_bytes + kBlock * 9 / 10);
    high = with_block->peak_bytes;
  }
  // The block is gone; until the reset the peak still remembers it.
  const auto after = clothbench::harness::read_resident_memory();
  ASSERT_TRUE(after.has_value());
  EXPECT_GE(after->peak_bytes + kCounterSlack, high);
  EXPECT_LT(after->current_bytes + kBlock / 2, high);
  // Linux 4.0 and later (every machine clothbench supports) reset it to the resident set now.
  ASSERT_TRUE(clothbench::harness::reset_resident_peak());
  const auto reset = clothbench::harness::read_resident_memory();
  ASSERT_TRUE(reset.has_value());
  EXPECT_LT(reset->peak_bytes + kBlock / 2, high);
  EXPECT_GE(reset->peak_bytes, reset->current_bytes);
}

TEST(ResidentMemory, ARunsPeakIsItsOwn) {
  constexpr std::size_t kBlock = 32u << 20;
  {
    const Touched earlier(2 * kBlock);  // an earlier, larger "run" of the same process
    ASSERT_NE(earlier.data, MAP_FAILED);
  }
  const clothbench::harness::RunMemoryProbe probe;
  std::uint64_t during = 0;
  {
    const Touched block(kBlock);
    ASSERT_NE(block.data, MAP_FAILED);
    during = clothbench::harness::read_resident_memory()->current_bytes;
  }
  const clothbench::harness::RunMemory m = probe.finish();
  EXPECT_EQ(m.scope, "run");
  EXPECT_GE(m.peak_bytes + kCounterSlack, during);
  EXPECT_GE(m.peak_bytes, m.start_bytes + kBlock * 9 / 10);
  // Not the earlier block's peak: this run touched half as much on top of its start.
  EXPECT_LT(m.peak_bytes, m.start_bytes + 2 * kBlock - kBlock / 2);
}

}  // namespace
