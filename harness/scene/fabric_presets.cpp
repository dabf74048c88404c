// Fabric presets (scenarios/presets/fabrics.toml) and the KES fabric table reader.
#include <fmt/format.h>

#include "harness/scene/fabric_reader.hpp"
#include "harness/scene/scene.hpp"

namespace clothbench::harness {
namespace scene_detail {
namespace {

const std::vector<std::string> kDirectionKeys = {"emt_percent", "lt", "rt_percent", "bending_b",
                                                 "bending_2hb"};
const std::vector<std::string> kFabricKeys = {
    "weight_mg_per_cm2", "thickness_mm", "fm_gf_per_cm", "kappa0_per_cm",
    "tension_plateau_slope", "warp", "weft"};

// One thread direction's tensile and bending data (MODEL.md section 3).
void read_direction(const TableReader& reader, kernels::KesDirection& direction) {
  reader.allow_only(kDirectionKeys);
  // EMT: strain at Fm, %. LT in (0, 2) keeps p = 2/LT - 1 > 0; RT <= 100 keeps q >= p.
  if (auto v = reader.number("emt_percent", NumberRange::open(0.0, 100.0), "%"))
    direction.emt_percent = *v;
  if (auto v = reader.number("lt", NumberRange::open(0.0, 2.0))) direction.lt = *v;
  if (auto v = reader.number("rt_percent", NumberRange::open_closed(0.0, 100.0), "%"))
    direction.rt_percent = *v;
  if (auto v = reader.number("bending_b", NumberRange::positive(), "gf cm^2/cm"))
    direction.bending_b = *v;
  if (auto v = reader.number("bending_2hb", NumberRange::non_negative(), "gf cm/cm"))
    direction.bending_2hb = *v;
}

}  // namespace

void read_fabric(const TableReader& reader, kernels::KesParameters& fabric,
                 const std::vector<std::string>& extra_keys) {
  std::vector<std::string> valid = extra_keys;
  valid.insert(valid.end(), kFabricKeys.begin(), kFabricKeys.end());
  reader.allow_only(valid);
  if (auto v = reader.number("weight_mg_per_cm2", NumberRange::positive(), "mg/cm^2"))
    fabric.weight_mg_per_cm2 = *v;
  if (auto v = reader.number("thickness_mm", NumberRange::positive(), "mm"))
    fabric.thickness_mm = *v;
  if (auto v = reader.number("fm_gf_per_cm", NumberRange::positive(), "gf/cm"))
    fabric.fm_gf_per_cm = *v;
  if (auto v = reader.number("kappa0_per_cm", NumberRange::positive(), "1/cm"))
    fabric.kappa0_per_cm = *v;
  // The tilted tension plateau (kernels/tilted_plateau.hpp): opt-in, in units of Fm / EMT;
  // its bound against the loading exponent is kernels::validate's.
  if (auto v = reader.number("tension_plateau_slope", NumberRange::half_open(0.0, 1.0), "Fm/EMT"))
    fabric.tension_plateau_slope = *v;
  if (const toml::table* warp = reader.table("warp")) {
    read_direction(TableReader(*warp, reader.file(), reader.section() + ".warp"), fabric.warp);
  }
  if (const toml::table* weft = reader.table("weft")) {
    read_direction(TableReader(*weft, reader.file(), reader.section() + ".weft"), fabric.weft);
  }
}

PresetsDocument open_presets(const std::string& file) {
  const std::string text = read_text_file(file);
  return PresetsDocument{file, parse_toml(text, file)};
}

std::vector<std::string> preset_names(const PresetsDocument& presets) {
  std::vector<std::string> names;
  for (auto&& [key, value] : presets.document) names.emplace_back(key.str());
  std::sort(names.begin(), names.end());
  return names;
}

std::optional<kernels::KesParameters> find_preset(const PresetsDocument& presets,
                                                  std::string_view name) {
  const toml::node* node = presets.document.get(name);
  if (node == nullptr) return std::nullopt;
  const toml::table* table = node->as_table();
  if (table == nullptr) {
    fail(presets.file, node->source(), name, "", fmt::format("got {}", describe_type(*node)),
         "expected a table of KES parameters");
  }
  const TableReader reader(*table, presets.file, std::string(name));
  // A preset states every value: defaults must not leak into a named fabric silently.
  for (const auto& key : {"weight_mg_per_cm2", "thickness_mm", "warp", "weft"}) {
    if (reader.node(key) == nullptr) {
      reader.fail_at(table->source(), key, "missing",
                     "every preset gives weight_mg_per_cm2, "
                     "thickness_mm and complete warp and weft tables");
    }
  }
  for (const auto& direction : {"warp", "weft"}) {
    if (const toml::table* sub = reader.table(direction)) {
      for (const auto& key : kDirectionKeys) {
        if (sub->get(key) == nullptr) {
          fail(presets.file, sub->source(), fmt::format("{}.{}", name, direction), key, "missing",
               "every preset gives emt_percent, lt, rt_percent, bending_b and bending_2hb");
        }
      }
    }
  }
  kernels::KesParameters fabric;
  read_fabric(reader, fabric, {"description"});
  (void)reader.string("description");
  return fabric;
}

}  // namespace scene_detail

std::vector<std::string> fabric_preset_names(const std::filesystem::path& presets_file) {
  return scene_detail::preset_names(scene_detail::open_presets(presets_file.string()));
}

kernels::KesParameters load_fabric_preset(const std::filesystem::path& presets_file,
                                          std::string_view name) {
  const auto presets = scene_detail::open_presets(presets_file.string());
  if (auto fabric = scene_detail::find_preset(presets, name)) return *fabric;
  const auto names = scene_detail::preset_names(presets);
  std::string expected = fmt::format("valid presets: {}", scene_detail::join_names(names));
  if (const auto guess = scene_detail::closest_name(name, names); !guess.empty()) {
    expected = fmt::format("did you mean '{}'? {}", guess, expected);
  }
  scene_detail::fail(presets.file, presets.document.source(), name, "", "unknown fabric preset",
                     expected);
}

}  // namespace clothbench::harness
