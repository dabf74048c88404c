// Obstacle construction, SDF Hessians and the broad-phase bounds (MODEL.md 8).
#include "kernels/obstacle.hpp"

#include <limits>
#include <stdexcept>

namespace clothbench::kernels {
namespace {

/// Componentwise distance from the point `c` to the interval [min, max] of `region`.
Eigen::Vector3d interval_distance(const Eigen::Vector3d& c, const Eigen::AlignedBox3d& region) {
  return (region.min() - c).cwiseMax(c - region.max()).cwiseMax(0.0);
}

/// Lower bound over `region` of the SDF of the axis-aligned box (center, half): the box SDF
/// evaluated on per-axis interval distances (exact outside, max_k of per-axis minima inside).
double box_lower_bound(const Eigen::Vector3d& center, const Eigen::Vector3d& half,
                       const Eigen::AlignedBox3d& region) {
  const Eigen::Vector3d q = interval_distance(center, region) - half;
  const double outside = q.cwiseMax(0.0).norm();
  return outside > 0.0 ? outside : q.maxCoeff();
}

Eigen::Vector3d unit_or_throw(const Eigen::Vector3d& v, const char* what) {
  const double length = v.norm();
  if (!(length > 0.0) || !std::isfinite(length)) {
    throw std::invalid_argument(std::string("obstacle: ") + what + " must be a non-zero vector");
  }
  return v / length;
}

}  // namespace

Obstacle::Obstacle(const ObstacleConfig& config)
    : kind_(config.kind),
      center_(config.center),
      axis_(Eigen::Vector3d::UnitZ()),
      perpendicular_(Eigen::Vector3d::UnitX()),
      half_extents_(config.half_extents),
      radius_(config.radius),
      half_length_(config.half_length) {
  if (!(radius_ >= 0.0) || !(half_length_ >= 0.0) || !(half_extents_.minCoeff() >= 0.0)) {
    throw std::invalid_argument("obstacle: radius, half_length and half_extents must be >= 0");
  }
  if (kind_ == ObstacleKind::plane) axis_ = unit_or_throw(config.normal, "plane normal");
  if (kind_ == ObstacleKind::cylinder) {
    axis_ = unit_or_throw(config.axis, "cylinder axis");
    Eigen::Index smallest = 0;
    axis_.cwiseAbs().minCoeff(&smallest);
    perpendicular_ = axis_.cross(Eigen::Vector3d::Unit(smallest)).normalized();
  }
}

Eigen::Matrix3d Obstacle::normal_jacobian(const Eigen::Vector3d& x) const {
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  switch (kind_) {
    case ObstacleKind::plane:
      return Eigen::Matrix3d::Zero();
    case ObstacleKind::sphere: {
      const Eigen::Vector3d d = x - center_;
      const double r = d.norm();
      if (!(r > 0.0)) return Eigen::Matrix3d::Zero();
      const Eigen::Vector3d n = d / r;
      return (identity - n * n.transpose()) / r;
    }
    case ObstacleKind::box: {
      // Outside: n = v/|v| with v the offset from the closest point; dv/dx = P = diag(q > 0),
      // so dn/dx = (P - n n^T)/|v| (zero on faces). Inside: flat faces, zero.
      const Eigen::Vector3d d = x - center_;
      const Eigen::Vector3d q = d.cwiseAbs() - half_extents_;
      const double outside = q.cwiseMax(0.0).norm();
      if (!(outside > 0.0)) return Eigen::Matrix3d::Zero();
      Eigen::Vector3d n;
      box_distance(x, n);
      const Eigen::Vector3d active = (q.array() > 0.0).cast<double>();
      return (Eigen::Matrix3d(active.asDiagonal()) - n * n.transpose()) / outside;
    }
    case ObstacleKind::cylinder: {
      const Eigen::Vector3d d = x - center_;
      const double axial = axis_.dot(d);
      const Eigen::Vector3d radial = d - axial * axis_;
      const double rho = radial.norm();
      const double q_side = rho - radius_;
      const double q_cap = std::abs(axial) - half_length_;
      if (!(rho > 0.0)) return Eigen::Matrix3d::Zero();  // on the axis: cap or singular line
      const Eigen::Vector3d u = radial / rho;
      const Eigen::Vector3d t = axis_.cross(u);  // tangent of the circle through x
      const Eigen::Matrix3d tangential = t * t.transpose();
      if (q_side > 0.0 && q_cap > 0.0) {
        // Rim: v = q_side u + q_cap sign a, dv/dx = I - (r/rho) t t^T; n is its eigenvector.
        const double length = std::hypot(q_side, q_cap);
        Eigen::Vector3d n;
        cylinder_distance(x, n);
        return (identity - n * n.transpose() - (radius_ / rho) * tangential) / length;
      }
      if (q_side > q_cap) return tangential / rho;  // side: d(u)/dx = t t^T / rho
      return Eigen::Matrix3d::Zero();               // cap
    }
  }
  return Eigen::Matrix3d::Zero();
}

Eigen::AlignedBox3d Obstacle::bounds() const {
  switch (kind_) {
    case ObstacleKind::plane: {
      const double inf = std::numeric_limits<double>::infinity();
      return {Eigen::Vector3d::Constant(-inf), Eigen::Vector3d::Constant(inf)};
    }
    case ObstacleKind::sphere:
      return {center_.array() - radius_, center_.array() + radius_};
    case ObstacleKind::box:
      return {center_ - half_extents_, center_ + half_extents_};
    case ObstacleKind::cylinder: {
      // Per axis k: the axis segment spans half_length |a_k|; a cap disk spans r sqrt(1 - a_k^2).
      const Eigen::Vector3d disk =
          (Eigen::Vector3d::Ones() - axis_.cwiseAbs2()).cwiseMax(0.0).cwiseSqrt() * radius_;
      const Eigen::Vector3d extent = half_length_ * axis_.cwiseAbs() + disk;
      return {center_ - extent, center_ + extent};
    }
  }
  return {};
}

double Obstacle::distance_lower_bound(const Eigen::AlignedBox3d& region) const {
  switch (kind_) {
    case ObstacleKind::plane: {
      // Exact minimum of the affine SDF over the box.
      const Eigen::Vector3d mid = region.center();
      const Eigen::Vector3d half = 0.5 * region.sizes();
      return axis_.dot(mid - center_) - axis_.cwiseAbs().dot(half);
    }
    case ObstacleKind::sphere: {
      // |x - c| - r >= dist(c, region) - r.
      return interval_distance(center_, region).norm() - radius_;
    }
    case ObstacleKind::box:
      return box_lower_bound(center_, half_extents_, region);
    case ObstacleKind::cylinder: {
      // The SDF of a superset is <= the SDF: use the bounding box, and the slab |a.(x-c)| <= h.
      const Eigen::AlignedBox3d box = bounds();
      const double by_box = box_lower_bound(box.center(), 0.5 * box.sizes(), region);
      const double mid = axis_.dot(region.center() - center_);
      const double spread = axis_.cwiseAbs().dot(0.5 * region.sizes());
      const double nearest_axial = std::max(0.0, std::abs(mid) - spread);
      return std::max(by_box, nearest_axial - half_length_);
    }
  }
  return -std::numeric_limits<double>::infinity();
}

}  // namespace clothbench::kernels
