// The model Hessian of the potential formulation (see model_hessian.hpp).
#include "kernels/model_hessian.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "kernels/potential_elements.hpp"

namespace clothbench::kernels {

namespace {

/// The arms of triple id: unit vectors u1 = e1/|e1|, u2 = e2/|e2| and 1/|e1|, 1/|e2|, with
/// e1 = x_c - x_a, e2 = x_b - x_c. `valid` is false when an arm has zero length.
struct TripleArms {
  Eigen::Vector3d u1, u2;
  double inverse1 = 0.0, inverse2 = 0.0;
  bool valid = false;
};

template <class Positions>
TripleArms triple_arms(const ClothMesh& mesh, std::int64_t id, const Positions& x) {
  TripleArms arms;
  const Eigen::Vector3d xc = x(element_slot(id));
  const Eigen::Vector3d e1 = xc - x(mesh.prev[id]), e2 = x(mesh.next[id]) - xc;
  const double n1 = e1.norm(), n2 = e2.norm();
  if (!(n1 > 0.0) || !(n2 > 0.0)) return arms;
  arms.inverse1 = 1.0 / n1;
  arms.inverse2 = 1.0 / n2;
  arms.u1 = e1 * arms.inverse1;
  arms.u2 = e2 * arms.inverse2;
  arms.valid = true;
  return arms;
}

/// (I - u u^T) q.
inline Eigen::Vector3d project_out(const Eigen::Vector3d& u, const Eigen::Vector3d& q) {
  return q - u * u.dot(q);
}

/// K d for K = alpha u u^T + beta (I - u u^T).
inline Eigen::Vector3d edge_product(double alpha, double beta, const Eigen::Vector3d& u,
                                    const Eigen::Vector3d& d) {
  return beta * d + (alpha - beta) * u * u.dot(d);
}

}  // namespace

ModelHessian::ModelHessian(const ClothMesh& mesh) : dot_partials_(mesh.tile_count()) {
  const auto slots = static_cast<std::size_t>(mesh.slot_count());
  contact_of_.assign(slots, -1);
  tile_contact_.resize(static_cast<std::size_t>(mesh.tile_count()));
  edge_.assign(4 * slots, 0.0f);
  bending_.assign(2 * slots, 0.0f);
  bending_along_.assign(2 * slots, 0.0f);
}

void ModelHessian::assemble_elements(LoopRunner& run, const StepContext& ctx, bool new_step,
                                     bool floor_along) {
  const ClothMesh& mesh = ctx.mesh;
  ClothState& st = ctx.state;
  auto x = [&](std::int64_t k) { return vec3(st.position, k); };
  // Within a step the model also reaches along the last Newton direction p: the positions
  // x + p where the full step would have gone (ghosts at their parents' midpoints).
  const bool reach = !new_step;
  if (reach) refresh_ghosts(run, mesh, st.direction);
  auto reached = [&](std::int64_t k) -> Eigen::Vector3d {
    return vec3(st.position, k) + vec3(st.direction, k);
  };
  // Per element: the term's reads and the previous stiffness, p's share when reaching; the
  // stiffness written.
  const double reach_read = reach ? bytes::kSlotShare * bytes::kVector3 : 0.0;
  const LoopBytes edge_bytes{.read = kEdgeTermRead + bytes::kFloat + reach_read,
                             .written = 2 * bytes::kFloat};
  run.for_each(ElementKind::edges, edge_bytes, [&](std::int64_t id) {
    const EdgeTerm e = edge_term(ctx, id, x);
    const double w = mesh.edge_width[id];
    double slope = e.slope;
    if (reach) {  // the secant slope to where the last direction would take the edge
      const EdgeTerm far = edge_term(ctx, id, reached);
      const double delta = far.strain - e.strain;
      if (std::abs(delta) > kReachChange) slope = std::max(slope, (far.force - e.force) / delta);
    }
    double alpha = w * slope / mesh.edge_rest[id];
    alpha = std::max(alpha, kStiffnessMemory * edge_[2 * id]);
    edge_[2 * id] = static_cast<float>(alpha);
    edge_[2 * id + 1] =
        static_cast<float>(e.length > 0.0 ? w * std::max(e.force, 0.0) / e.length : 0.0);
  });
  const double zero_slopes[2] = {
      ctx.material.bending[0].curves(std::numeric_limits<double>::min()).upper_slope,
      ctx.material.bending[1].curves(std::numeric_limits<double>::min()).upper_slope};
  const LoopBytes triple_bytes{.read = kTripleTermRead + 2 * bytes::kFloat + reach_read,
                               .written = 2 * bytes::kFloat};
  run.for_each(ElementKind::triples, triple_bytes, [&](std::int64_t id) {
    // The band's slope on the branch the return mapping takes at the current curvature: zero
    // on the plateau (a straight triple with no previous moment lies on it). A straight triple
    // with a previous moment is on the loading branch as soon as it bends: its slope there is
    // the limit at zero curvature, B + HB / kappa0 (the return mapping itself gives 0 at 0).
    //
    // It is also at least the secant from zero curvature M / kappa, capped at that slope: the
    // energy is even in the turning angle, a concave loading curve or a plateau's constant
    // moment makes it grow like |kappa| beyond kappa0, and a direction that straightens the
    // triple meets the stiff start of the band (B + HB / kappa0) the tangent cannot see.
    //
    // Along the turning vector the floor M / kappa is kept only with `floor_along`; the
    // tangent, the reach and the memory apply to both coefficients (model_hessian.hpp).
    const TripleTerm t = triple_term(ctx, id, x);
    const double zero_slope = zero_slopes[element_direction(id)];
    double slope = t.slope;
    if (!(t.curvature > 0.0) && st.triple_moment[id] > 0.0) slope = zero_slope;
    double along = slope;
    if (t.curvature > 0.0 && t.moment > 0.0) {
      slope = std::max(slope, std::min(t.moment / t.curvature, zero_slope));
    }
    const double rest = mesh.triple_rest(id), width = mesh.triple_width(id);
    if (reach) {
      const TripleTerm far = triple_term(ctx, id, reached);
      const double delta = far.curvature - t.curvature;
      if (std::abs(delta) * rest > kReachChange) {
        const double secant = (far.moment - t.moment) / delta;
        slope = std::max(slope, secant);
        along = std::max(along, secant);
      }
    }
    double c = width * std::max(slope, 0.0) / rest;
    c = std::max(c, kStiffnessMemory * bending_[id]);
    bending_[id] = static_cast<float>(c);
    double c_along = c;
    if (!floor_along) {
      c_along =
          std::max(width * std::max(along, 0.0) / rest, kStiffnessMemory * bending_along_[id]);
      c_along = std::min(c_along, c);
    }
    bending_along_[id] = static_cast<float>(c_along);
  });
}

Eigen::Matrix3d ModelHessian::element_diagonal(const StepContext& ctx, std::int64_t s) const {
  const ClothMesh& mesh = ctx.mesh;
  const ClothState& st = ctx.state;
  auto x = [&](std::int64_t k) { return vec3(st.position, k); };
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  auto add_edge = [&](std::int64_t id) {
    const Eigen::Vector3d e = x(mesh.next[id]) - x(element_slot(id));
    const double l = e.norm();
    if (!(l > 0.0)) return;
    const Eigen::Vector3d u = e / l;
    const double alpha = edge_[2 * id], beta = edge_[2 * id + 1];
    h += beta * identity + (alpha - beta) * u * u.transpose();
  };
  // role 0 = a (previous), 1 = c (centre), 2 = b (next): J_a = P1/|e1|, J_b = P2/|e2|,
  // J_c = -(J_a + J_b); the block is c J_r^T J_r.
  auto add_triple = [&](std::int64_t id, int role) {
    const double c = bending_[id];
    if (!(c > 0.0)) return;
    const TripleArms arms = triple_arms(mesh, id, x);
    if (!arms.valid) return;
    const Eigen::Matrix3d ja = (identity - arms.u1 * arms.u1.transpose()) * arms.inverse1;
    const Eigen::Matrix3d jb = (identity - arms.u2 * arms.u2.transpose()) * arms.inverse2;
    const Eigen::Matrix3d j = role == 0 ? ja : role == 2 ? jb : Eigen::Matrix3d(-(ja + jb));
    const Eigen::Vector3d turning = arms.u2 - arms.u1;
    const double length = turning.norm();
    const Eigen::Vector3d k = length > 0.0 ? Eigen::Vector3d(turning / length) : turning;
    h += bending_block(id, j.transpose(), j, length > 0.0 ? &k : nullptr);
  };
  for (int d = 0; d < 2; ++d) {
    const std::int64_t id = element_id(s, d);
    const std::int32_t n = mesh.next[id], p = mesh.prev[id];
    if (mesh.edge_active[id]) add_edge(id);
    if (p >= 0 && mesh.edge_active[element_id(p, d)] && mesh.next[element_id(p, d)] == s) {
      add_edge(element_id(p, d));
    }
    if (mesh.triple_active[id]) add_triple(id, 1);
    if (n >= 0 && mesh.triple_active[element_id(n, d)] && mesh.prev[element_id(n, d)] == s) {
      add_triple(element_id(n, d), 0);
    }
    if (p >= 0 && mesh.triple_active[element_id(p, d)] && mesh.next[element_id(p, d)] == s) {
      add_triple(element_id(p, d), 2);
    }
  }
  return h;
}

Eigen::Matrix3d ModelHessian::edge_block(const StepContext& ctx, std::int64_t id) const {
  const ClothState& st = ctx.state;
  const Eigen::Vector3d e =
      vec3(st.position, ctx.mesh.next[id]) - vec3(st.position, element_slot(id));
  const double l = e.norm();
  if (!(l > 0.0)) return Eigen::Matrix3d::Zero();
  const Eigen::Vector3d u = e / l;
  const double alpha = edge_[2 * id], beta = edge_[2 * id + 1];
  return beta * Eigen::Matrix3d::Identity() + (alpha - beta) * u * u.transpose();
}

double ModelHessian::apply(LoopRunner& run, const StepContext& ctx, std::span<double> v,
                           std::span<double> y) {
  const ClothMesh& mesh = ctx.mesh;
  ClothState& st = ctx.state;
  auto x = [&](std::int64_t k) { return vec3(st.position, k); };
  auto value = [&](std::int64_t k) { return vec3(v, k); };
  refresh_ghosts(run, mesh, v);
  // A triple's q_t = C J v with J v = P2 (v_b - v_c)/|e2| - P1 (v_c - v_a)/|e1| and
  // C = c (I - k k^T) + c_along k k^T, computed by each of its nodes where it is needed rather
  // than stored (no work space: the inner PCG's vectors share the evaluation's scratch,
  // newton_system.hpp). The same operations in the same order give every node the same q.
  auto triple_q = [&](std::int64_t id, const TripleArms& arms) {
    const Eigen::Vector3d vc = value(element_slot(id));
    const Eigen::Vector3d jv = project_out(arms.u2, value(mesh.next[id]) - vc) * arms.inverse2 -
                               project_out(arms.u1, vc - value(mesh.prev[id])) * arms.inverse1;
    const double c = bending_[id];
    Eigen::Vector3d q = c * jv;
    const double anisotropy = bending_along_[id] - c;
    const Eigen::Vector3d turning = arms.u2 - arms.u1;
    const double length = turning.norm();
    if (anisotropy != 0.0 && length > 0.0) {
      const Eigen::Vector3d k = turning / length;
      q += anisotropy * k * k.dot(jv);
    }
    return q;
  };
  // Particles: what each node receives from its edges and triples, ghosts' shares included.
  auto node_product = [&](std::int64_t k) {
    Eigen::Vector3d out = Eigen::Vector3d::Zero();
    const Eigen::Vector3d xk = x(k), vk = value(k);
    auto edge_to = [&](std::int64_t id, std::int64_t other) {
      const Eigen::Vector3d e = x(other) - xk;
      const double l = e.norm();
      if (!(l > 0.0)) return;
      out += edge_product(edge_[2 * id], edge_[2 * id + 1], e / l, vk - value(other));
    };
    for (int d = 0; d < 2; ++d) {
      const std::int64_t id = element_id(k, d);
      const std::int32_t n = mesh.next[id], p = mesh.prev[id];
      if (n >= 0) {
        if (mesh.edge_active[id]) edge_to(id, n);
        const std::int64_t tn = element_id(n, d);  // k is the previous node of n's triple
        if (mesh.triple_active[tn] && mesh.prev[tn] == k && bending_[tn] > 0.0) {
          const TripleArms arms = triple_arms(mesh, tn, x);
          if (arms.valid) out += project_out(arms.u1, triple_q(tn, arms)) * arms.inverse1;
        }
      }
      if (p >= 0) {
        const std::int64_t ep = element_id(p, d);  // k is the next node of p's edge and triple
        if (mesh.edge_active[ep] && mesh.next[ep] == k) edge_to(ep, p);
        if (mesh.triple_active[ep] && mesh.next[ep] == k && bending_[ep] > 0.0) {
          const TripleArms arms = triple_arms(mesh, ep, x);
          if (arms.valid) out += project_out(arms.u2, triple_q(ep, arms)) * arms.inverse2;
        }
      }
      if (mesh.triple_active[id] && bending_[id] > 0.0) {
        const TripleArms arms = triple_arms(mesh, id, x);
        if (arms.valid) {
          const Eigen::Vector3d q = triple_q(id, arms);
          out -= project_out(arms.u1, q) * arms.inverse1 + project_out(arms.u2, q) * arms.inverse2;
        }
      }
    }
    return out;
  };
  // Flags, the mass and contact index, x, v and the slot's elements read (the triples' q are
  // formed from the neighbours' x and v, counted at their own slots); y written (a contact
  // block read besides for the few particles near an obstacle).
  const LoopBytes particle_bytes{.read = bytes::kFlag + bytes::kDouble + bytes::kIndex +
                                         2 * bytes::kVector3 + bytes::kIdsPerSlot * kElementRead,
                                 .written = bytes::kVector3};
  run.for_each_prepared<ScalarSum>(
      ElementKind::particles, &dot_partials_, particle_bytes,
      [&](std::int64_t tile, ScalarSum&) { return &tile_contact_[static_cast<std::size_t>(tile)]; },
      [&](std::int64_t s, ScalarSum& acc, const std::vector<double>* blocks) {
        auto out = vec3(y, s);
        if (!ctx.is_free(s)) {
          out.setZero();
          return;
        }
        const std::int32_t c = contact_of_[s];
        const Eigen::Matrix3d own = c < 0 ? particle_inertia(ctx, s) : contact_block(*blocks, c);
        out = own * value(s) + with_ghost_children(mesh, s, node_product);
        acc.value += value(s).dot(out);
      });
  return run.reduce(dot_partials_).value;
}

void ModelHessian::forget_inactive(const ClothMesh& mesh) {
  const std::int64_t ids = 2 * mesh.slot_count();
  // Reads before it writes: a page handed back (slot_pages.hpp) reads as zero without being
  // brought back.
#pragma omp parallel for schedule(static)
  for (std::int64_t id = 0; id < ids; ++id) {
    if (!mesh.edge_active[id] && (edge_[2 * id] != 0.0 || edge_[2 * id + 1] != 0.0)) {
      edge_[2 * id] = edge_[2 * id + 1] = 0.0f;
    }
    if (!mesh.triple_active[id]) {
      if (bending_[id] != 0.0f) bending_[id] = 0.0f;
      if (bending_along_[id] != 0.0f) bending_along_[id] = 0.0f;
    }
  }
  // A tile left without particles keeps no contact blocks (no slot of it reads them).
  const auto tiles = static_cast<std::int64_t>(tile_contact_.size());
#pragma omp parallel for schedule(static)
  for (std::int64_t t = 0; t < tiles; ++t) {
    std::vector<double>& blocks = tile_contact_[static_cast<std::size_t>(t)];
    if (blocks.capacity() == 0) continue;
    bool particles = false;
    for (std::int64_t s = mesh.tile_slot_begin[t]; s < mesh.tile_slot_begin[t + 1] && !particles;
         ++s) {
      particles = (mesh.flags[s] & kParticleActive) != 0;
    }
    if (!particles) std::vector<double>().swap(blocks);
  }
}

std::size_t ModelHessian::memory_bytes() const {
  std::size_t b =
      (edge_.capacity() + bending_.capacity() + bending_along_.capacity()) * sizeof(float) +
      contact_of_.capacity() * sizeof(std::int32_t) +
      tile_contact_.capacity() * sizeof(std::vector<double>);
  for (const std::vector<double>& blocks : tile_contact_) b += blocks.capacity() * sizeof(double);
  return b;
}

std::int64_t ModelHessian::contact_blocks() const {
  std::size_t values = 0;
  for (const std::vector<double>& blocks : tile_contact_) values += blocks.size();
  return static_cast<std::int64_t>(values / 6);
}

}  // namespace clothbench::kernels
