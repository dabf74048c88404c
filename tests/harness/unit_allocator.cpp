// The allocator policy (harness/machine/allocator.hpp): freed large blocks leave the process,
// the policy is recorded with the machine context, and a user's MALLOC_MMAP_THRESHOLD_ wins.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "harness/machine/allocator.hpp"
#include "harness/machine/machine_context.hpp"
#include "tests/harness/clothbench_process.hpp"
#include "tests/harness/sanitizer_build.hpp"

namespace {

using clothbench::harness::AllocatorPolicy;
using clothbench::harness::configure_allocator;
using clothbench::harness::kLargeBlockBytes;

/// VmRSS of this process in bytes (/proc/self/status).
std::int64_t resident_bytes() {
  std::FILE* status = std::fopen("/proc/self/status", "r");
  if (status == nullptr) return -1;
  char line[256];
  long kib = -1;
  while (std::fgets(line, sizeof line, status) != nullptr) {
    if (std::sscanf(line, "VmRSS: %ld", &kib) == 1) break;
  }
  std::fclose(status);
  return kib < 0 ? -1 : std::int64_t{kib} * 1024;
}

/// What the policy must be in this build: the fixed threshold, except under a sanitizer, whose
/// allocator replaces glibc's and refuses mallopt (the policy then says the allocator keeps
/// its own).
/// `user`: the MALLOC_MMAP_THRESHOLD_ the process was started with (0: none).
nlohmann::json expected_policy(const std::string& library, std::int64_t user = 0) {
  if (clothbench_test::kSanitized) {
    return {{"library", library}, {"mmap_threshold_bytes", nullptr}, {"source", "allocator default"}};
  }
  if (user > 0) {
    return {{"library", library}, {"mmap_threshold_bytes", user}, {"source", "environment"}};
  }
  return {{"library", library}, {"mmap_threshold_bytes", kLargeBlockBytes}, {"source", "clothbench"}};
}

/// `bytes` from malloc with every page written (so that it is resident).
std::unique_ptr<char, decltype(&std::free)> touched_block(std::size_t bytes) {
  std::unique_ptr<char, decltype(&std::free)> block(static_cast<char*>(std::malloc(bytes)),
                                                    &std::free);
  if (block != nullptr) std::memset(block.get(), 1, bytes);
  return block;
}

TEST(AllocatorPolicy, FreedLargeBlocksLeaveTheProcess) {
#if !defined(__GLIBC__)
  GTEST_SKIP() << "the policy is glibc's mallopt; this C library keeps its own";
#else
  ASSERT_EQ(std::getenv("MALLOC_MMAP_THRESHOLD_"), nullptr) << "the test sets its own policy";
  const AllocatorPolicy policy = configure_allocator();
  ASSERT_EQ(clothbench::harness::to_json(policy), expected_policy(policy.library));
  if (clothbench_test::kSanitized) return;  // the sanitizer's allocator quarantines freed blocks
  // The pattern that kept memory resident under glibc's default: one large block freed (which
  // raises the default threshold above its size), then many of that size, all freed but the
  // last. Without the policy they come from the heap, whose top the last one pins.
  constexpr std::size_t kBlock = 4u << 20;
  constexpr int kBlocks = 48;
  touched_block(kBlock).reset();
  const std::int64_t before = resident_bytes();
  ASSERT_GT(before, 0);
  std::vector<std::unique_ptr<char, decltype(&std::free)>> blocks;
  for (int b = 0; b < kBlocks; ++b) {
    blocks.push_back(touched_block(kBlock));
    ASSERT_NE(blocks.back(), nullptr);
  }
  const std::int64_t held = resident_bytes();
  EXPECT_GE(held - before, std::int64_t{kBlocks - 1} * std::int64_t{kBlock})
      << "the blocks were not resident: the test measures nothing";
  for (int b = 0; b + 1 < kBlocks; ++b) blocks[static_cast<std::size_t>(b)].reset();
  const std::int64_t after = resident_bytes();
  // The last block and a few pages of bookkeeping stay; 47 blocks (188 MiB) must have gone.
  EXPECT_LT(after - before, std::int64_t{2 * kBlock})
      << "before " << before << " B, holding " << held << " B, after freeing " << after << " B";
#endif
}

TEST(AllocatorPolicy, IsRecordedInTheMachineContext) {
  ASSERT_EQ(std::getenv("MALLOC_MMAP_THRESHOLD_"), nullptr) << "the test expects clothbench's";
  const AllocatorPolicy policy = configure_allocator();
  const nlohmann::json recorded = clothbench::harness::machine_context().at("memory").at("allocator");
  EXPECT_EQ(recorded, clothbench::harness::to_json(policy));
  EXPECT_EQ(configure_allocator().source, policy.source) << "a second call changes nothing";
#if defined(__GLIBC__)
  EXPECT_EQ(recorded.at("library").get<std::string>().rfind("glibc ", 0), 0u) << recorded;
  EXPECT_EQ(recorded, expected_policy(policy.library));
#endif
  const std::string summary =
      clothbench::harness::machine_summary(clothbench::harness::machine_context());
  EXPECT_NE(summary.find("allocator "), std::string::npos) << summary;
}

TEST(AllocatorPolicy, TheCommandKeepsAUsersThreshold) {
  using clothbench_test::run;
  const auto own = run("info --json");
  ASSERT_EQ(own.exit_code, 0) << own.output;
  const auto own_policy = nlohmann::json::parse(own.output).at("memory").at("allocator");
  const auto user = run("info --json", "MALLOC_MMAP_THRESHOLD_=65536");
  ASSERT_EQ(user.exit_code, 0) << user.output;
  const auto user_policy = nlohmann::json::parse(user.output).at("memory").at("allocator");
#if defined(__GLIBC__)
  EXPECT_EQ(own_policy, expected_policy(own_policy.at("library").get<std::string>()));
  // glibc reads the variable itself; clothbench records it and sets nothing.
  EXPECT_EQ(user_policy, expected_policy(own_policy.at("library").get<std::string>(), 65536));
  // A form clothbench does not read is the user's all the same: left alone, its value unknown.
  const auto other = run("info --json", "MALLOC_MMAP_THRESHOLD_=0x10000");
  ASSERT_EQ(other.exit_code, 0) << other.output;
  const auto other_policy = nlohmann::json::parse(other.output).at("memory").at("allocator");
  EXPECT_EQ(other_policy.at("source"), "environment") << other_policy;
  EXPECT_TRUE(other_policy.at("mmap_threshold_bytes").is_null()) << other_policy;
#else
  EXPECT_EQ(own_policy, user_policy);
#endif
}

}  // namespace
