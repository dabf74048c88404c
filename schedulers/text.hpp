// `concat`: builds a message from strings and integers by appending (this also avoids
// GCC 12's false -Wrestrict warning on `"literal" + std::string&&`, GCC PR 105329).
#pragma once

#include <concepts>
#include <string>
#include <string_view>

namespace clothbench::schedulers {

/// Appends one text part.
inline void append_part(std::string& text, std::string_view part) { text.append(part); }
/// Appends one integer in decimal.
template <std::integral Integer>
void append_part(std::string& text, Integer number) {
  text.append(std::to_string(number));
}

/// The parts (strings, string views, C strings, integers) joined without separator.
template <class... Parts>
[[nodiscard]] std::string concat(const Parts&... parts) {
  std::string text;
  (append_part(text, parts), ...);
  return text;
}

}  // namespace clothbench::schedulers
