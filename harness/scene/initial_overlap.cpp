// The start-inside-an-obstacle check of the scene loader (see initial_overlap.hpp).
#include "harness/scene/initial_overlap.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace clothbench::harness::scene_detail {
namespace {

/// The grid's start positions: flat point of (i, j) plus t * crumple, t in [-1, 1].
struct StartGrid {
  Eigen::Vector3d origin;
  Eigen::Vector3d step_i;   ///< (1 + stretch) h_i axis_i, m
  Eigen::Vector3d step_j;   ///< (1 + stretch) h_j axis_j, m
  Eigen::Vector3d crumple;  ///< initial_crumple_m * unit normal, m

  Eigen::Vector3d flat(std::int64_t i, std::int64_t j) const {
    return origin + static_cast<double>(i) * step_i + static_cast<double>(j) * step_j;
  }
};

/// Minimum of the signed distance over the segment p + t crumple, t in [-1, 1]. Every
/// obstacle is convex, so its signed distance is convex along a line: golden-section search.
double segment_minimum(const kernels::Obstacle& obstacle, const Eigen::Vector3d& p,
                       const Eigen::Vector3d& crumple) {
  double best = obstacle.signed_distance(p);
  if (crumple.isZero()) return best;
  auto f = [&](double t) { return obstacle.signed_distance(p + t * crumple); };
  constexpr double kGolden = 0.6180339887498949;
  double a = -1.0, b = 1.0;
  double c = b - kGolden * (b - a), d = a + kGolden * (b - a);
  double fc = f(c), fd = f(d);
  for (int k = 0; k < 48; ++k) {
    if (fc < fd) {
      b = d, d = c, fd = fc;
      c = b - kGolden * (b - a);
      fc = f(c);
    } else {
      a = c, c = d, fc = fd;
      d = a + kGolden * (b - a);
      fd = f(d);
    }
  }
  return std::min({best, fc, fd, f(-1.0), f(1.0)});
}

struct Search {
  const kernels::Obstacle& obstacle;
  StartGrid grid;
  Eigen::Vector3d crumple_extent;  ///< |crumple| per axis: how far a block's box grows
  std::int64_t& budget;
  double best = -kOverlapTolerance;  ///< deepest signed distance found (only below this counts)
  std::optional<InitialOverlap> found;

  /// Axis-aligned box of every start position of the block [i0, i1] x [j0, j1].
  Eigen::AlignedBox3d bounds(std::int64_t i0, std::int64_t i1, std::int64_t j0,
                             std::int64_t j1) const {
    Eigen::AlignedBox3d box(grid.flat(i0, j0));
    box.extend(grid.flat(i1, j0));
    box.extend(grid.flat(i0, j1));
    box.extend(grid.flat(i1, j1));
    return {box.min() - crumple_extent, box.max() + crumple_extent};
  }

  /// Whether a block whose signed distance is at least `lower` may still beat `best`; the
  /// relative slack stops refining once the depth is known to 0.1 %.
  bool promising(double lower) const {
    return lower < best - 1e-3 * std::abs(best);  // false for NaN (overflowing coordinates)
  }

  void visit(std::int64_t i0, std::int64_t i1, std::int64_t j0, std::int64_t j1) {
    if (--budget < 0) {
      if (found) found->complete = false;
      return;
    }
    if (i0 == i1 && j0 == j1) {
      const Eigen::Vector3d p = grid.flat(i0, j0);
      const double distance = segment_minimum(obstacle, p, grid.crumple);
      if (distance < best) {
        best = distance;
        found = InitialOverlap{static_cast<int>(i0),
                               static_cast<int>(j0),
                               p,
                               -distance,
                               -obstacle.signed_distance(p),
                               true};
      }
      return;
    }
    // Split the longer side; visit the half with the lower bound first.
    std::int64_t a[4], b[4];
    if (i1 - i0 >= j1 - j0) {
      const std::int64_t mid = i0 + (i1 - i0) / 2;
      a[0] = i0, a[1] = mid, a[2] = j0, a[3] = j1;
      b[0] = mid + 1, b[1] = i1, b[2] = j0, b[3] = j1;
    } else {
      const std::int64_t mid = j0 + (j1 - j0) / 2;
      a[0] = i0, a[1] = i1, a[2] = j0, a[3] = mid;
      b[0] = i0, b[1] = i1, b[2] = mid + 1, b[3] = j1;
    }
    double lower_a = obstacle.distance_lower_bound(bounds(a[0], a[1], a[2], a[3]));
    double lower_b = obstacle.distance_lower_bound(bounds(b[0], b[1], b[2], b[3]));
    if (lower_b < lower_a) {
      std::swap(a, b);
      std::swap(lower_a, lower_b);
    }
    if (promising(lower_a)) visit(a[0], a[1], a[2], a[3]);
    if (promising(lower_b)) visit(b[0], b[1], b[2], b[3]);
  }
};

}  // namespace

std::optional<InitialOverlap> deepest_initial_overlap(const kernels::ClothConfig& cloth,
                                                      const kernels::Obstacle& obstacle,
                                                      std::int64_t& budget) {
  const double scale = 1.0 + cloth.initial_stretch;
  const Eigen::Vector3d normal = cloth.axis_i.cross(cloth.axis_j).normalized();
  StartGrid grid{cloth.origin, scale * cloth.size_i / (cloth.particles_i - 1) * cloth.axis_i,
                 scale * cloth.size_j / (cloth.particles_j - 1) * cloth.axis_j,
                 cloth.initial_crumple * normal};
  Search search{obstacle, grid, grid.crumple.cwiseAbs(), budget, -kOverlapTolerance, {}};
  const std::int64_t last_i = cloth.particles_i - 1, last_j = cloth.particles_j - 1;
  if (search.promising(obstacle.distance_lower_bound(search.bounds(0, last_i, 0, last_j)))) {
    search.visit(0, last_i, 0, last_j);
  }
  return search.found;
}

}  // namespace clothbench::harness::scene_detail
