// Scripted scene events of a Simulation (MODEL.md section 8; see simulation.hpp): moving an
// obstacle, releasing a pin, an external force on one particle. Every event is a sequential
// change of state between two steps, so every scheduler and thread count sees the same state.
#include <algorithm>
#include <numeric>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include "kernels/simulation.hpp"

namespace clothbench::kernels {

namespace {

// Messages are built with streams: GCC 12 warns (-Wrestrict, a known false positive) on
// chains of std::string concatenations.
template <class... Parts>
std::string text(const Parts&... parts) {
  std::ostringstream out;
  (out << ... << parts);
  return out.str();
}

std::string grid_point(int i, int j) { return text('(', i, ", ", j, ')'); }

}  // namespace

std::int64_t Simulation::grid_slot(int i, int j, const char* what) const {
  if (i < 0 || j < 0 || i >= mesh_.size_i() || j >= mesh_.size_j()) {
    throw std::invalid_argument(text(what, ": particle ", grid_point(i, j), " is outside the ",
                                     mesh_.size_i(), " x ", mesh_.size_j(), " grid"));
  }
  return mesh_.slot(i, j);
}

void Simulation::check_events() const {
  const std::vector<SceneEvent>& events = config_.events;
  // Releases are checked in the order they happen (step, then file order).
  std::vector<std::size_t> order(events.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return events[a].step < events[b].step; });
  std::set<std::pair<int, int>> pinned(config_.cloth.pinned.begin(), config_.cloth.pinned.end());
  for (const std::size_t k : order) {
    const SceneEvent& e = events[k];
    const std::string name = text("event ", k);
    auto fail = [&](const std::string& problem) {
      throw std::invalid_argument(text(name, ": ", problem));
    };
    if (e.step < 1 || e.until_step < e.step) fail("needs 1 <= step <= until_step");
    if (!e.displacement.allFinite() || !e.velocity.allFinite() || !e.force.allFinite()) {
      fail("non-finite vector");
    }
    switch (e.kind) {
      case SceneEventKind::move_obstacle:
        if (e.obstacle < 0 || e.obstacle >= static_cast<int>(obstacles_.size())) {
          fail(text("there is no obstacle ", e.obstacle));
        }
        break;
      case SceneEventKind::release_pin:
        (void)grid_slot(e.particle_i, e.particle_j, name.c_str());
        if (pinned.erase({e.particle_i, e.particle_j}) == 0) {
          fail(text("particle ", grid_point(e.particle_i, e.particle_j), " is not pinned at step ",
                    e.step));
        }
        break;
      case SceneEventKind::force:
        (void)grid_slot(e.particle_i, e.particle_j, name.c_str());
        break;
    }
  }
}

std::vector<int> Simulation::apply_events(int step) {
  std::vector<int> begun;
  std::vector<std::pair<int, int>> changed;  // particles whose total force changes now
  const double dt = config_.time.step;       // the full step (sub-steps move nothing)
  const std::vector<SceneEvent>& events = config_.events;
  for (std::size_t k = 0; k < events.size(); ++k) {
    const SceneEvent& e = events[k];
    if (e.step == step) begun.push_back(static_cast<int>(k));
    const bool acting = e.step <= step && step <= e.until_step;
    switch (e.kind) {
      case SceneEventKind::move_obstacle:
        if (e.step == step && !e.displacement.isZero(0.0)) {
          move_obstacle(e.obstacle, e.displacement);
        }
        if (acting && !e.velocity.isZero(0.0)) move_obstacle(e.obstacle, dt * e.velocity);
        break;
      case SceneEventKind::release_pin:
        if (e.step == step) release_pin(e.particle_i, e.particle_j);
        break;
      case SceneEventKind::force:
        if (e.step == step || step - 1 == e.until_step) {
          changed.emplace_back(e.particle_i, e.particle_j);
        }
        break;
    }
  }
  // A particle's force is the sum, in file order, of the force events acting on it now.
  std::sort(changed.begin(), changed.end());
  changed.erase(std::unique(changed.begin(), changed.end()), changed.end());
  for (const auto& [i, j] : changed) {
    Eigen::Vector3d total = Eigen::Vector3d::Zero();
    for (const SceneEvent& e : events) {
      if (e.kind == SceneEventKind::force && e.particle_i == i && e.particle_j == j &&
          e.step <= step && step <= e.until_step) {
        total += e.force;
      }
    }
    set_external_force(i, j, total);
  }
  return begun;
}

void Simulation::move_obstacle(int index, const Eigen::Vector3d& displacement) {
  if (index < 0 || index >= static_cast<int>(obstacles_.size())) {
    throw std::out_of_range(text("move_obstacle: there is no obstacle ", index));
  }
  obstacles_[static_cast<std::size_t>(index)].translate(displacement);
  config_.obstacles[static_cast<std::size_t>(index)].center += displacement;
}

void Simulation::release_pin(int i, int j) {
  const std::int64_t s = grid_slot(i, j, "release_pin");
  if ((mesh_.flags[s] & kParticlePinned) == 0) {
    throw std::invalid_argument(text("release_pin: particle ", grid_point(i, j), " is not pinned"));
  }
  // A pinned particle is active (AMRC never drops it) and carries its mass already: clearing
  // the bit makes it an unknown from the next step on, whose begin_step rebuilds the
  // preconditioner. It starts at rest where it is.
  mesh_.flags[s] = static_cast<std::uint8_t>(mesh_.flags[s] & ~kParticlePinned);
  vec3(state_.step_start, s) = vec3(state_.position, s);
  vec3(state_.target, s) = vec3(state_.position, s);
  auto& pins = config_.cloth.pinned;
  pins.erase(std::remove(pins.begin(), pins.end(), std::make_pair(i, j)), pins.end());
}

void Simulation::set_external_force(int i, int j, const Eigen::Vector3d& force) {
  const std::int64_t s = grid_slot(i, j, "set_external_force");
  if (!force.allFinite()) {
    throw std::invalid_argument(text("set_external_force: non-finite force on ", grid_point(i, j)));
  }
  std::vector<ExternalForce>& forces = state_.external_forces;
  const auto it = std::find_if(forces.begin(), forces.end(),
                               [&](const ExternalForce& f) { return f.slot == s; });
  if (force.isZero(0.0)) {
    if (it != forces.end()) forces.erase(it);
    mesh_.flags[s] = static_cast<std::uint8_t>(mesh_.flags[s] & ~kParticleForced);
    return;
  }
  if ((mesh_.flags[s] & kParticleActive) == 0) {
    // Only AMRC makes a particle inactive: split the leaves around it until it is a corner
    // of all of them (a mesh change between steps, like an AMRC event).
    if (!amrc_) throw std::logic_error("set_external_force: inactive particle without AMRC");
    amrc_->begin_change(mesh_, state_);
    amrc_->refine_to_particle(i, j);
    amrc_->finish_change(mesh_, state_);
    if (lists_built_) rebuild_lists();
  }
  mesh_.flags[s] = static_cast<std::uint8_t>(mesh_.flags[s] | kParticleForced);
  if (it != forces.end()) {
    it->force = force;
  } else {
    forces.push_back(ExternalForce{s, force});
  }
}

}  // namespace clothbench::kernels
