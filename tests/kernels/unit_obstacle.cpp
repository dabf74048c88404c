// Analytic obstacles (MODEL.md 8): the SDF against brute-force distances to the surface
// patches, normal == central-difference gradient, normal_jacobian == central differences of
// the normal, bounds and the broad-phase lower bound.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include "kernels/obstacle.hpp"

namespace clothbench::kernels {
namespace {

using Eigen::Vector3d;

ObstacleConfig plane_config() {
  ObstacleConfig c;
  c.kind = ObstacleKind::plane;
  c.center = Vector3d(0.1, -0.2, 0.3);
  c.normal = Vector3d(1.0, 2.0, 2.0);  // not unit: the obstacle normalises it
  return c;
}
ObstacleConfig box_config() {
  ObstacleConfig c;
  c.kind = ObstacleKind::box;
  c.center = Vector3d(0.1, 0.2, -0.1);
  c.half_extents = Vector3d(0.3, 0.2, 0.1);
  return c;
}
ObstacleConfig sphere_config() {
  ObstacleConfig c;
  c.kind = ObstacleKind::sphere;
  c.center = Vector3d(0.2, -0.1, 0.05);
  c.radius = 0.35;
  return c;
}
ObstacleConfig cylinder_config(const Vector3d& axis) {
  ObstacleConfig c;
  c.kind = ObstacleKind::cylinder;
  c.center = Vector3d(0.05, 0.1, -0.05);
  c.axis = axis.normalized();
  c.radius = 0.2;
  c.half_length = 0.3;
  return c;
}
std::vector<ObstacleConfig> all_configs() {
  return {plane_config(), box_config(), sphere_config(),
          cylinder_config(Vector3d(1.0, 1.0, 2.0)), cylinder_config(Vector3d::UnitZ())};
}

/// Distance from x to the closest point of the surface, by projecting on each surface patch
/// separately (faces, disks, side) and taking the minimum; sign by an inside test.
double brute_force_distance(const ObstacleConfig& c, const Vector3d& x) {
  const Vector3d d = x - c.center;
  switch (c.kind) {
    case ObstacleKind::plane: {
      // Closest point y = x - t n with (y - c) . n = 0: distance |t|, sign of t.
      const Vector3d n = c.normal.normalized();
      const Vector3d y = x - n.dot(d) * n;
      const double dist = (x - y).norm();
      return n.dot(d) < 0.0 ? -dist : dist;
    }
    case ObstacleKind::sphere: {
      const double dist = std::abs(d.norm() - c.radius);
      return d.norm() < c.radius ? -dist : dist;
    }
    case ObstacleKind::box: {
      double best = std::numeric_limits<double>::infinity();
      for (int axis = 0; axis < 3; ++axis) {
        for (double side : {-1.0, 1.0}) {  // face: clamp onto its rectangle
          Vector3d y = d.cwiseMax(-c.half_extents).cwiseMin(c.half_extents);
          y[axis] = side * c.half_extents[axis];
          best = std::min(best, (d - y).norm());
        }
      }
      const bool inside = (d.cwiseAbs() - c.half_extents).maxCoeff() < 0.0;
      return inside ? -best : best;
    }
    case ObstacleKind::cylinder: {
      const Vector3d a = c.axis.normalized();
      const double h = a.dot(d);
      const Vector3d radial = d - h * a;
      const double rho = radial.norm();
      const Vector3d u = rho > 0.0 ? Vector3d(radial / rho) : Vector3d::UnitX();
      const Vector3d side = std::clamp(h, -c.half_length, c.half_length) * a + c.radius * u;
      double best = (d - side).norm();
      for (double s : {-1.0, 1.0}) {  // caps: disks of radius r
        const Vector3d disk = s * c.half_length * a + std::min(rho, c.radius) * u;
        best = std::min(best, (d - disk).norm());
      }
      const bool inside = rho < c.radius && std::abs(h) < c.half_length;
      return inside ? -best : best;
    }
  }
  return 0.0;
}

/// True when x is at least `margin` away from every set where the SDF's Hessian jumps
/// (region boundaries, medial surfaces, centre, axis).
bool smooth_at(const ObstacleConfig& c, const Vector3d& x, double margin) {
  const Vector3d d = x - c.center;
  switch (c.kind) {
    case ObstacleKind::plane:
      return true;
    case ObstacleKind::sphere:
      return d.norm() > margin;
    case ObstacleKind::box: {
      Vector3d q = d.cwiseAbs() - c.half_extents;
      if (q.cwiseAbs().minCoeff() < margin) return false;
      if (q.maxCoeff() < 0.0) {  // inside: away from the medial surfaces
        std::sort(q.data(), q.data() + 3);
        return q[2] - q[1] > margin;
      }
      return true;
    }
    case ObstacleKind::cylinder: {
      const Vector3d a = c.axis.normalized();
      const double h = a.dot(d);
      const double rho = (d - h * a).norm();
      const double q_side = rho - c.radius;
      const double q_cap = std::abs(h) - c.half_length;
      return rho > margin && std::abs(q_side) > margin && std::abs(q_cap) > margin &&
             std::abs(q_side - q_cap) > margin;
    }
  }
  return false;
}

std::vector<Vector3d> random_points(std::mt19937& rng, int count, double extent) {
  std::uniform_real_distribution<double> uniform(-extent, extent);
  std::vector<Vector3d> points;
  for (int i = 0; i < count; ++i) points.emplace_back(uniform(rng), uniform(rng), uniform(rng));
  return points;
}

TEST(Obstacle, SignedDistanceMatchesBruteForce) {
  std::mt19937 rng(7);
  for (const ObstacleConfig& c : all_configs()) {
    const Obstacle obstacle(c);
    EXPECT_EQ(obstacle.kind(), c.kind);
    int inside = 0;
    for (const Vector3d& x : random_points(rng, 4000, 0.5)) {
      const double sd = obstacle.signed_distance(x);
      EXPECT_NEAR(sd, brute_force_distance(c, x), 1e-12) << x.transpose();
      Vector3d n;
      EXPECT_EQ(obstacle.signed_distance(x, n), sd);
      EXPECT_NEAR(n.norm(), 1.0, 1e-14);
      inside += sd < 0.0;
    }
    EXPECT_GT(inside, 150);  // both signs were exercised
    EXPECT_LT(inside, 3900);
  }
}

TEST(Obstacle, NormalIsTheSdfGradient) {
  std::mt19937 rng(11);
  const double h = 1e-6;
  for (const ObstacleConfig& c : all_configs()) {
    const Obstacle obstacle(c);
    int checked = 0;
    for (const Vector3d& x : random_points(rng, 3000, 0.8)) {
      if (!smooth_at(c, x, 1e-3)) continue;
      Vector3d n;
      obstacle.signed_distance(x, n);
      Vector3d gradient;
      for (int k = 0; k < 3; ++k) {
        const Vector3d e = h * Vector3d::Unit(k);
        gradient[k] = (obstacle.signed_distance(x + e) - obstacle.signed_distance(x - e)) / (2 * h);
      }
      EXPECT_LT((gradient - n).norm(), 1e-8) << x.transpose();
      ++checked;
    }
    EXPECT_GT(checked, 2000);
  }
}

TEST(Obstacle, NormalJacobianMatchesCentralDifferences) {
  std::mt19937 rng(13);
  const double h = 1e-6;
  for (const ObstacleConfig& c : all_configs()) {
    const Obstacle obstacle(c);
    double largest = 0.0;
    for (const Vector3d& x : random_points(rng, 3000, 0.8)) {
      if (!smooth_at(c, x, 2e-3)) continue;
      const Eigen::Matrix3d jacobian = obstacle.normal_jacobian(x);
      Eigen::Matrix3d numeric;
      for (int k = 0; k < 3; ++k) {
        const Vector3d e = h * Vector3d::Unit(k);
        Vector3d plus;
        Vector3d minus;
        obstacle.signed_distance(x + e, plus);
        obstacle.signed_distance(x - e, minus);
        numeric.col(k) = (plus - minus) / (2 * h);
      }
      const double scale = 1.0 + jacobian.norm();
      EXPECT_LT((jacobian - numeric).norm(), 1e-7 * scale)
          << static_cast<int>(c.kind) << " at " << x.transpose();
      EXPECT_LT((jacobian - jacobian.transpose()).norm(), 1e-12 * scale);
      Vector3d n;
      obstacle.signed_distance(x, n);
      EXPECT_LT((jacobian * n).norm(), 1e-12 * scale);
      largest = std::max(largest, jacobian.norm());
    }
    if (c.kind != ObstacleKind::plane) {
      EXPECT_GT(largest, 1.0);  // curvature was exercised
    }
  }
}

TEST(Obstacle, BoundsContainTheSolid) {
  std::mt19937 rng(17);
  for (const ObstacleConfig& c : all_configs()) {
    const Obstacle obstacle(c);
    const Eigen::AlignedBox3d box = obstacle.bounds();
    if (c.kind == ObstacleKind::plane) {
      EXPECT_TRUE(std::isinf(box.volume()));
      continue;
    }
    Vector3d lowest = Vector3d::Constant(1e9);
    Vector3d highest = Vector3d::Constant(-1e9);
    for (const Vector3d& x : random_points(rng, 200000, 0.8)) {
      if (obstacle.signed_distance(x) > 0.0) continue;
      EXPECT_TRUE(box.contains(x)) << x.transpose();
      lowest = lowest.cwiseMin(x);
      highest = highest.cwiseMax(x);
    }
    EXPECT_LT((lowest - box.min()).cwiseAbs().maxCoeff(), 0.03);  // and are tight
    EXPECT_LT((highest - box.max()).cwiseAbs().maxCoeff(), 0.03);
  }
}

TEST(Obstacle, DistanceLowerBoundHoldsOverRandomBoxes) {
  std::mt19937 rng(19);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const ObstacleConfig& c : all_configs()) {
    const Obstacle obstacle(c);
    int useful = 0;
    for (int trial = 0; trial < 300; ++trial) {
      const Vector3d centre = random_points(rng, 1, 1.2).front();
      const Vector3d half(0.3 * unit(rng), 0.3 * unit(rng), 0.3 * unit(rng));
      const Eigen::AlignedBox3d region(centre - half, centre + half);
      const double bound = obstacle.distance_lower_bound(region);
      double smallest = std::numeric_limits<double>::infinity();
      for (int corner = 0; corner < 8; ++corner) {
        smallest = std::min(smallest, obstacle.signed_distance(
                                          region.corner(static_cast<Eigen::AlignedBox3d::CornerType>(corner))));
      }
      for (int k = 0; k < 3000; ++k) {
        const Vector3d x = centre + half.cwiseProduct(random_points(rng, 1, 1.0).front());
        smallest = std::min(smallest, obstacle.signed_distance(x));
      }
      EXPECT_LE(bound, smallest + 1e-12) << centre.transpose() << " / " << half.transpose();
      useful += bound > 0.5 * smallest && smallest > 0.0;
    }
    EXPECT_GT(useful, 30);  // far boxes are recognised as far
  }
}

TEST(Obstacle, RejectsDegenerateConfigs) {
  ObstacleConfig plane = plane_config();
  plane.normal = Vector3d::Zero();
  EXPECT_THROW(Obstacle{plane}, std::invalid_argument);
  ObstacleConfig cylinder = cylinder_config(Vector3d::UnitX());
  cylinder.axis = Vector3d::Zero();
  EXPECT_THROW(Obstacle{cylinder}, std::invalid_argument);
  ObstacleConfig sphere = sphere_config();
  sphere.radius = -1.0;
  EXPECT_THROW(Obstacle{sphere}, std::invalid_argument);
}

}  // namespace
}  // namespace clothbench::kernels
