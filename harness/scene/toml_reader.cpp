// Typed, range-checked reads from toml++ tables with file:line:column messages.
#include "harness/scene/toml_reader.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include "harness/scene/scene.hpp"
#include "harness/scene/toml_text_check.hpp"

namespace clothbench::harness::scene_detail {

std::string printable(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte < 0x20 || byte == 0x7F) {
      out += fmt::format("\\u{:04X}", static_cast<unsigned>(byte));
    } else {
      out += c;
    }
  }
  return out;
}

void fail(const std::string& file, const toml::source_region& where, std::string_view section,
          std::string_view key, std::string_view problem, std::string_view expected) {
  const bool has_position = where.begin.line > 0;
  const auto line = has_position ? where.begin.line : 1u;
  const auto column = has_position && where.begin.column > 0 ? where.begin.column : 1u;
  std::string message = fmt::format("{}:{}:{}: [{}]", file, line, column, section);
  if (!key.empty()) message += fmt::format(" {}", key);
  message += fmt::format(": {}", problem);
  if (!expected.empty()) message += fmt::format(" ({})", expected);
  throw SceneError(printable(message));
}

toml::table parse_toml(std::string_view text, const std::string& file) {
  auto syntax_error = [&](const toml::parse_error& error) {
    const auto& where = error.source();
    return SceneError(printable(fmt::format(
        "{}:{}:{}: TOML syntax error: {}", file, std::max<toml::source_index>(where.begin.line, 1),
        std::max<toml::source_index>(where.begin.column, 1), error.description())));
  };
  if (const auto bad = find_character_toml_cannot_take(text)) {
    // toml++ must not read that character; the text before it is safe. A syntax error there
    // comes first. A space stands in for the character, so that an error the cut causes
    // (end of file inside a string, say) is located at or after it.
    try {
      (void)toml::parse(std::string(text.substr(0, bad->offset)) + " ", std::string_view(file));
    } catch (const toml::parse_error& error) {
      const auto& at = error.source().begin;
      if (at.line < bad->line || (at.line == bad->line && at.column < bad->column)) {
        throw syntax_error(error);
      }
    }
    throw SceneError(
        fmt::format("{}:{}:{}: TOML syntax error: {}", file, bad->line, bad->column, bad->problem));
  }
  try {
    return toml::parse(text, std::string_view(file));
  } catch (const toml::parse_error& error) {
    throw syntax_error(error);
  }
}

std::string read_text_file(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    throw SceneError(fmt::format("{}: cannot open: {}", file, std::strerror(errno)));
  }
  std::ostringstream content;
  content << in.rdbuf();
  if (in.bad()) throw SceneError(fmt::format("{}: read error", file));
  return content.str();
}

std::string join_names(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& name : names) {
    if (!out.empty()) out += ", ";
    out += name;
  }
  return out;
}

std::string closest_name(std::string_view word, const std::vector<std::string>& names) {
  // Optimal-string-alignment distance (edits and adjacent transpositions); a suggestion
  // only when it is small against the word's length. No valid name is longer than this, so
  // a longer word is no typo of one (and its distance table is not worth building).
  constexpr std::size_t kLongestTypo = 64;
  if (word.size() > kLongestTypo) return {};
  auto distance = [](std::string_view a, std::string_view b) {
    std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
    for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
    for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
      for (std::size_t j = 1; j <= b.size(); ++j) {
        const std::size_t cost = a[i - 1] == b[j - 1] ? 0 : 1;
        d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
        if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) {
          d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
        }
      }
    }
    return d[a.size()][b.size()];
  };
  std::string best;
  std::size_t best_distance = std::max<std::size_t>(1, word.size() / 3) + 1;
  for (const auto& name : names) {
    const std::size_t d = distance(word, name);
    if (d < best_distance) {
      best_distance = d;
      best = name;
    }
  }
  return best;
}

std::string NumberRange::describe() const {
  const bool low = std::isfinite(min);
  const bool high = std::isfinite(max);
  if (low && high) {
    return fmt::format("in {}{}, {}{}", min_inclusive ? '[' : '(', min, max,
                       max_inclusive ? ']' : ')');
  }
  if (low) return fmt::format("{} {}", min_inclusive ? ">=" : ">", min);
  if (high) return fmt::format("{} {}", max_inclusive ? "<=" : "<", max);
  return {};
}

bool NumberRange::contains(double value) const {
  const bool above = min_inclusive ? value >= min : value > min;
  const bool below = max_inclusive ? value <= max : value < max;
  return above && below;
}

namespace {
// `text` cut to about 40 bytes at a UTF-8 character boundary, "..." marking the cut.
std::string abbreviated(std::string_view text) {
  constexpr std::size_t kLimit = 40;
  if (text.size() <= kLimit) return std::string(text);
  std::size_t end = kLimit;
  while (end > 0 && (static_cast<unsigned char>(text[end]) & 0xC0) == 0x80) --end;
  return std::string(text.substr(0, end)) + "...";
}
}  // namespace

std::string describe_type(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::string:
      return fmt::format("the string \"{}\"", abbreviated(*n.value<std::string>()));
    case toml::node_type::integer:
      return fmt::format("the integer {}", *n.value<std::int64_t>());
    case toml::node_type::floating_point:
      return fmt::format("the number {}", *n.value<double>());
    case toml::node_type::boolean:
      return fmt::format("the boolean {}", *n.value<bool>());
    case toml::node_type::table:
      return "a table";
    case toml::node_type::array:
      return "an array";
    case toml::node_type::date:
      return "a date";
    case toml::node_type::time:
      return "a time";
    case toml::node_type::date_time:
      return "a date-time";
    default:
      return "nothing";
  }
}

TableReader::TableReader(const toml::table& table, std::string file, std::string section)
    : table_(table), file_(std::move(file)), section_(std::move(section)) {}

void TableReader::allow_only(const std::vector<std::string>& valid, std::string_view what) const {
  for (auto&& [key, value] : table_) {
    const std::string name(key.str());
    if (std::find(valid.begin(), valid.end(), name) != valid.end()) continue;
    std::string expected = fmt::format("valid keys: {}", join_names(valid));
    if (const auto suggestion = closest_name(name, valid); !suggestion.empty()) {
      expected = fmt::format("did you mean '{}'? {}", suggestion, expected);
    }
    fail(file_, key.source(), section_, name, fmt::format("unknown {}", what), expected);
  }
}

const toml::source_region& TableReader::where(std::string_view key) const {
  if (const toml::node* n = table_.get(key)) return n->source();
  return table_.source();
}

void TableReader::fail_at(const toml::source_region& at, std::string_view key,
                          std::string_view problem, std::string_view expected) const {
  fail(file_, at, section_, key, problem, expected);
}

const toml::node* TableReader::node(std::string_view key) const { return table_.get(key); }

double TableReader::checked_number(const toml::node& n, std::string_view key,
                                   const NumberRange& range, std::string_view unit) const {
  const std::string range_text = range.describe();
  const std::string expected =
      fmt::format("expected a finite number{}{}{}{}", range_text.empty() ? "" : " ", range_text,
                  unit.empty() ? "" : ", ", unit);
  if (!n.is_number()) fail_at(n.source(), key, fmt::format("got {}", describe_type(n)), expected);
  const double value = *n.value<double>();
  if (!std::isfinite(value))
    fail_at(n.source(), key, fmt::format("{} is not finite", value), expected);
  if (!range.contains(value))
    fail_at(n.source(), key, fmt::format("{} is out of range", value), expected);
  return value;
}

std::optional<double> TableReader::number(std::string_view key, const NumberRange& range,
                                          std::string_view unit) const {
  const toml::node* n = node(key);
  if (n == nullptr) return std::nullopt;
  return checked_number(*n, key, range, unit);
}

std::optional<std::int64_t> TableReader::integer(std::string_view key, std::int64_t min,
                                                 std::int64_t max) const {
  const toml::node* n = node(key);
  if (n == nullptr) return std::nullopt;
  const std::string expected = max == std::numeric_limits<std::int64_t>::max()
                                   ? fmt::format("expected an integer >= {}", min)
                                   : fmt::format("expected an integer in [{}, {}]", min, max);
  if (!n->is_integer())
    fail_at(n->source(), key, fmt::format("got {}", describe_type(*n)), expected);
  const std::int64_t value = *n->value<std::int64_t>();
  if (value < min || value > max)
    fail_at(n->source(), key, fmt::format("{} is out of range", value), expected);
  return value;
}

std::optional<bool> TableReader::boolean(std::string_view key) const {
  const toml::node* n = node(key);
  if (n == nullptr) return std::nullopt;
  if (!n->is_boolean()) {
    fail_at(n->source(), key, fmt::format("got {}", describe_type(*n)), "expected true or false");
  }
  return *n->value<bool>();
}

std::optional<std::string> TableReader::string(std::string_view key) const {
  const toml::node* n = node(key);
  if (n == nullptr) return std::nullopt;
  if (!n->is_string())
    fail_at(n->source(), key, fmt::format("got {}", describe_type(*n)), "expected a string");
  return *n->value<std::string>();
}

std::optional<std::string> TableReader::choice(std::string_view key,
                                               const std::vector<std::string>& valid) const {
  const toml::node* n = node(key);
  if (n == nullptr) return std::nullopt;
  const std::string expected = fmt::format("expected one of: {}", join_names(valid));
  if (!n->is_string())
    fail_at(n->source(), key, fmt::format("got {}", describe_type(*n)), expected);
  std::string value = *n->value<std::string>();
  if (std::find(valid.begin(), valid.end(), value) == valid.end()) {
    fail_at(n->source(), key, fmt::format("unknown value \"{}\"", value), expected);
  }
  return value;
}

namespace {
// The array at `key` with exactly `count` elements, or a failure.
const toml::array& sized_array(const TableReader& reader, const toml::node& n, std::string_view key,
                               std::size_t count, std::string_view element_text) {
  const std::string expected = fmt::format("expected an array of {} {}", count, element_text);
  const toml::array* array = n.as_array();
  if (array == nullptr)
    reader.fail_at(n.source(), key, fmt::format("got {}", describe_type(n)), expected);
  if (array->size() != count) {
    reader.fail_at(n.source(), key, fmt::format("got {} elements", array->size()), expected);
  }
  return *array;
}
}  // namespace

std::optional<Eigen::Vector3d> TableReader::vector3(std::string_view key, const NumberRange& range,
                                                    std::string_view unit) const {
  const toml::node* n = node(key);
  if (n == nullptr) return std::nullopt;
  const toml::array& array = sized_array(*this, *n, key, 3, "numbers");
  Eigen::Vector3d v;
  for (int k = 0; k < 3; ++k)
    v[k] = checked_number(*array.get(static_cast<std::size_t>(k)), key, range, unit);
  return v;
}

std::optional<std::array<double, 2>> TableReader::number_pair(std::string_view key,
                                                              const NumberRange& range,
                                                              std::string_view unit) const {
  const toml::node* n = node(key);
  if (n == nullptr) return std::nullopt;
  const toml::array& array = sized_array(*this, *n, key, 2, "numbers");
  return std::array<double, 2>{checked_number(*array.get(0), key, range, unit),
                               checked_number(*array.get(1), key, range, unit)};
}

std::optional<std::array<std::int64_t, 2>> TableReader::integer_pair(std::string_view key,
                                                                     std::int64_t min,
                                                                     std::int64_t max) const {
  const toml::node* n = node(key);
  if (n == nullptr) return std::nullopt;
  const toml::array& array = sized_array(*this, *n, key, 2, "integers");
  const std::string expected = fmt::format("expected integers in [{}, {}]", min, max);
  std::array<std::int64_t, 2> out{};
  for (std::size_t k = 0; k < 2; ++k) {
    const toml::node& element = *array.get(k);
    if (!element.is_integer()) {
      fail_at(element.source(), key, fmt::format("got {}", describe_type(element)), expected);
    }
    out[k] = *element.value<std::int64_t>();
    if (out[k] < min || out[k] > max) {
      fail_at(element.source(), key, fmt::format("{} is out of range", out[k]), expected);
    }
  }
  return out;
}

const toml::table* TableReader::table(std::string_view key) const {
  const toml::node* n = node(key);
  if (n == nullptr) return nullptr;
  if (!n->is_table())
    fail_at(n->source(), key, fmt::format("got {}", describe_type(*n)), "expected a table");
  return n->as_table();
}

}  // namespace clothbench::harness::scene_detail
