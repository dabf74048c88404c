// Internal to harness/scene: typed, range-checked reads from one toml++ table with error
// messages that name file:line:column, section and key (the "parser" half of the loader).
#pragma once

#include <toml++/toml.h>
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace clothbench::harness::scene_detail {

/// Throws SceneError `file:line:column: [section] key: problem (expected)`. An empty key
/// leaves `key` out, an empty `expected` the parenthesis; positions without a line
/// (implicit tables) are reported as 1:1.
[[noreturn]] void fail(const std::string& file, const toml::source_region& where,
                       std::string_view section, std::string_view key, std::string_view problem,
                       std::string_view expected);

/// `text` with control characters (NUL, tab, line breaks, ...) written as \uXXXX, so that a
/// key or value quoted in a message prints whole on one line.
std::string printable(std::string_view text);

/// Parses TOML text; syntax errors become SceneError with toml++'s line and column.
toml::table parse_toml(std::string_view text, const std::string& file);

/// Reads the whole file; failure is a SceneError naming it.
std::string read_text_file(const std::string& file);

/// "a, b, c" from a list of names.
std::string join_names(const std::vector<std::string>& names);

/// The valid name closest to `word` by edit distance if it is a plausible typo, else "".
std::string closest_name(std::string_view word, const std::vector<std::string>& names);

/// A closed/open interval a number must lie in; describes itself for messages.
struct NumberRange {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_inclusive = true;
  bool max_inclusive = true;
  /// e.g. "> 0", ">= 0", "in [0, 1)", "" for any finite number.
  std::string describe() const;
  bool contains(double value) const;

  static NumberRange any() { return {}; }
  static NumberRange positive() {
    return {0.0, std::numeric_limits<double>::infinity(), false, true};
  }
  static NumberRange non_negative() {
    return {0.0, std::numeric_limits<double>::infinity(), true, true};
  }
  static NumberRange at_least(double m) {
    return {m, std::numeric_limits<double>::infinity(), true, true};
  }
  static NumberRange closed(double a, double b) { return {a, b, true, true}; }
  static NumberRange half_open(double a, double b) { return {a, b, true, false}; }
  static NumberRange open(double a, double b) { return {a, b, false, false}; }
  static NumberRange open_closed(double a, double b) { return {a, b, false, true}; }
};

/// One table of the document being read, named `section` in messages ("cloth",
/// "fabric.warp", "obstacle[1]", "cotton-shirting"). Reads return nullopt for absent keys.
class TableReader {
 public:
  TableReader(const toml::table& table, std::string file, std::string section);

  /// Every key not in `valid` is an error listing the valid keys (and a likely typo).
  /// `what` names the owner for messages, e.g. "key" or "key for kind = \"box\"".
  void allow_only(const std::vector<std::string>& valid, std::string_view what = "key") const;

  std::optional<double> number(std::string_view key, const NumberRange& range,
                               std::string_view unit = {}) const;
  std::optional<std::int64_t> integer(
      std::string_view key, std::int64_t min,
      std::int64_t max = std::numeric_limits<std::int64_t>::max()) const;
  std::optional<bool> boolean(std::string_view key) const;
  std::optional<std::string> string(std::string_view key) const;
  /// A string that must be one of `valid`.
  std::optional<std::string> choice(std::string_view key,
                                    const std::vector<std::string>& valid) const;
  /// [x, y, z] of finite numbers, each in `range`.
  std::optional<Eigen::Vector3d> vector3(std::string_view key, const NumberRange& range,
                                         std::string_view unit = {}) const;
  /// [a, b] of finite numbers, each in `range`.
  std::optional<std::array<double, 2>> number_pair(std::string_view key, const NumberRange& range,
                                                   std::string_view unit = {}) const;
  /// [a, b] of integers, each in [min, max].
  std::optional<std::array<std::int64_t, 2>> integer_pair(std::string_view key, std::int64_t min,
                                                          std::int64_t max) const;
  /// A sub-table (nullptr when absent; an error when the key holds something else).
  const toml::table* table(std::string_view key) const;
  /// A raw node (nullptr when absent).
  const toml::node* node(std::string_view key) const;

  /// Fails at `at` (a node of this table) for `key`.
  [[noreturn]] void fail_at(const toml::source_region& at, std::string_view key,
                            std::string_view problem, std::string_view expected) const;
  /// Where `key`'s value is (the table's own position when absent).
  const toml::source_region& where(std::string_view key) const;

  const toml::table& raw() const { return table_; }
  const std::string& file() const { return file_; }
  const std::string& section() const { return section_; }

 private:
  double checked_number(const toml::node& n, std::string_view key, const NumberRange& range,
                        std::string_view unit) const;

  const toml::table& table_;
  std::string file_;
  std::string section_;
};

/// "a string", "an integer", ... for messages.
std::string describe_type(const toml::node& n);

}  // namespace clothbench::harness::scene_detail
