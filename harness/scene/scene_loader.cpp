// Builds a validated kernels::SimulationConfig from a parsed scene file. Each section has
// one function; every value is range-checked where it is read (toml_reader.hpp), and the
// cross-checks (pins inside the grid, AMRC sizes, thresholds) follow. Keys: scenarios/README.md.
#include <fmt/format.h>
#include <Eigen/Geometry>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <set>
#include <stdexcept>

#include "harness/scene/event_reader.hpp"
#include "harness/scene/fabric_reader.hpp"
#include "harness/scene/initial_overlap.hpp"
#include "harness/scene/scene.hpp"
#include "harness/scene/toml_reader.hpp"

namespace clothbench::harness {
namespace {

using scene_detail::fail;
using scene_detail::NumberRange;
using scene_detail::TableReader;

constexpr std::int64_t kMaxParticles = 1'000'000;  // per direction; far above any sane run

const std::vector<std::string> kSections = {"scene",  "cloth", "fabric",   "time", "contact",
                                            "solver", "amrc",  "obstacle", "event"};

// Where the particle counts were written: each count (for the AMRC size check) and the
// whole [I, J] value (kept in Scene for the memory check).
struct ClothSources {
  toml::source_region particles[2];
  toml::source_region particles_value;
};

// A unit vector from `key`, or a failure when it has zero length.
std::optional<Eigen::Vector3d> unit_vector(const TableReader& reader, std::string_view key) {
  auto v = reader.vector3(key, NumberRange::any());
  if (!v) return std::nullopt;
  const double length = v->norm();
  if (!(length > 1e-12)) {
    reader.fail_at(reader.where(key), key, "zero-length vector",
                   "expected a direction; it is normalised");
  }
  return *v / length;
}

void read_scene_section(const TableReader& reader, Scene& scene) {
  reader.allow_only({"name", "description", "steps"});
  if (auto v = reader.string("name")) scene.name = *v;
  if (auto v = reader.string("description")) scene.description = *v;
  if (auto v = reader.integer("steps", 1, std::numeric_limits<int>::max()))
    scene.steps = static_cast<int>(*v);
}

// [cloth]: the particle grid, its placement, pins and initial perturbation.
ClothSources read_cloth(const TableReader& reader, kernels::ClothConfig& cloth) {
  reader.allow_only({"particles", "size_m", "origin_m", "axis_i", "axis_j", "block", "fabric",
                     "pinned", "initial_stretch", "initial_crumple_m", "seed"});
  ClothSources sources;
  const auto particles = reader.integer_pair("particles", 2, kMaxParticles);
  if (!particles) {
    reader.fail_at(reader.raw().source(), "particles", "missing required key",
                   "expected particles = [I, J], integers >= 2");
  }
  cloth.particles_i = static_cast<int>((*particles)[0]);
  cloth.particles_j = static_cast<int>((*particles)[1]);
  const toml::array& counts = *reader.node("particles")->as_array();
  sources.particles[0] = counts.get(0)->source();
  sources.particles[1] = counts.get(1)->source();
  sources.particles_value = reader.where("particles");

  if (auto v = reader.number_pair("size_m", NumberRange::positive(), "m")) {
    cloth.size_i = (*v)[0];
    cloth.size_j = (*v)[1];
  }
  if (auto v = reader.vector3("origin_m", NumberRange::any(), "m")) cloth.origin = *v;
  if (auto v = unit_vector(reader, "axis_i")) cloth.axis_i = *v;
  if (auto v = unit_vector(reader, "axis_j")) cloth.axis_j = *v;
  if (cloth.axis_i.cross(cloth.axis_j).norm() < 1e-6) {
    reader.fail_at(reader.where(reader.node("axis_j") ? "axis_j" : "axis_i"),
                   reader.node("axis_j") ? "axis_j" : "axis_i", "parallel to the other axis",
                   "expected axis_i and axis_j to span the cloth's plane");
  }
  if (auto v = reader.integer("block", 2, kMaxParticles)) cloth.block_size = static_cast<int>(*v);
  if (auto v = reader.number("initial_stretch", NumberRange{-1.0, 1e300, false, true})) {
    cloth.initial_stretch = *v;
  }
  if (auto v = reader.number("initial_crumple_m", NumberRange::non_negative(), "m"))
    cloth.initial_crumple = *v;
  if (auto v = reader.integer("seed", 0, std::numeric_limits<std::uint32_t>::max())) {
    cloth.initial_seed = static_cast<unsigned>(*v);
  }

  if (const toml::node* pinned = reader.node("pinned")) {
    const std::string expected =
        fmt::format("expected an array of [i, j] grid coordinates, 0 <= i < {}, 0 <= j < {}",
                    cloth.particles_i, cloth.particles_j);
    const toml::array* list = pinned->as_array();
    if (list == nullptr) {
      reader.fail_at(pinned->source(), "pinned",
                     fmt::format("got {}", scene_detail::describe_type(*pinned)), expected);
    }
    const std::int64_t limits[2] = {cloth.particles_i - 1, cloth.particles_j - 1};
    std::set<std::pair<int, int>> seen;
    for (const toml::node& entry : *list) {
      const toml::array* pair = entry.as_array();
      if (pair == nullptr || pair->size() != 2) {
        reader.fail_at(entry.source(), "pinned", "each pin must be a pair [i, j]", expected);
      }
      std::int64_t ij[2] = {0, 0};
      for (std::size_t k = 0; k < 2; ++k) {
        const toml::node& index = *pair->get(k);
        if (!index.is_integer()) {
          reader.fail_at(index.source(), "pinned",
                         fmt::format("got {}", scene_detail::describe_type(index)), expected);
        }
        ij[k] = *index.value<std::int64_t>();
        if (ij[k] < 0 || ij[k] > limits[k]) {
          reader.fail_at(index.source(), "pinned",
                         fmt::format("{} index {} is outside the {} x {} grid", k == 0 ? "i" : "j",
                                     ij[k], cloth.particles_i, cloth.particles_j),
                         expected);
        }
      }
      const std::pair<int, int> pin(static_cast<int>(ij[0]), static_cast<int>(ij[1]));
      if (seen.insert(pin).second) cloth.pinned.push_back(pin);  // a repeated pin is one pin
    }
  }
  return sources;
}

// The fabric: a preset ([cloth] fabric), a [fabric] table, or a preset with [fabric]
// overrides on top. Neither: the KesParameters defaults, named "default".
void read_fabric_choice(const TableReader& cloth, const toml::table* fabric_table,
                        const std::filesystem::path& presets_file,
                        kernels::SimulationConfig& simulation) {
  const auto preset = cloth.string("fabric");
  if (preset) {
    scene_detail::PresetsDocument presets;
    try {
      presets = scene_detail::open_presets(presets_file.string());
    } catch (const SceneError& error) {
      cloth.fail_at(
          cloth.where("fabric"), "fabric", fmt::format("cannot read the presets: {}", error.what()),
          "set CLOTHBENCH_PRESETS to the presets file, or describe the fabric in [fabric]");
    }
    std::optional<kernels::KesParameters> parameters;
    try {
      parameters = scene_detail::find_preset(presets, *preset);
    } catch (const SceneError& error) {  // the preset itself is invalid: say who uses it
      const auto& at = cloth.where("fabric");
      throw SceneError(fmt::format("{} (fabric preset \"{}\" used at {}:{}:{})", error.what(),
                                   scene_detail::printable(*preset), cloth.file(), at.begin.line,
                                   at.begin.column));
    }
    if (!parameters) {
      const auto names = scene_detail::preset_names(presets);
      std::string expected =
          fmt::format("valid presets in {}: {}", presets.file, scene_detail::join_names(names));
      if (const auto guess = scene_detail::closest_name(*preset, names); !guess.empty()) {
        expected = fmt::format("did you mean '{}'? {}", guess, expected);
      }
      cloth.fail_at(cloth.where("fabric"), "fabric",
                    fmt::format("unknown fabric preset \"{}\"", *preset), expected);
    }
    simulation.fabric = *parameters;
    simulation.fabric_name = *preset;
  } else {
    simulation.fabric = kernels::KesParameters{};
    simulation.fabric_name = fabric_table != nullptr ? "custom" : "default";
  }
  if (fabric_table != nullptr) {
    scene_detail::read_fabric(TableReader(*fabric_table, cloth.file(), "fabric"), simulation.fabric,
                              {});
    if (preset && !fabric_table->empty()) simulation.fabric_name = *preset + " (modified)";
  }
}

void read_time(const TableReader& reader, kernels::TimeConfig& time) {
  reader.allow_only({"step_s", "damping", "gravity_m_s2"});
  if (auto v = reader.number("step_s", NumberRange::positive(), "s")) time.step = *v;
  if (auto v = reader.number("damping", NumberRange::half_open(0.0, 1.0))) time.damping = *v;
  if (auto v = reader.vector3("gravity_m_s2", NumberRange::any(), "m/s^2")) time.gravity = *v;
}

void read_contact(const TableReader& reader, kernels::ContactConfig& contact) {
  reader.allow_only({"distance_m", "stiffness", "broad_phase"});
  if (auto v = reader.number("distance_m", NumberRange::positive(), "m")) contact.distance = *v;
  if (auto v = reader.number("stiffness", NumberRange::positive(), "multiples of m g / d"))
    contact.stiffness = *v;
  if (auto v = reader.boolean("broad_phase")) contact.broad_phase = *v;
}

void read_solver(const TableReader& reader, kernels::SolverConfig& solver) {
  reader.allow_only({"formulation", "gradient", "kernel", "method", "preconditioner", "line_solves",
                     "tolerance", "max_iterations", "max_newton_iterations",
                     "max_linear_iterations", "smoothing_sweeps", "smoothing_threshold",
                     "model_refinements", "coarsest_nodes", "vcycle_after", "numeric_step",
                     "weights", "stretch_reference_fm", "time_budget_s"});
  if (auto v = reader.choice("formulation", {"potential", "violation"})) {
    solver.formulation =
        *v == "violation" ? kernels::Formulation::violation : kernels::Formulation::potential;
  }
  if (auto v = reader.choice("gradient", {"analytic", "numeric"})) {
    solver.gradient =
        *v == "numeric" ? kernels::GradientMode::numeric : kernels::GradientMode::analytic;
  }
  if (auto v = reader.choice("kernel", kernels::element_kernel_names())) {
    solver.kernel = *kernels::element_kernel_from_string(*v);
  }
  if (auto v = reader.choice("method", kernels::step_method_names())) {
    solver.method = *kernels::step_method_from_string(*v);
  }
  // The preconditioner was a boolean (with a separate line_solves boolean) before it became a
  // choice: an old scene gets told what to write instead.
  if (const toml::node* n = reader.node("preconditioner"); n != nullptr && n->is_boolean()) {
    const bool on = *n->value<bool>();
    reader.fail_at(n->source(), "preconditioner",
                   fmt::format("a boolean is no longer accepted (preconditioner = {})",
                               on ? "true" : "false"),
                   fmt::format("expected preconditioner = \"{}\" (one of: {})",
                               on ? "block-jacobi" : "none",
                               scene_detail::join_names(kernels::preconditioner_names())));
  }
  if (auto v = reader.choice("preconditioner", kernels::preconditioner_names())) {
    solver.preconditioner = *kernels::preconditioner_from_string(*v);
  }
  if (const toml::node* n = reader.node("line_solves")) {
    reader.fail_at(n->source(), "line_solves", "the key was replaced by a preconditioner choice",
                   "expected preconditioner = \"line-solves\" instead of line_solves = true");
  }
  if (auto v = reader.number("tolerance", NumberRange::positive())) solver.tolerance = *v;
  if (auto v = reader.integer("max_iterations", 1, std::numeric_limits<int>::max())) {
    solver.max_iterations = static_cast<int>(*v);
  }
  if (auto v = reader.integer("max_newton_iterations", 1, std::numeric_limits<int>::max())) {
    solver.max_newton_iterations = static_cast<int>(*v);
  }
  if (auto v = reader.integer("max_linear_iterations", 1, std::numeric_limits<int>::max())) {
    solver.max_linear_iterations = static_cast<int>(*v);
  }
  if (auto v = reader.integer("smoothing_sweeps", 0, 1000)) {
    solver.smoothing_sweeps = static_cast<int>(*v);
  }
  if (auto v = reader.number("smoothing_threshold", NumberRange::positive(), "multiples of tolerance")) {
    solver.smoothing_threshold = *v;
  }
  if (auto v = reader.integer("model_refinements", 0, 10)) {
    solver.model_refinements = static_cast<int>(*v);
  }
  if (auto v = reader.integer("coarsest_nodes", 1, std::numeric_limits<std::int32_t>::max())) {
    solver.coarsest_nodes = *v;
  }
  if (auto v = reader.integer("vcycle_after", 0, 1000)) solver.vcycle_after = static_cast<int>(*v);
  if (auto v = reader.number("numeric_step", NumberRange::positive())) solver.numeric_step = *v;
  if (auto v = reader.number("stretch_reference_fm", NumberRange::non_negative(), "0 = m g / h")) {
    solver.stretch_reference_fm = *v;
  }
  if (auto v = reader.number("time_budget_s", NumberRange::non_negative(), "s, 0 = none"))
    solver.time_budget = *v;
  if (const toml::table* weights = reader.table("weights")) {
    const TableReader w(*weights, reader.file(), "solver.weights");
    w.allow_only({"newton", "stretch", "bend", "contact"});
    if (auto v = w.number("newton", NumberRange::non_negative())) solver.weight_newton = *v;
    if (auto v = w.number("stretch", NumberRange::non_negative())) solver.weight_stretch = *v;
    if (auto v = w.number("bend", NumberRange::non_negative())) solver.weight_bend = *v;
    if (auto v = w.number("contact", NumberRange::non_negative())) solver.weight_contact = *v;
  }
  if (solver.weight_newton + solver.weight_stretch + solver.weight_bend + solver.weight_contact <=
      0.0) {
    reader.fail_at(reader.where("weights"), "weights", "all weights are zero",
                   "expected at least one weight > 0");
  }
}

// The nearest sizes 2^L n + 1 (n >= 1) below and above `count`.
std::string nearest_amrc_sizes(std::int64_t count, int levels) {
  const std::int64_t stride = std::int64_t{1} << levels;
  const std::int64_t below = (count - 1) / stride * stride + 1;
  const std::int64_t above = below + stride;
  if (below >= stride + 1) return fmt::format("nearest valid sizes: {} and {}", below, above);
  return fmt::format("smallest valid size: {}", stride + 1);
}

void read_amrc(const TableReader& reader, const ClothSources& sources, const std::string& file,
               kernels::SimulationConfig& simulation) {
  kernels::AmrcConfig& amrc = simulation.amrc;
  reader.allow_only({"enabled", "levels", "check_every", "refine_threshold", "coarsen_threshold"});
  if (auto v = reader.boolean("enabled")) amrc.enabled = *v;
  if (auto v = reader.integer("levels", 0, 16)) amrc.levels = static_cast<int>(*v);
  if (auto v = reader.integer("check_every", 1, std::numeric_limits<int>::max()))
    amrc.check_every = static_cast<int>(*v);
  if (auto v = reader.number("refine_threshold", NumberRange::non_negative(), "rad"))
    amrc.refine_threshold = *v;
  if (auto v = reader.number("coarsen_threshold", NumberRange::non_negative(), "rad"))
    amrc.coarsen_threshold = *v;
  if (amrc.refine_threshold <= amrc.coarsen_threshold) {
    const char* key = reader.node("refine_threshold") ? "refine_threshold" : "coarsen_threshold";
    reader.fail_at(reader.where(key), key,
                   fmt::format("refine_threshold {} <= coarsen_threshold {}", amrc.refine_threshold,
                               amrc.coarsen_threshold),
                   "expected refine_threshold > coarsen_threshold, so that refining and coarsening "
                   "do not alternate");
  }
  if (!amrc.enabled) return;
  if (amrc.levels < 1) {
    const char* key = reader.node("levels") ? "levels" : "enabled";
    reader.fail_at(reader.where(key), key, "AMRC is enabled with no coarser level",
                   "expected levels >= 1 when enabled = true");
  }
  const std::int64_t stride = std::int64_t{1} << amrc.levels;
  const int counts[2] = {simulation.cloth.particles_i, simulation.cloth.particles_j};
  for (int k = 0; k < 2; ++k) {
    if ((counts[k] - 1) % stride == 0 && counts[k] - 1 >= stride) continue;
    fail(file, sources.particles[k], "cloth", "particles",
         fmt::format(
             "{} particles along {} is not 2^{} n + 1 (n >= 1) as [amrc] levels = {} requires",
             counts[k], k == 0 ? "i" : "j", amrc.levels, amrc.levels),
         nearest_amrc_sizes(counts[k], amrc.levels));
  }
}

kernels::ObstacleConfig read_obstacle(const TableReader& reader) {
  kernels::ObstacleConfig obstacle;
  const std::vector<std::string> kinds = {"plane", "box", "sphere", "cylinder"};
  const auto kind = reader.choice("kind", kinds);
  if (!kind) {
    reader.fail_at(reader.raw().source(), "kind", "missing required key",
                   fmt::format("expected one of: {}", scene_detail::join_names(kinds)));
  }
  const std::string what = fmt::format("key for kind = \"{}\"", *kind);
  if (*kind == "plane") {
    obstacle.kind = kernels::ObstacleKind::plane;
    reader.allow_only({"kind", "center_m", "normal"}, what);
  } else if (*kind == "box") {
    obstacle.kind = kernels::ObstacleKind::box;
    reader.allow_only({"kind", "center_m", "half_extents_m"}, what);
  } else if (*kind == "sphere") {
    obstacle.kind = kernels::ObstacleKind::sphere;
    reader.allow_only({"kind", "center_m", "radius_m"}, what);
  } else {
    obstacle.kind = kernels::ObstacleKind::cylinder;
    reader.allow_only({"kind", "center_m", "axis", "radius_m", "half_length_m"}, what);
  }
  if (auto v = reader.vector3("center_m", NumberRange::any(), "m")) obstacle.center = *v;
  if (auto v = unit_vector(reader, "normal")) obstacle.normal = *v;
  if (auto v = unit_vector(reader, "axis")) obstacle.axis = *v;
  if (auto v = reader.vector3("half_extents_m", NumberRange::positive(), "m"))
    obstacle.half_extents = *v;
  if (auto v = reader.number("radius_m", NumberRange::positive(), "m")) obstacle.radius = *v;
  if (auto v = reader.number("half_length_m", NumberRange::positive(), "m"))
    obstacle.half_length = *v;
  return obstacle;
}

// Reads every [[obstacle]]; returns where each one's table starts, for later messages.
std::vector<toml::source_region> read_obstacles(const toml::node& node, const std::string& file,
                                                std::vector<kernels::ObstacleConfig>& obstacles) {
  const toml::array* list = node.as_array();
  if (list == nullptr || !list->is_array_of_tables()) {
    fail(file, node.source(), "obstacle", "", "obstacles are an array of tables",
         "expected [[obstacle]] sections");
  }
  std::vector<toml::source_region> sources;
  for (std::size_t k = 0; k < list->size(); ++k) {
    const TableReader reader(*list->get(k)->as_table(), file, fmt::format("obstacle[{}]", k));
    obstacles.push_back(read_obstacle(reader));
    sources.push_back(list->get(k)->source());
  }
  return sources;
}

const char* kind_name(kernels::ObstacleKind kind) {
  switch (kind) {
    case kernels::ObstacleKind::plane: return "plane";
    case kernels::ObstacleKind::box: return "box";
    case kernels::ObstacleKind::sphere: return "sphere";
    case kernels::ObstacleKind::cylinder: return "cylinder";
  }
  return "obstacle";
}

// Blocks of the grid the start-overlap search may visit per scene (well under a second);
// only absurd grids, such as 10^6 x 10^6 particles deep inside an obstacle, come near it.
constexpr std::int64_t kOverlapSearchBudget = std::int64_t{1} << 18;

// The cloth must start outside every obstacle (touching is allowed): a particle that starts
// inside is thrown out by the contact penalty in the first step. Reported at the obstacle.
void check_cloth_starts_outside(const kernels::SimulationConfig& simulation,
                                const std::vector<toml::source_region>& sources,
                                const std::string& file) {
  std::int64_t budget = kOverlapSearchBudget;
  for (std::size_t k = 0; k < simulation.obstacles.size(); ++k) {
    const std::string section = fmt::format("obstacle[{}]", k);
    std::optional<kernels::Obstacle> obstacle;
    try {
      obstacle.emplace(simulation.obstacles[k]);
    } catch (const std::invalid_argument& error) {  // the reads above rule this out
      fail(file, sources[k], section, "", error.what(), "");
    }
    const auto overlap = scene_detail::deepest_initial_overlap(simulation.cloth, *obstacle, budget);
    if (!overlap) continue;
    const kernels::ClothConfig& cloth = simulation.cloth;
    std::string problem = fmt::format(
        "the cloth starts inside this {}: particle ({}, {}) at ({:.6g}, {:.6g}, {:.6g}) m is "
        "{}{:.6g} m deep",
        kind_name(simulation.obstacles[k].kind), overlap->i, overlap->j, overlap->position.x(),
        overlap->position.y(), overlap->position.z(), overlap->complete ? "" : "at least ",
        overlap->depth);
    if (overlap->flat_depth <= scene_detail::kOverlapTolerance) {
      problem += fmt::format(
          " once [cloth] initial_crumple_m = {} displaces it ({:.6g} m outside when flat)",
          cloth.initial_crumple, -overlap->flat_depth);
    }
    fail(file, sources[k], section, "center_m", problem,
         "expected every cloth particle to start outside every obstacle, touching at most; "
         "move the obstacle or the cloth ([cloth] origin_m)");
  }
}

}  // namespace

std::string Fnv1a64::hex() const { return fmt::format("{:016x}", hash_); }

std::string fnv1a64_hex(std::string_view bytes) {
  Fnv1a64 hash;
  hash.add(bytes);
  return hash.hex();
}

std::filesystem::path default_presets_file() {
  if (const char* env = std::getenv("CLOTHBENCH_PRESETS"); env != nullptr && *env != '\0')
    return env;
  return std::filesystem::path(CLOTHBENCH_SOURCE_DIR) / "scenarios" / "presets" / "fabrics.toml";
}

std::filesystem::path scenario_directory() {
  return default_presets_file().parent_path().parent_path();
}

Scene parse_scene(std::string_view source_text, const std::filesystem::path& file,
                  const std::filesystem::path& presets_file) {
  const std::string file_name = file.string();
  const toml::table document = scene_detail::parse_toml(source_text, file_name);

  Scene scene;
  scene.file = file;
  scene.source_text = std::string(source_text);
  scene.source_sha256_or_fnv = fnv1a64_hex(source_text);
  scene.name = file.stem().string();

  // Sections first: an unknown or misplaced one is reported before any value in it.
  for (auto&& [key, value] : document) {
    const std::string name(key.str());
    std::string expected = fmt::format("valid sections: {}", scene_detail::join_names(kSections));
    if (std::find(kSections.begin(), kSections.end(), name) == kSections.end()) {
      if (const auto guess = scene_detail::closest_name(name, kSections); !guess.empty()) {
        expected = fmt::format("did you mean '{}'? {}", guess, expected);
      }
      fail(file_name, key.source(), name, "",
           value.is_table() ? "unknown section" : "key outside any section", expected);
    }
    if (name != "obstacle" && name != "event" && !value.is_table()) {
      fail(file_name, value.source(), name, "",
           fmt::format("got {}", scene_detail::describe_type(value)),
           fmt::format("expected a [{}] section", name));
    }
  }
  auto section = [&](const char* name) -> std::optional<TableReader> {
    if (const toml::node* n = document.get(name))
      return TableReader(*n->as_table(), file_name, name);
    return std::nullopt;
  };

  if (auto reader = section("scene")) read_scene_section(*reader, scene);
  kernels::SimulationConfig& simulation = scene.simulation;
  const auto cloth = section("cloth");
  if (!cloth) {
    fail(file_name, document.source(), "cloth", "", "missing required section",
         "expected [cloth] with at least particles = [I, J]");
  }
  const ClothSources sources = read_cloth(*cloth, simulation.cloth);
  if (sources.particles_value.begin.line > 0) {
    scene.particles_position.line = sources.particles_value.begin.line;
    scene.particles_position.column = std::max(1u, sources.particles_value.begin.column);
  }
  const toml::node* fabric = document.get("fabric");
  read_fabric_choice(*cloth, fabric != nullptr ? fabric->as_table() : nullptr, presets_file,
                     simulation);
  if (auto reader = section("time")) read_time(*reader, simulation.time);
  if (auto reader = section("contact")) read_contact(*reader, simulation.contact);
  if (auto reader = section("solver")) read_solver(*reader, simulation.solver);
  if (auto reader = section("amrc")) {
    read_amrc(*reader, sources, file_name, simulation);
  }
  // Combinations the kernel cannot run (kernels::validate, the one place they are checked),
  // located at the setting the file gives: the problem's own key, else the one it conflicts with.
  for (const kernels::ConfigProblem& problem : kernels::validate(simulation)) {
    for (const std::string& full_key : {problem.key, problem.other_key}) {
      const std::size_t dot = full_key.find('.');
      const std::string table = full_key.substr(0, dot), key = full_key.substr(dot + 1);
      const auto reader = section(table.c_str());
      if (!reader || reader->node(key) == nullptr) continue;
      reader->fail_at(reader->where(key), key, problem.problem, problem.expected);
    }
    const std::string table = problem.key.substr(0, problem.key.find('.'));
    fail(file_name, document.source(), table, problem.key.substr(table.size() + 1),
         problem.problem, problem.expected);
  }
  if (const toml::node* obstacles = document.get("obstacle")) {
    const auto obstacle_sources = read_obstacles(*obstacles, file_name, simulation.obstacles);
    check_cloth_starts_outside(simulation, obstacle_sources, file_name);
  }
  if (const toml::node* events = document.get("event")) {
    scene_detail::read_events(*events, file_name, scene.steps, simulation);
  }
  return scene;
}

Scene load_scene(const std::filesystem::path& scene_file,
                 const std::filesystem::path& presets_file) {
  const std::string text = scene_detail::read_text_file(scene_file.string());
  return parse_scene(text, scene_file, presets_file);
}

}  // namespace clothbench::harness
