// What the step objectives share: mesh, material, obstacles, configuration and state, plus
// the per-particle physics both formulations use (inertia, contact penalty, preconditioner).
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <vector>

#include "kernels/cloth_mesh.hpp"
#include "kernels/cloth_state.hpp"
#include "kernels/contact_broad_phase.hpp"
#include "kernels/element_geometry.hpp"
#include "kernels/ghost_nodes.hpp"
#include "kernels/kes_material.hpp"
#include "kernels/loop_runner.hpp"
#include "kernels/obstacle.hpp"
#include "kernels/simulation_config.hpp"

namespace clothbench::kernels {

/// References to everything one step reads and writes.
struct StepContext {
  const ClothMesh& mesh;
  const FabricMaterial& material;
  const std::vector<Obstacle>& obstacles;
  const SimulationConfig& config;
  ClothState& state;
  /// Length of the (sub-)step being solved (s); 0 = the scene's step. Set by the objective's
  /// set_step_length when a rejected step is redone in halves: the configuration stays fixed.
  double step_length = 0.0;

  /// dt of the current (sub-)step, s.
  [[nodiscard]] double dt() const { return step_length > 0.0 ? step_length : config.time.step; }

  /// |g| used to normalise residuals and scale the contact stiffness (m/s^2).
  [[nodiscard]] double gravity_reference() const {
    const double g = config.time.gravity.norm();
    return g > 0.0 ? g : 9.80665;
  }
  /// Penalty stiffness of particle s (N/m): stiffness * m |g| / d.
  [[nodiscard]] double contact_stiffness(std::int64_t s) const {
    return config.contact.stiffness * mesh.mass[s] * gravity_reference() / config.contact.distance;
  }
  [[nodiscard]] bool is_free(std::int64_t s) const {
    return (mesh.flags[s] & (kParticleActive | kParticlePinned)) == kParticleActive;
  }
  /// True when particle s carries a scripted external force.
  [[nodiscard]] bool is_forced(std::int64_t s) const {
    return (mesh.flags[s] & kParticleForced) != 0;
  }
  /// The scripted external force on particle s (N); zero when there is none.
  [[nodiscard]] Eigen::Vector3d external_force(std::int64_t s) const {
    for (const ExternalForce& f : state.external_forces) {
      if (f.slot == s) return f.force;
    }
    return Eigen::Vector3d::Zero();
  }
  /// True when the loops that evaluate contact run the per-tile broad phase.
  [[nodiscard]] bool broad_phase() const {
    return config.contact.broad_phase && !obstacles.empty();
  }
  /// Broad phase of `tile` over `points` (positions or targets), and over points + offsets
  /// where `offsets` is given: contact_broad_phase.hpp.
  [[nodiscard]] TileContacts tile_contacts(std::int64_t tile, const std::vector<double>& points,
                                           const std::vector<double>* offsets = nullptr) const {
    return kernels::tile_contacts(mesh, obstacles, config.contact.distance, tile, points,
                                  offsets);
  }
};

/// Return mapping with breakpoints computed from the previous force (MODEL.md 4B).
template <class Band>
inline ReturnMapped map_force(const Band& band, double previous, double strain) {
  return return_map(band, previous, band_breakpoints(band, previous), strain);
}

/// Contact penalty of one particle against all obstacles: adds energy, gradient, support.
struct ContactPenalty {
  double energy = 0.0;
  Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
  double support = 0.0;                         ///< summed normal force (N)
  Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();  ///< sum k n n^T (preconditioner)
};
/// Obstacles outside `mask` are skipped (the broad phase proved them farther than d, at x and
/// at `reach` where that is given). `reach` (x + p, p a Newton direction) adds the stiffness
/// k n n^T, and nothing else, of every obstacle the particle does not touch at x but would
/// touch there: a Newton model that sees the contacts its direction would make.
inline ContactPenalty contact_penalty(const StepContext& ctx, std::int64_t s,
                                      const Eigen::Vector3d& x,
                                      ObstacleMask mask = kEveryObstacle,
                                      const Eigen::Vector3d* reach = nullptr) {
  ContactPenalty c;
  const double d = ctx.config.contact.distance;
  const double k = ctx.contact_stiffness(s);
  for (std::size_t i = 0; i < ctx.obstacles.size(); ++i) {
    if (!may_touch(mask, i)) continue;
    const Obstacle& obstacle = ctx.obstacles[i];
    Eigen::Vector3d n;
    const double phi = obstacle.signed_distance(x, n);
    if (phi < d) {
      const double depth = d - phi;
      c.energy += 0.5 * k * depth * depth;
      c.gradient -= k * depth * n;
      c.support += k * depth;
      c.stiffness += k * n * n.transpose();
    } else if (reach != nullptr && obstacle.signed_distance(*reach, n) < d) {
      c.stiffness += k * n * n.transpose();
    }
  }
  return c;
}

/// LoopBytes (loop_bytes.hpp) of a loop setting every free particle's initial guess: flags
/// and x~ read, x written.
inline constexpr LoopBytes kInitialGuessBytes{.read = bytes::kFlag + bytes::kVector3,
                                              .written = bytes::kVector3};
/// LoopBytes of a move along the direction, x += delta d: x and d read, x written.
inline constexpr LoopBytes kMoveBytes{.read = 2 * bytes::kVector3, .written = bytes::kVector3};

/// The step's initial guess for particle s: the inertial target x~, projected out of any
/// obstacle to `layer` times the contact distance (a falling particle's x~ can lie deep inside
/// an obstacle, where the penalty would start the minimisation from a huge residual). The
/// violation formulation's support switches on at the contact distance, so it projects to
/// the middle of the layer rather than onto the switch. `mask` is the broad phase of the
/// targets; once a projection has moved x off its target every later obstacle is tested.
inline Eigen::Vector3d initial_guess(const StepContext& ctx, std::int64_t s, double layer = 1.0,
                                     ObstacleMask mask = kEveryObstacle) {
  Eigen::Vector3d x = vec3(ctx.state.target, s);
  const double d = layer * ctx.config.contact.distance;
  for (std::size_t k = 0; k < ctx.obstacles.size(); ++k) {
    if (!may_touch(mask, k)) continue;
    Eigen::Vector3d n;
    const double phi = ctx.obstacles[k].signed_distance(x, n);
    if (phi < d) {
      x += (d - phi) * n;
      mask = kEveryObstacle;
    }
  }
  return x;
}

/// Stores a symmetric 3x3 block (e.g. a preconditioner's inverse) as 6 values
/// (xx xy xz yy yz zz), in float or double.
template <class T>
inline void store_symmetric(std::vector<T>& out, std::int64_t s, const Eigen::Matrix3d& m) {
  T* p = out.data() + 6 * s;
  p[0] = static_cast<T>(m(0, 0));
  p[1] = static_cast<T>(m(0, 1));
  p[2] = static_cast<T>(m(0, 2));
  p[3] = static_cast<T>(m(1, 1));
  p[4] = static_cast<T>(m(1, 2));
  p[5] = static_cast<T>(m(2, 2));
}
/// z = P^-1 g with the stored symmetric block of slot s.
inline Eigen::Vector3d apply_symmetric(const std::vector<float>& in, std::int64_t s,
                                       const Eigen::Vector3d& g) {
  const float* p = in.data() + 6 * s;
  return {p[0] * g.x() + p[1] * g.y() + p[2] * g.z(), p[1] * g.x() + p[3] * g.y() + p[4] * g.z(),
          p[2] * g.x() + p[4] * g.y() + p[5] * g.z()};
}

/// Per ghost refreshed: its flags, prev and next along its direction and both parents' values
/// (in full: the loop does not visit their owners) read; its own value written.
inline constexpr LoopBytes kGhostRefreshBytes{
    .read = bytes::kFlag + 2 * bytes::kIndex + 2 * bytes::kVector3, .written = bytes::kVector3};

/// Puts every ghost of an interleaved xyz array (positions, adjoints) on the midpoint of its
/// parents. Skipped entirely on a mesh without ghosts (no loop, no barrier).
inline void refresh_ghosts(LoopRunner& run, const ClothMesh& mesh, std::span<double> values) {
  if (mesh.ghost_count() == 0) return;
  run.for_each(ElementKind::ghosts, kGhostRefreshBytes,
               [&](std::int64_t g) { vec3(values, g) = node_value(mesh, values, g); });
}

/// As refresh_ghosts, for the listed ghosts only: those whose parents moved. Skipped entirely
/// (no loop, no barrier) when the list is empty.
inline void refresh_listed_ghosts(LoopRunner& run, const ClothMesh& mesh,
                                  const std::vector<std::int64_t>& ghosts,
                                  std::vector<double>& values) {
  if (ghosts.empty()) return;
  run.for_index(static_cast<std::int64_t>(ghosts.size()), kGhostRefreshBytes,
                [&](std::int64_t k) { vec3(values, ghosts[k]) = node_value(mesh, values, ghosts[k]); });
}

/// The share of the velocity a (sub-)step of length h keeps: damping is a rate (MODEL.md 5),
/// c_damp per step of the scene's length, so (1 - c_damp)^(h / step).
inline double velocity_keep(const TimeConfig& time, double h) {
  return time.damping == 0.0 ? 1.0 : std::pow(1.0 - time.damping, h / time.step);
}

/// End of an accepted (sub-)step of length h for every particle: the next step's inertial
/// target x~ = x + keep(h) (x - x^n) and x^n = x (both formulations).
inline void advance_position_history(LoopRunner& run, ClothState& st, const TimeConfig& time,
                                     double h) {
  const double keep = velocity_keep(time, h);
  // x and x^n read; x~ and x^n written.
  const LoopBytes history_bytes{.read = 2 * bytes::kVector3, .written = 2 * bytes::kVector3};
  run.for_each(ElementKind::particles, history_bytes, [&](std::int64_t s) {
    const Eigen::Vector3d xs = vec3(st.position, s);
    vec3(st.target, s) = xs + keep * (xs - vec3(st.step_start, s));
    vec3(st.step_start, s) = xs;
  });
}

/// Per-tile sum of one scalar (energies, dot products).
struct ScalarSum {
  double value = 0.0;
  ScalarSum& operator+=(const ScalarSum& o) {
    value += o.value;
    return *this;
  }
};

/// The position part of a CG direction update, shared by both formulations:
/// direction = -P^-1 g + beta direction and gradient_old = g for every particle; the per-tile
/// sums of direction . g go to `partials`. P^-1 g is the block-Jacobi product, or `z` when
/// the caller has computed it (the line-solve preconditioner).
inline void update_position_direction(LoopRunner& run, ClothState& st, double beta,
                                      TilePartials<ScalarSum>& partials,
                                      const std::vector<double>* z = nullptr) {
  // g, d and P^-1 g (the block, or z: 24 B either way) read; d and g_old written.
  const LoopBytes direction_bytes{.read = 3 * bytes::kVector3, .written = 2 * bytes::kVector3};
  run.for_each<ScalarSum>(ElementKind::particles, &partials, direction_bytes,
                          [&](std::int64_t s, ScalarSum& acc) {
                            const Eigen::Vector3d g = vec3(st.gradient, s);
                            auto dir = vec3(st.direction, s);
                            dir = -(z != nullptr ? Eigen::Vector3d(vec3(*z, s))
                                                 : apply_symmetric(st.preconditioner, s, g)) +
                                  beta * dir;
                            vec3(st.gradient_old, s) = g;
                            acc.value += dir.dot(g);
                          });
}

}  // namespace clothbench::kernels
