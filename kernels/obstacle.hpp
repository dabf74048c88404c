// Analytic rigid obstacles with an exact signed distance, its gradient (outward normal) and
// Hessian (normal Jacobian) for contact, and a cheap broad phase (MODEL.md 4, 8).
// Lengths in metres. The hot queries are inline; construction and bounds live in obstacle.cpp.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "kernels/simulation_config.hpp"

namespace clothbench::kernels {

/// One obstacle: plane, axis-aligned box, sphere or capped cylinder (arbitrary unit axis).
/// signed_distance is the exact Euclidean SDF, negative inside. Where the SDF is not
/// differentiable (medial axis, centre, cylinder axis: sets of measure zero) the normal is a
/// consistent one-sided choice: ties go to the lowest coordinate / the cap, zero goes to +.
class Obstacle {
 public:
  /// Validates and normalises `config` (throws std::invalid_argument on a zero normal or
  /// axis, or negative sizes).
  explicit Obstacle(const ObstacleConfig& config);

  /// Which analytic shape this is.
  ObstacleKind kind() const { return kind_; }
  /// Centre (for a plane: a point on it), m.
  const Eigen::Vector3d& center() const { return center_; }
  /// Moves the obstacle by `displacement`, m (scripted scene events, between steps).
  void translate(const Eigen::Vector3d& displacement) { center_ += displacement; }
  /// Magnitude of the numbers its distances are computed from, m: |centre|_inf plus its
  /// largest extent (scales the rounding margin of the contact broad phase).
  double coordinate_scale() const {
    return center_.cwiseAbs().maxCoeff() +
           std::max({radius_, half_length_, half_extents_.maxCoeff()});
  }

  /// Exact signed distance of `x` to the surface, m (negative inside).
  double signed_distance(const Eigen::Vector3d& x) const {
    Eigen::Vector3d normal;
    return signed_distance(x, normal);
  }

  /// Signed distance, m, and `normal`: the unit outward gradient of the SDF at `x`.
  double signed_distance(const Eigen::Vector3d& x, Eigen::Vector3d& normal) const {
    switch (kind_) {
      case ObstacleKind::plane:
        normal = axis_;
        return axis_.dot(x - center_);
      case ObstacleKind::sphere:
        return sphere_distance(x, normal);
      case ObstacleKind::box:
        return box_distance(x, normal);
      case ObstacleKind::cylinder:
        return cylinder_distance(x, normal);
    }
    normal = Eigen::Vector3d::UnitZ();
    return 0.0;
  }

  /// d(normal)/dx at `x`, 1/m: the SDF Hessian (symmetric, normal in its null space).
  /// Zero on flat faces; (I - n n^T)/r style near spheres, edges, corners, cylinder sides.
  Eigen::Matrix3d normal_jacobian(const Eigen::Vector3d& x) const;

  /// Axis-aligned bounds of the solid, m (infinite for a plane).
  Eigen::AlignedBox3d bounds() const;

  /// A value <= signed_distance(x) for every x in `region` (cheap broad phase, m).
  double distance_lower_bound(const Eigen::AlignedBox3d& region) const;

 private:
  double sphere_distance(const Eigen::Vector3d& x, Eigen::Vector3d& normal) const {
    const Eigen::Vector3d d = x - center_;
    const double r = d.norm();
    normal = r > 0.0 ? Eigen::Vector3d(d / r) : Eigen::Vector3d::UnitZ();
    return r - radius_;
  }

  double box_distance(const Eigen::Vector3d& x, Eigen::Vector3d& normal) const {
    const Eigen::Vector3d d = x - center_;
    const Eigen::Vector3d sign = d.unaryExpr([](double v) { return v < 0.0 ? -1.0 : 1.0; });
    const Eigen::Vector3d q = d.cwiseAbs() - half_extents_;
    const Eigen::Vector3d outside = q.cwiseMax(0.0);
    const double outside_norm = outside.norm();
    if (outside_norm > 0.0) {  // outside: towards the closest point (face, edge or corner)
      normal = sign.cwiseProduct(outside) / outside_norm;
      return outside_norm;
    }
    Eigen::Index face = 0;  // inside: the nearest face (first on ties)
    const double depth = q.maxCoeff(&face);
    normal = Eigen::Vector3d::Zero();
    normal[face] = sign[face];
    return depth;
  }

  double cylinder_distance(const Eigen::Vector3d& x, Eigen::Vector3d& normal) const {
    const Eigen::Vector3d d = x - center_;
    const double axial = axis_.dot(d);
    const Eigen::Vector3d radial = d - axial * axis_;
    const double rho = radial.norm();
    const Eigen::Vector3d radial_unit = rho > 0.0 ? Eigen::Vector3d(radial / rho) : perpendicular_;
    const double axial_sign = axial < 0.0 ? -1.0 : 1.0;
    const double q_side = rho - radius_;
    const double q_cap = std::abs(axial) - half_length_;
    if (q_side > 0.0 && q_cap > 0.0) {  // outside, nearest the rim
      const double length = std::hypot(q_side, q_cap);
      normal = (q_side * radial_unit + q_cap * axial_sign * axis_) / length;
      return length;
    }
    if (q_side > q_cap) {  // side (outside or inside)
      normal = radial_unit;
      return q_side;
    }
    normal = axial_sign * axis_;  // cap (outside or inside; ties go to the cap)
    return q_cap;
  }

  ObstacleKind kind_;
  Eigen::Vector3d center_;
  Eigen::Vector3d axis_;           ///< plane normal or cylinder axis (unit)
  Eigen::Vector3d perpendicular_;  ///< a unit vector normal to axis_ (cylinder axis choice)
  Eigen::Vector3d half_extents_;
  double radius_ = 0.0;
  double half_length_ = 0.0;
};

}  // namespace clothbench::kernels
