// Element and particle terms of the `violation` formulation (MODEL.md 4A, the paper's):
// band violations of the unknown forces, the Newton residual built from them, the obstacle
// supports that cancel its outward part, and a forward-mode dual number that differentiates
// the turning-angle gradient of element_geometry.hpp (exact Hessian-vector products).
// Positions, tensions and moments are read through accessors so that the analytic loops and
// the local numeric gradient share one definition.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "kernels/potential_elements.hpp"
#include "kernels/step_context.hpp"

namespace clothbench::kernels {

/// Forward-mode dual number value + derivative * epsilon (epsilon^2 = 0).
struct Dual {
  double v = 0.0;  ///< value
  double d = 0.0;  ///< derivative along the seeded direction
  constexpr Dual() = default;
  constexpr Dual(double value, double derivative = 0.0) : v(value), d(derivative) {}  // NOLINT
  Dual& operator+=(const Dual& o) {
    v += o.v;
    d += o.d;
    return *this;
  }
  Dual& operator-=(const Dual& o) {
    v -= o.v;
    d -= o.d;
    return *this;
  }
  Dual& operator*=(const Dual& o) {
    d = d * o.v + v * o.d;
    v *= o.v;
    return *this;
  }
  Dual& operator/=(const Dual& o) {
    const double q = v / o.v;
    d = (d - q * o.d) / o.v;
    v = q;
    return *this;
  }
};
inline Dual operator+(Dual a, const Dual& b) { return a += b; }
inline Dual operator-(Dual a, const Dual& b) { return a -= b; }
inline Dual operator*(Dual a, const Dual& b) { return a *= b; }
inline Dual operator/(Dual a, const Dual& b) { return a /= b; }
inline Dual operator-(const Dual& a) { return {-a.v, -a.d}; }
inline Dual operator+(const Dual& a) { return a; }
inline bool operator<(const Dual& a, const Dual& b) { return a.v < b.v; }
inline bool operator>(const Dual& a, const Dual& b) { return a.v > b.v; }
inline bool operator<=(const Dual& a, const Dual& b) { return a.v <= b.v; }
inline bool operator>=(const Dual& a, const Dual& b) { return a.v >= b.v; }
inline bool operator==(const Dual& a, const Dual& b) { return a.v == b.v; }
inline bool operator!=(const Dual& a, const Dual& b) { return a.v != b.v; }
inline Dual sqrt(const Dual& a) {
  const double s = std::sqrt(a.v);
  return {s, s > 0.0 ? a.d / (2.0 * s) : 0.0};
}
inline Dual atan2(const Dual& y, const Dual& x) {
  const double r2 = x.v * x.v + y.v * y.v;
  return {std::atan2(y.v, x.v), r2 > 0.0 ? (x.v * y.d - y.v * x.d) / r2 : 0.0};
}

}  // namespace clothbench::kernels

namespace Eigen {
/// Lets Eigen's fixed-size vectors hold dual numbers (dot, cross, squaredNorm).
template <>
struct NumTraits<clothbench::kernels::Dual> : NumTraits<double> {
  using Real = clothbench::kernels::Dual;
  using NonInteger = clothbench::kernels::Dual;
  using Nested = clothbench::kernels::Dual;
  using Literal = clothbench::kernels::Dual;
  enum {
    IsComplex = 0,
    IsInteger = 0,
    IsSigned = 1,
    RequireInitialization = 1,
    ReadCost = 1,
    AddCost = 3,
    MulCost = 3
  };
};
}  // namespace Eigen

namespace clothbench::kernels {

/// Reference scales and weights of E = Cn En + Cs Es + Cb Eb + Cc Ec (MODEL.md 4A).
struct ViolationScales {
  /// s_ref per direction, N/m: stretch_reference_fm * Fm, or (stretch_reference_fm <= 0)
  /// m g / h per unit width = areal_density |g| spacing(d) (the weight of one finest cell
  /// carried by one strip of width h).
  double tension[2] = {1.0, 1.0};
  /// Mref per direction, N: HB = 2HB/2, or (HB = 0) B / spacing(d).
  double moment[2] = {1.0, 1.0};
  double length = 1.0;  ///< position scale: the finest spacing (min over directions), m
  double newton = 1.0, stretch = 1.0, bend = 1.0, contact = 1.0;  ///< Cn, Cs, Cb, Cc
};

inline ViolationScales violation_scales(const StepContext& ctx) {
  ViolationScales s;
  const SolverConfig& solver = ctx.config.solver;
  for (int d = 0; d < 2; ++d) {
    const double fm = ctx.material.tensile[d].fm;
    s.tension[d] = solver.stretch_reference_fm > 0.0 && fm > 0.0
                       ? solver.stretch_reference_fm * fm
                       : ctx.mesh.areal_density() * ctx.gravity_reference() * ctx.mesh.spacing(d);
    const BendingBand& band = ctx.material.bending[d];
    s.moment[d] = band.hb > 0.0 ? band.hb : band.b / ctx.mesh.spacing(d);
    if (!(s.moment[d] > 0.0)) s.moment[d] = 1.0;
    if (!(s.tension[d] > 0.0)) s.tension[d] = 1.0;
  }
  s.length = std::min(ctx.mesh.spacing(0), ctx.mesh.spacing(1));
  s.newton = solver.weight_newton;
  s.stretch = solver.weight_stretch;
  s.bend = solver.weight_bend;
  s.contact = solver.weight_contact;
  return s;
}

/// Geometry and band violation of edge `id` carrying tension `tension` (N/m).
struct EdgeViolation {
  Eigen::Vector3d unit = Eigen::Vector3d::Zero();  ///< (x_b - x_a) / l (zero if l = 0)
  double length = 0.0;                             ///< l, m
  BandViolation band;                              ///< v and its partials (force, strain)
};

template <class Positions>
inline EdgeViolation edge_violation(const StepContext& ctx, std::int64_t id, const Positions& x,
                                    double tension) {
  const ClothMesh& mesh = ctx.mesh;
  const Eigen::Vector3d e = x(mesh.next[id]) - x(element_slot(id));
  EdgeViolation ev;
  ev.length = e.norm();
  if (ev.length > 0.0) ev.unit = e / ev.length;
  const double strain = ev.length / mesh.edge_rest[id] - 1.0;
  ev.band = band_violation(ctx.material.tensile[element_direction(id)], tension, strain);
  return ev;
}

/// Geometry and band violation of triple `id` carrying moment `moment` (N).
struct TripleViolation {
  TurningAngle<double> angle{};
  Eigen::Vector3d e1 = Eigen::Vector3d::Zero();  ///< x_c - x_a
  Eigen::Vector3d e2 = Eigen::Vector3d::Zero();  ///< x_b - x_c
  BandViolation band;                            ///< v and its partials (moment, curvature)
};

template <class Positions>
inline TripleViolation triple_violation(const StepContext& ctx, std::int64_t id, const Positions& x,
                                        double moment) {
  const ClothMesh& mesh = ctx.mesh;
  const Eigen::Vector3d xc = x(element_slot(id));
  TripleViolation tv;
  tv.e1 = xc - x(mesh.prev[id]);
  tv.e2 = x(mesh.next[id]) - xc;
  tv.angle = turning_angle<double>(tv.e1, tv.e2);
  tv.band = band_violation(ctx.material.bending[element_direction(id)], moment,
                           tv.angle.theta / mesh.triple_rest(id));
  return tv;
}

/// Newton residual r_s = m (x_s - x~_s)/dt^2 - m g - f_s - F_s of free particle s (f_s the
/// scripted external force, if any), computed from
/// scratch (no support): forces from the accessors tension(id), moment(id).
template <class Positions, class Tension, class Moment>
inline Eigen::Vector3d newton_residual(const StepContext& ctx, std::int64_t s, const Positions& x,
                                       const Tension& tension, const Moment& moment) {
  const ClothMesh& mesh = ctx.mesh;
  const double dt = ctx.dt(), m = mesh.mass[s];
  auto edge = [&](std::int64_t id) {
    const double l = (x(mesh.next[id]) - x(element_slot(id))).norm();
    return l > 0.0 ? mesh.edge_width[id] * tension(id) / l : 0.0;
  };
  auto triple = [&](std::int64_t id) {
    const Eigen::Vector3d xc = x(element_slot(id));
    const TurningAngle<double> t =
        turning_angle<double>(xc - x(mesh.prev[id]), x(mesh.next[id]) - xc);
    return Eigen::Vector3d(mesh.triple_width(id) * moment(id) * Eigen::Vector3d(t.a, t.bc, t.c));
  };
  Eigen::Vector3d r = m / (dt * dt) * (x(s) - vec3(ctx.state.target, s)) -
                      m * ctx.config.time.gravity + gather_elastic(mesh, s, x, edge, triple);
  if (ctx.is_forced(s)) r -= ctx.external_force(s);  // a scripted force, like gravity
  return r;
}

/// Applies the supports of obstacles [0, count), in order, to residual r of a particle at x:
/// within distance d of obstacle k (outward normal n), lambda = max(0, n . r) and
/// r <- r - lambda n (MODEL.md 4A). Obstacles outside `mask` are farther than d (broad phase).
inline Eigen::Vector3d supported_residual(const StepContext& ctx, const Eigen::Vector3d& x,
                                          Eigen::Vector3d r, std::size_t count,
                                          ObstacleMask mask = kEveryObstacle) {
  const double d = ctx.config.contact.distance;
  for (std::size_t k = 0; k < count; ++k) {
    if (!may_touch(mask, k)) continue;
    Eigen::Vector3d n;
    if (!(ctx.obstacles[k].signed_distance(x, n) < d)) continue;
    const double lambda = n.dot(r);
    if (lambda > 0.0) r -= lambda * n;
  }
  return r;
}

/// Reverse pass of supported_residual over all obstacles: given `bar` = dC/d(r~) and the
/// unsupported residual r, returns dC/dr and adds to `grad_x` the dependence through the
/// normals, -J_n (lambda bar_k + (bar_k . n) r_(k-1)) per applied support (J_n the SDF Hessian).
/// Stages are recomputed rather than stored (obstacle counts are small).
inline Eigen::Vector3d support_adjoint(const StepContext& ctx, const Eigen::Vector3d& x,
                                       const Eigen::Vector3d& r, Eigen::Vector3d bar,
                                       Eigen::Vector3d& grad_x,
                                       ObstacleMask mask = kEveryObstacle) {
  const double d = ctx.config.contact.distance;
  for (std::size_t k = ctx.obstacles.size(); k-- > 0;) {
    if (!may_touch(mask, k)) continue;
    Eigen::Vector3d n;
    if (!(ctx.obstacles[k].signed_distance(x, n) < d)) continue;
    const Eigen::Vector3d before = supported_residual(ctx, x, r, k, mask);
    const double lambda = n.dot(before);
    if (!(lambda > 0.0)) continue;
    const double bar_n = bar.dot(n);
    grad_x -= ctx.obstacles[k].normal_jacobian(x) * (lambda * bar + bar_n * before);
    bar -= bar_n * n;
  }
  return bar;
}

/// Non-penetration cost of a particle at x: sum over obstacles of (max(0, d - sdf) / d)^2,
/// and (if not null) its gradient -2 (d - sdf) / d^2 n.
inline double penetration_cost(const StepContext& ctx, const Eigen::Vector3d& x,
                               Eigen::Vector3d* gradient, ObstacleMask mask = kEveryObstacle) {
  const double d = ctx.config.contact.distance;
  double cost = 0.0;
  for (std::size_t k = 0; k < ctx.obstacles.size(); ++k) {
    if (!may_touch(mask, k)) continue;
    Eigen::Vector3d n;
    const double depth = d - ctx.obstacles[k].signed_distance(x, n);
    if (depth > 0.0) {
      cost += depth * depth / (d * d);
      if (gradient != nullptr) *gradient -= 2.0 * depth / (d * d) * n;
    }
  }
  return cost;
}

/// Cn |r~_j|^2 / (m_j |g|)^2 of free particle j computed from scratch with the accessors.
template <class Positions, class Tension, class Moment>
inline double newton_cost(const StepContext& ctx, const ViolationScales& scales, std::int64_t j,
                          const Positions& x, const Tension& t, const Moment& m) {
  const Eigen::Vector3d r = newton_residual(ctx, j, x, t, m);
  const Eigen::Vector3d supported = supported_residual(ctx, x(j), r, ctx.obstacles.size());
  const double inverse_weight = 1.0 / (ctx.mesh.mass[j] * ctx.gravity_reference());
  return scales.newton * supported.squaredNorm() * inverse_weight * inverse_weight;
}

/// Numeric gradient (MODEL.md 5): central differences of the local cost of x_s, i.e. the En
/// of every particle whose residual may depend on x_s, the Es / Eb of the elements that touch
/// s, and its own Ec; step numeric_step * spacing.
inline Eigen::Vector3d numeric_position_gradient(const StepContext& ctx,
                                                 const ViolationScales& scales, std::int64_t s) {
  const ClothMesh& mesh = ctx.mesh;
  const ClothState& st = ctx.state;
  // Particles whose residual may depend on x_s: s and up to two nodes each way per line.
  std::int64_t near[9];
  int count = 0;
  near[count++] = s;
  for (int d = 0; d < 2; ++d) {
    const std::int32_t n = mesh.next[element_id(s, d)], p = mesh.prev[element_id(s, d)];
    if (n >= 0) {
      near[count++] = n;
      if (mesh.next[element_id(n, d)] >= 0) near[count++] = mesh.next[element_id(n, d)];
    }
    if (p >= 0) {
      near[count++] = p;
      if (mesh.prev[element_id(p, d)] >= 0) near[count++] = mesh.prev[element_id(p, d)];
    }
  }
  auto tension = [&](std::int64_t id) { return st.edge_force[id]; };
  auto moment = [&](std::int64_t id) { return st.triple_moment[id]; };
  auto local_cost = [&](const Eigen::Vector3d& xs) {
    auto x = [&](std::int64_t k) -> Eigen::Vector3d {
      return k == s ? xs : Eigen::Vector3d(vec3(st.position, k));
    };
    double cost = scales.contact * penetration_cost(ctx, xs, nullptr);
    for (int k = 0; k < count; ++k) {
      if (ctx.is_free(near[k])) cost += newton_cost(ctx, scales, near[k], x, tension, moment);
    }
    auto add_edge = [&](std::int64_t id) {
      const double ratio = edge_violation(ctx, id, x, st.edge_force[id]).band.value /
                           scales.tension[element_direction(id)];
      cost += scales.stretch * ratio * ratio;
    };
    auto add_triple = [&](std::int64_t id) {
      const double ratio = triple_violation(ctx, id, x, st.triple_moment[id]).band.value /
                           scales.moment[element_direction(id)];
      cost += scales.bend * ratio * ratio;
    };
    for (int d = 0; d < 2; ++d) {
      const std::int64_t id = element_id(s, d);
      const std::int32_t n = mesh.next[id], p = mesh.prev[id];
      if (mesh.edge_active[id]) add_edge(id);
      if (mesh.triple_active[id]) add_triple(id);
      if (p >= 0 && mesh.edge_active[element_id(p, d)] && mesh.next[element_id(p, d)] == s) {
        add_edge(element_id(p, d));
      }
      if (p >= 0 && mesh.triple_active[element_id(p, d)] && mesh.next[element_id(p, d)] == s) {
        add_triple(element_id(p, d));
      }
      if (n >= 0 && mesh.triple_active[element_id(n, d)] && mesh.prev[element_id(n, d)] == s) {
        add_triple(element_id(n, d));
      }
    }
    return cost;
  };
  const double h = ctx.config.solver.numeric_step * scales.length;
  const Eigen::Vector3d xs = vec3(st.position, s);
  Eigen::Vector3d g;
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d plus = xs, minus = xs;
    plus[k] += h;
    minus[k] -= h;
    g[k] = (local_cost(plus) - local_cost(minus)) / (plus[k] - minus[k]);
  }
  return g;
}

/// Numeric dE/dt_e: central differences of Es_e + En of its two ends; step numeric_step * s_ref.
inline double numeric_edge_gradient(const StepContext& ctx, const ViolationScales& scales,
                                    std::int64_t id) {
  const ClothState& st = ctx.state;
  const std::int64_t ends[2] = {element_slot(id), ctx.mesh.next[id]};
  auto x = [&](std::int64_t k) { return vec3(st.position, k); };
  auto moment = [&](std::int64_t k) { return st.triple_moment[k]; };
  const double ref = scales.tension[element_direction(id)];
  auto local_cost = [&](double value) {
    auto tension = [&](std::int64_t k) { return k == id ? value : st.edge_force[k]; };
    const double ratio = edge_violation(ctx, id, x, value).band.value / ref;
    double cost = scales.stretch * ratio * ratio;
    for (const std::int64_t j : ends) {
      if (ctx.is_free(j)) cost += newton_cost(ctx, scales, j, x, tension, moment);
    }
    return cost;
  };
  const double h = ctx.config.solver.numeric_step * ref, t = st.edge_force[id];
  const double plus = t + h, minus = t - h;
  return (local_cost(plus) - local_cost(minus)) / (plus - minus);
}

/// Numeric dE/dM_t: central differences of Eb_t + En of a, c, b; step numeric_step * Mref.
inline double numeric_triple_gradient(const StepContext& ctx, const ViolationScales& scales,
                                      std::int64_t id) {
  const ClothState& st = ctx.state;
  const std::int64_t nodes[3] = {ctx.mesh.prev[id], element_slot(id), ctx.mesh.next[id]};
  auto x = [&](std::int64_t k) { return vec3(st.position, k); };
  auto tension = [&](std::int64_t k) { return st.edge_force[k]; };
  const double ref = scales.moment[element_direction(id)];
  auto local_cost = [&](double value) {
    auto moment = [&](std::int64_t k) { return k == id ? value : st.triple_moment[k]; };
    const double ratio = triple_violation(ctx, id, x, value).band.value / ref;
    double cost = scales.bend * ratio * ratio;
    for (const std::int64_t j : nodes) {
      if (ctx.is_free(j)) cost += newton_cost(ctx, scales, j, x, tension, moment);
    }
    return cost;
  };
  const double h = ctx.config.solver.numeric_step * ref, m = st.triple_moment[id];
  const double plus = m + h, minus = m - h;
  return (local_cost(plus) - local_cost(minus)) / (plus - minus);
}

}  // namespace clothbench::kernels
