// Internal to harness/scene: a scan of TOML text for the characters toml++ 3.3.0 (Debian 12)
// cannot be given. Asked whether certain non-ASCII characters (U+00A1-U+0499 and
// U+2E9E-U+3297, except U+3000) are whitespace, it reaches __builtin_unreachable():
// undefined behaviour (upstream issues marzer/tomlplusplus#190 and #295, fixed after 3.3.0;
// found here by tests/fuzz/fuzz_scene.cpp). It asks that of every character it reads outside
// strings and comments - between tokens and through a bare value up to the next space, ']',
// '}', ',' or '#' - and of the first character after a backslash in a multi-line basic
// string once spaces and line breaks are skipped. TOML 1.0 allows no non-ASCII character in
// any of those places, so parse_toml reports the first one as a syntax error instead of
// handing the text to toml++.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

namespace clothbench::harness::scene_detail {

/// A character parse_toml refuses, with its position (1-based; columns count code points,
/// as toml++'s do).
struct UnsafeCharacter {
  std::size_t offset = 0;  ///< byte offset in the text
  std::size_t line = 1;
  std::size_t column = 1;
  std::string problem;  ///< e.g. "unexpected U+00E9 outside a string or comment (...)"
};

/// The first non-ASCII character toml++ would test for whitespace, following TOML's strings,
/// comments, bare values, arrays and inline tables; nullopt when there is none.
std::optional<UnsafeCharacter> find_character_toml_cannot_take(std::string_view text);

}  // namespace clothbench::harness::scene_detail
