// [[event]] tables -> kernels::SceneEvent, with file:line:column errors (see event_reader.hpp).
#include "harness/scene/event_reader.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <iterator>
#include <map>
#include <optional>
#include <set>
#include <tuple>
#include <utility>
#include <vector>

#include "harness/scene/toml_reader.hpp"

namespace clothbench::harness::scene_detail {
namespace {

using kernels::SceneEvent;
using kernels::SceneEventKind;

// A release, kept with where its particle was written for the pin timeline check.
struct Release {
  std::size_t index = 0;
  int step = 0;
  std::pair<int, int> particle;
  toml::source_region where;
};

// `particle = [i, j]`: required, integers inside the grid.
std::pair<int, int> read_particle(const TableReader& reader, const kernels::ClothConfig& cloth) {
  const std::string expected =
      fmt::format("expected [i, j] grid coordinates, 0 <= i < {}, 0 <= j < {}", cloth.particles_i,
                  cloth.particles_j);
  const toml::node* node = reader.node("particle");
  if (node == nullptr) {
    reader.fail_at(reader.raw().source(), "particle", "missing required key", expected);
  }
  const toml::array* pair = node->as_array();
  if (pair == nullptr || pair->size() != 2) {
    reader.fail_at(node->source(), "particle",
                   pair == nullptr ? fmt::format("got {}", describe_type(*node))
                                   : fmt::format("got {} elements", pair->size()),
                   expected);
  }
  const std::int64_t limits[2] = {cloth.particles_i, cloth.particles_j};
  std::int64_t ij[2] = {0, 0};
  for (std::size_t k = 0; k < 2; ++k) {
    const toml::node& index = *pair->get(k);
    if (!index.is_integer()) {
      reader.fail_at(index.source(), "particle", fmt::format("got {}", describe_type(index)),
                     expected);
    }
    ij[k] = *index.value<std::int64_t>();
    if (ij[k] < 0 || ij[k] >= limits[k]) {
      reader.fail_at(index.source(), "particle",
                     fmt::format("{} index {} is outside the {} x {} grid", k == 0 ? "i" : "j",
                                 ij[k], cloth.particles_i, cloth.particles_j),
                     expected);
    }
  }
  return {static_cast<int>(ij[0]), static_cast<int>(ij[1])};
}

// `until_step`: optional, in [step, steps]; `step` when absent.
int read_until_step(const TableReader& reader, int step, int steps) {
  const toml::node* node = reader.node("until_step");
  if (node == nullptr) return step;
  if (node->is_integer() && *node->value<std::int64_t>() < step) {
    reader.fail_at(node->source(), "until_step",
                   fmt::format("{} is before step = {}", *node->value<std::int64_t>(), step),
                   fmt::format("expected an integer in [{}, {}]: the last step the event acts on",
                               step, steps));
  }
  return static_cast<int>(*reader.integer("until_step", step, steps));
}

// `obstacle`: required, an index of an [[obstacle]] table in file order.
int read_obstacle_index(const TableReader& reader, std::size_t obstacles) {
  const std::string expected =
      obstacles == 0 ? std::string("expected an [[obstacle]] table to move")
                     : fmt::format("expected an integer in [0, {}]: [[obstacle]] tables in file "
                                   "order, 0 for the first",
                                   obstacles - 1);
  const toml::node* node = reader.node("obstacle");
  if (node == nullptr) {
    reader.fail_at(reader.raw().source(), "obstacle", "missing required key", expected);
  }
  if (!node->is_integer()) {
    reader.fail_at(node->source(), "obstacle", fmt::format("got {}", describe_type(*node)),
                   expected);
  }
  const std::int64_t index = *node->value<std::int64_t>();
  if (index < 0 || index >= static_cast<std::int64_t>(obstacles)) {
    reader.fail_at(node->source(), "obstacle",
                   fmt::format("there is no obstacle {}: the scene has {} [[obstacle]] table{}",
                               index, obstacles, obstacles == 1 ? "" : "s"),
                   expected);
  }
  return static_cast<int>(index);
}

SceneEvent read_event(const TableReader& reader, int steps,
                      const kernels::SimulationConfig& simulation) {
  SceneEvent e;
  const std::vector<std::string> kinds(std::begin(kEventKinds), std::end(kEventKinds));
  const auto kind = reader.choice("kind", kinds);
  if (!kind) {
    reader.fail_at(reader.raw().source(), "kind", "missing required key",
                   fmt::format("expected one of: {}", join_names(kinds)));
  }
  const std::string what = fmt::format("key for kind = \"{}\"", *kind);
  if (*kind == "move-obstacle") {
    e.kind = SceneEventKind::move_obstacle;
    reader.allow_only({"kind", "step", "obstacle", "displacement_m", "velocity_m_s", "until_step"},
                      what);
  } else if (*kind == "release-pin") {
    e.kind = SceneEventKind::release_pin;
    reader.allow_only({"kind", "step", "particle"}, what);
  } else {
    e.kind = SceneEventKind::force;
    reader.allow_only({"kind", "step", "particle", "force_N", "until_step"}, what);
  }
  const auto step = reader.integer("step", 1, steps);
  if (!step) {
    reader.fail_at(reader.raw().source(), "step", "missing required key",
                   fmt::format("expected an integer in [1, {}]: the event applies before that "
                               "step is simulated",
                               steps));
  }
  e.step = e.until_step = static_cast<int>(*step);
  switch (e.kind) {
    case SceneEventKind::move_obstacle: {
      e.obstacle = read_obstacle_index(reader, simulation.obstacles.size());
      const auto displacement = reader.vector3("displacement_m", NumberRange::any(), "m");
      const auto velocity = reader.vector3("velocity_m_s", NumberRange::any(), "m/s");
      const std::string expected =
          "expected displacement_m = [x, y, z] (once) or velocity_m_s = [x, y, z] (each step "
          "up to until_step)";
      if (displacement && velocity) {
        reader.fail_at(reader.where("velocity_m_s"), "velocity_m_s",
                       "given together with displacement_m", expected);
      }
      if (!displacement && !velocity) {
        reader.fail_at(reader.raw().source(), "displacement_m", "missing required key", expected);
      }
      if (displacement && reader.node("until_step") != nullptr) {
        reader.fail_at(reader.where("until_step"), "until_step",
                       "a displacement is applied once", "expected until_step with velocity_m_s");
      }
      if (displacement) e.displacement = *displacement;
      if (velocity) {
        e.velocity = *velocity;
        e.until_step = read_until_step(reader, e.step, steps);
      }
      break;
    }
    case SceneEventKind::release_pin:
      std::tie(e.particle_i, e.particle_j) = read_particle(reader, simulation.cloth);
      break;
    case SceneEventKind::force: {
      std::tie(e.particle_i, e.particle_j) = read_particle(reader, simulation.cloth);
      const auto force = reader.vector3("force_N", NumberRange::any(), "N");
      if (!force) {
        reader.fail_at(reader.raw().source(), "force_N", "missing required key",
                       "expected force_N = [x, y, z], N");
      }
      e.force = *force;
      e.until_step = read_until_step(reader, e.step, steps);
      break;
    }
  }
  return e;
}

}  // namespace

void read_events(const toml::node& node, const std::string& file, int steps,
                 kernels::SimulationConfig& simulation) {
  const toml::array* list = node.as_array();
  if (list == nullptr || !list->is_array_of_tables()) {
    fail(file, node.source(), "event", "", "events are an array of tables",
         "expected [[event]] sections");
  }
  std::vector<Release> releases;
  for (std::size_t k = 0; k < list->size(); ++k) {
    const TableReader reader(*list->get(k)->as_table(), file, fmt::format("event[{}]", k));
    const SceneEvent e = read_event(reader, steps, simulation);
    if (e.kind == SceneEventKind::release_pin) {
      releases.push_back({k, e.step, {e.particle_i, e.particle_j}, reader.where("particle")});
    }
    simulation.events.push_back(e);
  }
  // Releases in the order they happen (step, then file order): each needs a pin still held.
  std::stable_sort(releases.begin(), releases.end(),
                   [](const Release& a, const Release& b) { return a.step < b.step; });
  std::set<std::pair<int, int>> pinned(simulation.cloth.pinned.begin(),
                                       simulation.cloth.pinned.end());
  std::map<std::pair<int, int>, const Release*> released;
  for (const Release& r : releases) {
    if (pinned.erase(r.particle) == 1) {
      released[r.particle] = &r;
      continue;
    }
    const auto [i, j] = r.particle;
    const auto earlier = released.find(r.particle);
    fail(file, r.where, fmt::format("event[{}]", r.index), "particle",
         earlier != released.end()
             ? fmt::format("particle ({}, {}) is already released by event[{}] at step {}", i, j,
                           earlier->second->index, earlier->second->step)
             : fmt::format("particle ({}, {}) is not pinned", i, j),
         "expected a particle listed in [cloth] pinned, released once");
  }
}

}  // namespace clothbench::harness::scene_detail
