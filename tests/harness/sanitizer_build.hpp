// Whether this test binary is built with AddressSanitizer or ThreadSanitizer (scripts/test
// --sanitize, scripts/tsan-check): those builds run the kernel 10 to 25 times slower, so some
// tests wait longer or leave their heaviest cases to the Release builds.
#pragma once

namespace clothbench_test {

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
inline constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
#else
inline constexpr bool kSanitized = false;
#endif

}  // namespace clothbench_test
