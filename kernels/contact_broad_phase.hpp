// Contact broad phase per tile: which obstacles the free particles of one tile (one row of a
// storage block, the loops' unit of work) can touch at all, so that the narrow phase (the
// exact signed distance of every particle to every obstacle) skips the others.
//
// Where the bounds come from. Each loop that evaluates contact computes its tile's box at
// the start of that tile (LoopRunner::for_each_prepared), from the very position values the
// narrow phase then reads; within one loop nothing moves them (positions change only in other
// loops: the initial guess, the line search's moves, AMRC and scripted events, all separated
// by barriers). So no bound is ever stale and no motion margin is needed, wherever and however
// often positions change; the cost is one more pass over the tile's positions, which the loop
// reads next anyway (in cache).
//
// Exactness. An obstacle is ruled out only when its lower bound over the box is at least
// d + margin, so every queried particle has signed distance >= d, where every contact term
// (penalty, support, non-penetration cost, their preconditioner blocks, the initial-guess
// projection) does nothing: skipping it changes no bit. The margin 1e-9 (1 + coordinate
// magnitudes) m is ~10^6 times the rounding of the two distance formulas (a few ulp of the
// coordinates). A tile with a non-finite position tests every obstacle.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <limits>
#include <vector>

#include "kernels/cloth_mesh.hpp"
#include "kernels/cloth_state.hpp"
#include "kernels/obstacle.hpp"

namespace clothbench::kernels {

/// Obstacles a tile may touch: bit k for obstacle k < 64 (from 64 on, always tested).
using ObstacleMask = std::uint64_t;
inline constexpr ObstacleMask kEveryObstacle = ~ObstacleMask{0};
inline constexpr std::size_t kMaskedObstacles = 64;

/// False only when the broad phase ruled obstacle k out.
constexpr bool may_touch(ObstacleMask mask, std::size_t k) {
  return k >= kMaskedObstacles || ((mask >> k) & 1u) != 0;
}

/// The broad phase of one tile.
struct TileContacts {
  ObstacleMask mask = kEveryObstacle;
  std::int64_t particles = 0;  ///< free particles in the tile
  std::int64_t tested = 0;     ///< particle-obstacle pairs left to the narrow phase
  std::int64_t skipped = 0;    ///< pairs ruled out
};

/// Broad phase of tile `tile`: the box of its free particles' points in `points` (positions,
/// or the inertial targets for the initial guess), and of points + offsets where `offsets` is
/// given (where a Newton direction would take them), against every obstacle's distance bound.
inline TileContacts tile_contacts(const ClothMesh& mesh, const std::vector<Obstacle>& obstacles,
                                  double distance, std::int64_t tile,
                                  const std::vector<double>& points,
                                  const std::vector<double>* offsets = nullptr) {
  TileContacts c;
  const double inf = std::numeric_limits<double>::infinity();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(inf), hi = Eigen::Vector3d::Constant(-inf);
  bool finite = true;
  for (std::int64_t s = mesh.tile_slot_begin[tile]; s < mesh.tile_slot_begin[tile + 1]; ++s) {
    if ((mesh.flags[s] & (kParticleActive | kParticlePinned)) != kParticleActive) continue;
    const Eigen::Vector3d p = vec3(points, s);
    finite = finite && p.allFinite();
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
    if (offsets != nullptr) {
      const Eigen::Vector3d q = p + vec3(*offsets, s);
      finite = finite && q.allFinite();
      lo = lo.cwiseMin(q);
      hi = hi.cwiseMax(q);
    }
    ++c.particles;
  }
  const auto count = static_cast<std::int64_t>(obstacles.size());
  if (c.particles == 0 || !finite) {
    c.tested = c.particles * count;
    return c;
  }
  const Eigen::AlignedBox3d box(lo, hi);
  const double box_scale = std::max(lo.cwiseAbs().maxCoeff(), hi.cwiseAbs().maxCoeff());
  c.mask = 0;
  std::int64_t touching = 0;
  for (std::size_t k = 0; k < obstacles.size(); ++k) {
    const Obstacle& o = obstacles[k];
    const double margin = 1e-9 * (1.0 + box_scale + o.coordinate_scale());
    const bool far = k < kMaskedObstacles && o.distance_lower_bound(box) >= distance + margin;
    if (!far) {
      if (k < kMaskedObstacles) c.mask |= ObstacleMask{1} << k;
      ++touching;
    }
  }
  c.tested = c.particles * touching;
  c.skipped = c.particles * count - c.tested;
  return c;
}

}  // namespace clothbench::kernels
