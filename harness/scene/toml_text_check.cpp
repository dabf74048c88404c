// The scan for characters toml++ 3.3.0 cannot be given (see toml_text_check.hpp).
#include "harness/scene/toml_text_check.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <vector>

namespace clothbench::harness::scene_detail {
namespace {

// The code point (or the lone byte) starting at text[at], as "U+00E9" or "byte 0xE9".
std::string describe_character(std::string_view text, std::size_t at) {
  const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned lead = byte(at);
  const int length = lead >= 0xF0 ? 4 : lead >= 0xE0 ? 3 : lead >= 0xC0 ? 2 : 0;
  if (length == 0 || at + static_cast<std::size_t>(length) > text.size()) {
    return fmt::format("byte 0x{:02X}", lead);
  }
  std::uint32_t code = lead & (0x7Fu >> length);
  for (int k = 1; k < length; ++k) {
    if ((byte(at + k) & 0xC0) != 0x80) return fmt::format("byte 0x{:02X}", lead);
    code = (code << 6) | (byte(at + k) & 0x3Fu);
  }
  return fmt::format("U+{:04X}", code);
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

// What ends a bare value for toml++ (its is_value_terminator, ASCII part).
bool ends_bare_value(char c) { return is_space(c) || c == ']' || c == '}' || c == ',' || c == '#'; }

// Follows the text the way toml++ reads it, one byte at a time.
class Scanner {
 public:
  explicit Scanner(std::string_view text) : text_(text) {}

  std::optional<UnsafeCharacter> run() {
    if (text_.substr(0, 3) == "\xEF\xBB\xBF") at_ = 3;  // toml++ skips a byte-order mark
    while (at_ < text_.size() && !found_) {
      const std::size_t advance = step();
      for (std::size_t k = 0; k < advance && at_ < text_.size(); ++k, ++at_) {
        if (text_[at_] == '\n') {
          ++line_;
          column_ = 1;
        } else if ((static_cast<unsigned char>(text_[at_]) & 0xC0) != 0x80) {
          ++column_;
        }
      }
    }
    return found_;
  }

 private:
  enum class State { outside, comment, basic, literal, multi_basic, multi_literal };
  // After a backslash in a multi-line basic string: just seen, or skipping the whitespace
  // of a line-ending backslash.
  enum class Backslash { none, just_seen, skipping_space };

  bool non_ascii() const { return (static_cast<unsigned char>(text_[at_]) & 0x80) != 0; }

  std::size_t quotes() const {
    std::size_t n = 0;
    while (at_ + n < text_.size() && text_[at_ + n] == text_[at_]) ++n;
    return n;
  }

  void report(std::string_view where, std::string_view expected) {
    found_ = UnsafeCharacter{
        at_, line_, column_,
        fmt::format("unexpected {} {} ({})", describe_character(text_, at_), where, expected)};
  }

  // Opens a string at a quote; returns the bytes its opening delimiter takes.
  std::size_t open_string() {
    const bool triple = quotes() >= 3;
    if (text_[at_] == '"') {
      state_ = triple ? State::multi_basic : State::basic;
    } else {
      state_ = triple ? State::multi_literal : State::literal;
    }
    return triple ? 3 : 1;
  }

  // A closing run of 3 to 5 quotes (a multi-line string may end with one or two quotes).
  std::size_t close_multi_line() {
    state_ = State::outside;
    return std::min<std::size_t>(quotes(), 5);
  }

  std::size_t step() {
    const char c = text_[at_];
    switch (state_) {
      case State::outside:
        return step_outside(c);
      case State::comment:
        if (c == '\n') state_ = State::outside;
        return 1;
      case State::basic:
      case State::literal:
        if (c == '\n' || c == (state_ == State::basic ? '"' : '\'')) {
          state_ = State::outside;
        } else if (c == '\\' && state_ == State::basic && at_ + 1 < text_.size() &&
                   text_[at_ + 1] != '\n') {
          return 2;  // an escaped character, e.g. \"
        }
        return 1;
      case State::multi_basic:
        return step_multi_basic(c);
      case State::multi_literal:
        return c == '\'' && quotes() >= 3 ? close_multi_line() : 1;
    }
    return 1;
  }

  std::size_t step_multi_basic(char c) {
    if (backslash_ == Backslash::just_seen && !is_space(c)) {
      backslash_ = Backslash::none;
      if (non_ascii()) fail_after_backslash();
      return 1;  // the escaped character
    }
    if (backslash_ != Backslash::none) {
      if (is_space(c)) {
        backslash_ = Backslash::skipping_space;
        return 1;
      }
      backslash_ = Backslash::none;  // the first character after a line-ending backslash
      if (non_ascii()) {
        fail_after_backslash();
        return 1;
      }
    }
    if (c == '\\') backslash_ = Backslash::just_seen;
    if (c == '"' && quotes() >= 3) return close_multi_line();
    return 1;
  }

  void fail_after_backslash() {
    report("after a backslash in a multi-line string",
           "expected an escape such as \\n or \\u00E9, or after a line-ending backslash an ASCII "
           "character");
  }

  // Between strings and comments: keys, '=', values, arrays, inline tables, headers.
  std::size_t step_outside(char c) {
    if (non_ascii()) {
      report("outside a string or comment",
             "TOML allows non-ASCII characters only inside strings and comments");
      return 1;
    }
    if (in_bare_value_) {
      if (!ends_bare_value(c)) return 1;  // quotes and brackets are part of a bare value
      in_bare_value_ = false;
    }
    if (c == '#') {
      state_ = State::comment;
      return 1;
    }
    const bool in_array = !open_.empty() && open_.back() == '[';
    if (expect_value_) {
      if (c == ' ' || c == '\t' || (in_array && is_space(c))) return 1;
      expect_value_ = false;
      if (c == '"' || c == '\'') return open_string();
      if (c == '[') {
        open_.push_back('[');
        expect_value_ = true;
      } else if (c == '{') {
        open_.push_back('{');
      } else if (c == ']' && in_array) {
        open_.pop_back();  // an empty array, or a trailing comma
      } else if (!is_space(c)) {
        in_bare_value_ = true;  // a number, boolean or date, read up to its end
      }
      return 1;
    }
    // Keys (bare or quoted), '.', '=', ',' and closing brackets.
    if (c == '"' || c == '\'') return open_string();
    if (c == '=') {
      expect_value_ = true;
    } else if (c == ',') {
      expect_value_ = in_array;  // in an inline table a key follows
    } else if ((c == ']' && in_array) || (c == '}' && !open_.empty() && open_.back() == '{')) {
      open_.pop_back();
    }
    return 1;  // '[' and ']' of a table header, key characters, whitespace
  }

  std::string_view text_;
  std::size_t at_ = 0;
  std::size_t line_ = 1;
  std::size_t column_ = 1;
  State state_ = State::outside;
  Backslash backslash_ = Backslash::none;
  bool expect_value_ = false;   ///< after '=', '[' of an array, or ',' in an array
  bool in_bare_value_ = false;  ///< inside a value that is not a string, array or table
  std::vector<char> open_;      ///< open arrays '[' and inline tables '{', innermost last
  std::optional<UnsafeCharacter> found_;
};

}  // namespace

std::optional<UnsafeCharacter> find_character_toml_cannot_take(std::string_view text) {
  return Scanner(text).run();
}

}  // namespace clothbench::harness::scene_detail
