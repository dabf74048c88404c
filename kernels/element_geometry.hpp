// Geometry of edges and triples and its derivatives (MODEL.md section 2).
//
// Triple (a, c, b) with e1 = x_c - x_a, e2 = x_b - x_c: turning angle
// theta = atan2(|e1 x e2|, e1 . e2) in [0, pi] (never acos of a clamped dot). Its gradient is a
// linear combination of e1 and e2:
//   d theta / d x_a = -A e1 + Bc e2,   d theta / d x_b = -Bc e1 + C e2,
//   d theta / d x_c = -(d theta / d x_a + d theta / d x_b),
// with A = cos / (sin |e1|^2), Bc = 1 / (sin |e1| |e2|), C = cos / (sin |e2|^2).
// Templated on the scalar so that dual numbers give exact Hessian-vector products.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace clothbench::kernels {

/// Coefficients of the turning-angle gradient in the (e1, e2) basis, plus theta itself.
template <class Scalar>
struct TurningAngle {
  Scalar theta;  ///< rad, in [0, pi]
  Scalar a;      ///< A
  Scalar bc;     ///< Bc
  Scalar c;      ///< C
  bool degenerate;  ///< sin(theta) ~ 0: gradient direction undefined (coefficients are zero)
};

/// Below this |e1 x e2| / (|e1| |e2|) the gradient is treated as zero: a straight or fully
/// folded triple. The bending band closes at zero curvature, so the force vanishes there.
inline constexpr double kStraightSine = 1e-12;

template <class Scalar>
TurningAngle<Scalar> turning_angle(const Eigen::Matrix<Scalar, 3, 1>& e1,
                                   const Eigen::Matrix<Scalar, 3, 1>& e2) {
  using std::atan2;
  using std::sqrt;
  const Scalar n1sq = e1.squaredNorm();
  const Scalar n2sq = e2.squaredNorm();
  const Scalar n1 = sqrt(n1sq), n2 = sqrt(n2sq);
  const Scalar cross = sqrt(e1.cross(e2).squaredNorm());
  const Scalar dot = e1.dot(e2);
  TurningAngle<Scalar> t{Scalar(0), Scalar(0), Scalar(0), Scalar(0), false};
  // Nearly straight triples (most of a draped cloth): atan(r) by its series, exact to the
  // last bit for r < 1e-3 (the first dropped term is r^9/9 < 1e-27 r); atan2 otherwise.
  if (dot > Scalar(0) && cross < Scalar(1e-3) * dot) {
    const Scalar r = cross / dot, r2 = r * r;
    t.theta = r * (Scalar(1) - r2 * (Scalar(1) / 3 - r2 * (Scalar(1) / 5 - r2 / 7)));
  } else {
    t.theta = atan2(cross, dot);
  }
  const Scalar n12 = n1 * n2;
  if (!(cross > kStraightSine * n12)) {
    t.degenerate = true;
    return t;
  }
  const Scalar sine = cross / n12, cosine = dot / n12;
  t.a = cosine / (sine * n1sq);
  t.bc = Scalar(1) / (sine * n12);
  t.c = cosine / (sine * n2sq);
  return t;
}

}  // namespace clothbench::kernels
