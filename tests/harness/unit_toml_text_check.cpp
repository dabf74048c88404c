// The scan that keeps toml++ 3.3.0 away from the non-ASCII characters it cannot classify
// (harness/scene/toml_text_check.hpp): valid TOML with non-ASCII text wherever TOML allows it
// passes untouched; a non-ASCII character anywhere toml++ would test it for whitespace is a
// located syntax error; an earlier syntax error is still reported first; and every input the
// fuzzer found (tests/fuzz/regressions) loads or is rejected with a located message.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "harness/scene/scene.hpp"
#include "harness/scene/toml_reader.hpp"
#include "harness/scene/toml_text_check.hpp"

namespace {

namespace fs = std::filesystem;
using clothbench::harness::SceneError;
using clothbench::harness::scene_detail::find_character_toml_cannot_take;
using clothbench::harness::scene_detail::parse_toml;
using testing::HasSubstr;
using testing::StartsWith;

// Every place TOML 1.0 allows non-ASCII text: comments, the four kinds of string (values,
// quoted keys, table headers, array elements, inline tables), escapes and line-ending
// backslashes followed by ASCII text.
constexpr const char* kValid = R"toml(# Überschrift – a comment with é, ß, Ж and 中文
[scene]
name = "Baumwolle, Ж, 中文"  # trailing comment ü
description = """
Mehrzeilig: é \"quoted\" \u00E9 \
   line-ending backslash, then ASCII: ü""ä"""
literal = 'C:\Wäsche\'
multi_literal = '''
Zeile mit '' und ü'''''
"schlüssel" = 1
"ключ".'內' = 2
dates = [1979-05-27 07:32:00Z, 1979-05-27T00:32:00.999999-07:00, 07:32:00]
nested = [["ä", 'ö'], [ # comment in an array: ü
  """ß""", {"ĸey" = "välue", plain = 3},
], ]
inline = { a = "ü", b = [1, "ö"], c = { d = 'é' } }
"quoted ]" = 0.5e-3
[["tåble"]]
x = true
)toml";

TEST(TomlTextCheck, NonAsciiWhereTomlAllowsItPassesAndParses) {
  EXPECT_FALSE(find_character_toml_cannot_take(kValid).has_value())
      << find_character_toml_cannot_take(kValid)->problem;
  try {
    const toml::table document = parse_toml(kValid, "valid.toml");
    EXPECT_EQ(document["scene"]["name"].value_or(std::string()), "Baumwolle, Ж, 中文");
    EXPECT_EQ(document["scene"]["multi_literal"].value_or(std::string()), "Zeile mit '' und ü''");
    EXPECT_EQ(document["scene"]["nested"][1][1]["ĸey"].value_or(std::string()), "välue");
  } catch (const SceneError& error) {
    FAIL() << error.what();
  }
}

struct Refused {
  const char* text;
  const char* unsafe_at;      // "LINE:COLUMN" of the character toml++ must not be given
  const char* message_start;  // after "t.toml:"
};

class TomlTextRefused : public testing::TestWithParam<Refused> {};

TEST_P(TomlTextRefused, IsALocatedSyntaxError) {
  const auto unsafe = find_character_toml_cannot_take(GetParam().text);
  ASSERT_TRUE(unsafe.has_value()) << GetParam().text;
  EXPECT_EQ(std::to_string(unsafe->line) + ":" + std::to_string(unsafe->column),
            GetParam().unsafe_at);
  try {
    (void)parse_toml(GetParam().text, "t.toml");
    FAIL() << "accepted: " << GetParam().text;
  } catch (const SceneError& error) {
    EXPECT_THAT(error.what(), StartsWith(std::string("t.toml:") + GetParam().message_start));
  }
}

INSTANTIATE_TEST_SUITE_P(
    TomlTextCheck, TomlTextRefused,
    testing::Values(
        Refused{"a = 1é\n", "1:6", "1:6: TOML syntax error: unexpected U+00E9 outside a string"},
        Refused{"a = \"x\"é\n", "1:8", "1:8: TOML syntax error: unexpected U+00E9 outside"},
        Refused{"é = 1\n", "1:1", "1:1: TOML syntax error: unexpected U+00E9 outside"},
        Refused{"s = \"\"\"\\\n§\"\"\"\n", "2:1",
                "2:1: TOML syntax error: unexpected U+00A7 after a backslash in a multi-line"},
        Refused{"s = \"\"\"a \\  \n\n   ж\"\"\"\n", "3:4",
                "3:4: TOML syntax error: unexpected U+0436 after a backslash"},
        Refused{"s = \"\"\"\\é\"\"\"\n", "1:9", "1:9: TOML syntax error: unexpected U+00E9 after"},
        Refused{"a = \xff\n", "1:5", "1:5: TOML syntax error: unexpected byte 0xFF outside"},
        // Quotes and brackets inside a bare value open nothing: toml++ reads on to the
        // character (the scan stops it there), and reports the bad value before it.
        Refused{"[a]\nb = 0.1'''x'''Ï\n", "2:15", "2:8: TOML syntax error: "},
        Refused{"b = 0.[\"Ϝ\"\n", "1:9", "1:7: TOML syntax error: "},
        Refused{"b = [1, 2]\nc = [x\"Ж\"]\n", "2:8", "2:6: TOML syntax error: "},
        // A syntax error before the character is reported first.
        Refused{"a = = 1\nb = 1é\n", "2:6", "1:5: TOML syntax error: "}));

TEST(TomlTextCheck, EveryFuzzerFindingLoadsOrIsRejectedWithALocation) {
  const fs::path dir = fs::path(CLOTHBENCH_SOURCE_DIR) / "tests" / "fuzz" / "regressions";
  int count = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    std::ifstream in(entry.path(), std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    ++count;
    try {  // loading is fine too: what matters is that nothing else happens
      (void)clothbench::harness::parse_scene(text.str(), "found.toml",
                                             clothbench::harness::default_presets_file());
    } catch (const SceneError& error) {
      EXPECT_THAT(error.what(), testing::MatchesRegex("found\\.toml:[0-9]+:[0-9]+: .*"))
          << entry.path();
    }
  }
  EXPECT_GE(count, 3);
}

}  // namespace
