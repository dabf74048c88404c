// The `violation` formulation's loops (see violation_objective.hpp for the loop order).
#include "kernels/violation_objective.hpp"

#include <omp.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "kernels/potential_elements.hpp"

namespace clothbench::kernels {

ViolationObjective::ResidualSums& ViolationObjective::ResidualSums::operator+=(
    const ResidualSums& o) {
  newton += o.newton;
  contact += o.contact;
  residual_max = std::max(residual_max, o.residual_max);
  free_particles += o.free_particles;
  contact_tested += o.contact_tested;
  contact_skipped += o.contact_skipped;
  return *this;
}

ViolationObjective::CgSums& ViolationObjective::CgSums::operator+=(const CgSums& o) {
  slope += o.slope;
  grad_dot_z += o.grad_dot_z;
  grad_old_dot_z += o.grad_old_dot_z;
  return *this;
}

ViolationObjective::ViolationObjective(const StepContext& ctx)
    : ctx_(ctx), scales_(violation_scales(ctx)) {
  vs_.allocate(ctx.mesh.slot_count());
  const auto tiles = ctx.mesh.tile_count();
  for (auto* v : {&edge_value_partials_, &triple_value_partials_, &particle_dir_partials_,
                  &edge_dir_partials_, &triple_dir_partials_}) {
    v->resize(tiles);
  }
  residual_partials_.resize(tiles);
  for (auto* v : {&particle_cg_partials_, &edge_cg_partials_, &triple_cg_partials_}) {
    v->resize(tiles);
  }
}

void ViolationObjective::prepare_history(LoopRunner& /*run*/) {}

void ViolationObjective::begin_step(LoopRunner& run) {
  ClothState& st = ctx_.state;
  prepare_history(run);
  // Positions start at the inertial target; forces keep their previous values (warm start).
  run.for_each_prepared(
      ElementKind::particles, kInitialGuessBytes,
      [&](std::int64_t tile) {  // broad phase of the targets the projection starts from
        return ctx_.broad_phase() ? ctx_.tile_contacts(tile, st.target).mask : kEveryObstacle;
      },
      [&](std::int64_t s, ObstacleMask mask) {
        if (ctx_.is_free(s)) vec3(st.position, s) = initial_guess(ctx_, s, 0.5, mask);
      });
  refresh_ghosts(run, ctx_.mesh, st.position);
  refresh_preconditioner(run);
}

void ViolationObjective::element_loops(LoopRunner& run, TilePartials<ScalarSum>* edge_partials,
                                       TilePartials<ScalarSum>* triple_partials) {
  ClothState& st = ctx_.state;
  const ClothMesh& mesh = ctx_.mesh;
  auto x = [&](std::int64_t k) { return vec3(st.position, k); };
  // Per element: the term's reads (a triple's without the breakpoints) and the scratch (1 or
  // 3) and band terms (2) written.
  const LoopBytes edge_bytes{.read = kEdgeTermRead, .written = 3 * bytes::kDouble};
  const LoopBytes triple_bytes{.read = kTripleTermRead - 2 * bytes::kDouble,
                               .written = 5 * bytes::kDouble};
  run.for_each<ScalarSum>(
      ElementKind::edges, edge_partials, edge_bytes, [&](std::int64_t id, ScalarSum& acc) {
        const double t = st.edge_force[id];
        const EdgeViolation ev = edge_violation(ctx_, id, x, t);
        st.edge_scratch[id] = ev.length > 0.0 ? mesh.edge_width[id] * t / ev.length : 0.0;
        const double ref = scales_.tension[element_direction(id)];
        const double ratio = ev.band.value / ref;
        acc.value += ratio * ratio;
        const double k = scales_.stretch * 2.0 * ev.band.value / (ref * ref);
        vs_.edge_band[2 * id] = k * ev.band.d_force;
        vs_.edge_band[2 * id + 1] = k * ev.band.d_strain / mesh.edge_rest[id];
      });
  run.for_each<ScalarSum>(
      ElementKind::triples, triple_partials, triple_bytes, [&](std::int64_t id, ScalarSum& acc) {
        const double moment = st.triple_moment[id];
        const TripleViolation tv = triple_violation(ctx_, id, x, moment);
        const double wm = mesh.triple_width(id) * moment;
        double* k = &st.triple_scratch[3 * id];
        k[0] = wm * tv.angle.a;
        k[1] = wm * tv.angle.bc;
        k[2] = wm * tv.angle.c;
        const double ref = scales_.moment[element_direction(id)];
        const double ratio = tv.band.value / ref;
        acc.value += ratio * ratio;
        const double c = scales_.bend * 2.0 * tv.band.value / (ref * ref);
        vs_.triple_band[2 * id] = c * tv.band.d_force;
        vs_.triple_band[2 * id + 1] = c * tv.band.d_strain / mesh.triple_rest(id);
      });
}

Evaluation ViolationObjective::evaluate(LoopRunner& run) {
  ClothState& st = ctx_.state;
  const ClothMesh& mesh = ctx_.mesh;
  auto x = [&](std::int64_t k) { return vec3(st.position, k); };
  auto rho = [&](std::int64_t k) { return vec3(vs_.rho, k); };
  const bool numeric = ctx_.config.solver.gradient == GradientMode::numeric;
  const double dt = ctx_.dt(), g_ref = ctx_.gravity_reference();
  const Eigen::Vector3d gravity = ctx_.config.time.gravity;
  const std::size_t obstacle_count = ctx_.obstacles.size();

  // 1, 2: element coefficients and band violations.
  element_loops(run, &edge_value_partials_, &triple_value_partials_);

  // 3: residuals, supports, dE/dr and the particle's own gradient terms. The contact broad
  // phase runs at the start of each tile, on the positions this loop reads.
  const bool broad_phase = ctx_.broad_phase();
  auto prepare = [&](std::int64_t tile, ResidualSums& acc) {
    if (!broad_phase) return kEveryObstacle;
    const TileContacts c = ctx_.tile_contacts(tile, st.position);
    acc.contact_tested += c.tested;
    acc.contact_skipped += c.skipped;
    return c.mask;
  };
  // Flags, mass, x~ and the gather (x included) read; rho and g written.
  const LoopBytes residual_bytes{
      .read = bytes::kFlag + bytes::kDouble + bytes::kVector3 + kGatherElasticRead,
      .written = 2 * bytes::kVector3};
  run.for_each_prepared<ResidualSums>(
      ElementKind::particles, &residual_partials_, residual_bytes, prepare,
      [&](std::int64_t s, ResidualSums& acc, ObstacleMask mask) {
        auto r_bar = vec3(vs_.rho, s);
        auto g = vec3(st.gradient, s);
        if (!ctx_.is_free(s)) {
          r_bar.setZero();
          g.setZero();
          return;
        }
        const double m = mesh.mass[s];
        const Eigen::Vector3d xs = x(s);
        Eigen::Vector3d r = m / (dt * dt) * (xs - vec3(st.target, s)) - m * gravity +
                            gather_elastic_gradient(mesh, st, s, x);
        if (ctx_.is_forced(s)) r -= ctx_.external_force(s);  // constant: dr/dx is unchanged
        if (!broad_phase) acc.contact_tested += static_cast<std::int64_t>(obstacle_count);
        const Eigen::Vector3d supported = supported_residual(ctx_, xs, r, obstacle_count, mask);
        const double inverse_weight = 1.0 / (m * g_ref);
        const double ratio_sq = supported.squaredNorm() * inverse_weight * inverse_weight;
        acc.newton += ratio_sq;
        acc.residual_max = std::max(acc.residual_max, std::sqrt(ratio_sq));
        acc.free_particles += 1;
        Eigen::Vector3d own = Eigen::Vector3d::Zero();
        acc.contact += penetration_cost(ctx_, xs, &own, mask);
        own *= scales_.contact;
        const Eigen::Vector3d bar = support_adjoint(
            ctx_, xs, r, 2.0 * scales_.newton * inverse_weight * inverse_weight * supported, own,
            mask);
        r_bar = bar;
        g = own + m / (dt * dt) * bar;
      });

  // A ghost's residual is handed half to each parent, so its adjoint is the parents' mean.
  refresh_ghosts(run, mesh, vs_.rho);

  // 4: dE/dt and the edges' position contributions. next, the shares of x and rho, band (2),
  // width, force, inverse, direction and old gradient read; the contribution (3) and the
  // gradient written.
  const LoopBytes edge_cg_bytes{.read = bytes::kIndex + 2 * bytes::kSlotShare * bytes::kVector3 +
                                        bytes::kFloat + 6 * bytes::kDouble,
                                .written = 4 * bytes::kDouble};
  run.for_each<CgSums>(
      ElementKind::edges, &edge_cg_partials_, edge_cg_bytes, [&](std::int64_t id, CgSums& acc) {
        double gt;
        if (numeric) {
          gt = numeric_edge_gradient(ctx_, scales_, id);
        } else {
          const std::int64_t a = element_slot(id), b = mesh.next[id];
          const Eigen::Vector3d e = x(b) - x(a);
          const double l = e.norm();
          const Eigen::Vector3d q = rho(b) - rho(a);
          gt = vs_.edge_band[2 * id];
          auto position = vec3(vs_.edge_position, id);
          if (l > 0.0) {
            const Eigen::Vector3d u = e / l;
            const double w = mesh.edge_width[id];
            gt += w * u.dot(q);
            position =
                w * st.edge_force[id] / l * (q - q.dot(u) * u) + vs_.edge_band[2 * id + 1] * u;
          } else {
            position.setZero();
          }
        }
        vs_.edge_gradient[id] = gt;
        const double z = vs_.edge_inverse[id] * gt;
        acc.slope += gt * vs_.edge_direction[id];
        acc.grad_dot_z += gt * z;
        acc.grad_old_dot_z += vs_.edge_gradient_old[id] * z;
      });

  // 5: dE/dM and the triples' position contributions (Hessian of theta times rho by duals).
  // prev, next, the shares of x and rho, band (2), width, moment, inverse, direction and old
  // gradient read; the contributions (6) and the gradient written.
  const LoopBytes triple_cg_bytes{.read = 2 * bytes::kIndex +
                                          2 * bytes::kSlotShare * bytes::kVector3 + bytes::kFloat +
                                          6 * bytes::kDouble,
                                  .written = 7 * bytes::kDouble};
  run.for_each<CgSums>(
      ElementKind::triples, &triple_cg_partials_, triple_cg_bytes,
      [&](std::int64_t id, CgSums& acc) {
        double gm;
        if (numeric) {
          gm = numeric_triple_gradient(ctx_, scales_, id);
        } else {
          const std::int64_t c = element_slot(id), a = mesh.prev[id], b = mesh.next[id];
          const Eigen::Vector3d xa = x(a), xc = x(c), xb = x(b);
          const Eigen::Vector3d ra = rho(a), rc = rho(c), rb = rho(b);
          Eigen::Matrix<Dual, 3, 1> e1, e2;
          for (int k = 0; k < 3; ++k) {
            e1[k] = Dual(xc[k] - xa[k], rc[k] - ra[k]);
            e2[k] = Dual(xb[k] - xc[k], rb[k] - rc[k]);
          }
          const TurningAngle<Dual> angle = turning_angle<Dual>(e1, e2);
          Eigen::Map<Eigen::Matrix<double, 3, 2>> position(&vs_.triple_position[6 * id]);
          gm = vs_.triple_band[2 * id];
          if (angle.degenerate) {
            position.setZero();
          } else {
            Eigen::Vector3d ga, gb, ha, hb;  // grad_a theta, grad_b theta, (H rho)_a, (H rho)_b
            for (int k = 0; k < 3; ++k) {
              const Dual da = -angle.a * e1[k] + angle.bc * e2[k];
              const Dual db = -angle.bc * e1[k] + angle.c * e2[k];
              ga[k] = da.v;
              ha[k] = da.d;
              gb[k] = db.v;
              hb[k] = db.d;
            }
            const double w = mesh.triple_width(id), wm = w * st.triple_moment[id];
            const double band = vs_.triple_band[2 * id + 1];
            gm += w * (ra.dot(ga) - rc.dot(ga + gb) + rb.dot(gb));
            position.col(0) = wm * ha + band * ga;
            position.col(1) = wm * hb + band * gb;
          }
        }
        vs_.triple_gradient[id] = gm;
        const double z = vs_.triple_inverse[id] * gm;
        acc.slope += gm * vs_.triple_direction[id];
        acc.grad_dot_z += gm * z;
        acc.grad_old_dot_z += vs_.triple_gradient_old[id] * z;
      });

  // 6: gather dE/dx (own terms from loop 3 plus every incident element, fixed order). Flags
  // and g, of its slot's two ids next, prev, both flags, the edge's contribution (3) and the
  // triple's (6), then P^-1, d and g_old read; g written.
  const LoopBytes gather_bytes{
      .read = bytes::kFlag + bytes::kVector3 +
              bytes::kIdsPerSlot * (2 * bytes::kIndex + 2 * bytes::kFlag + 9 * bytes::kDouble) +
              bytes::kBlockF + 2 * bytes::kVector3,
      .written = bytes::kVector3};
  run.for_each<CgSums>(
      ElementKind::particles, &particle_cg_partials_, gather_bytes,
      [&](std::int64_t s, CgSums& acc) {
        auto g = vec3(st.gradient, s);
        if (!ctx_.is_free(s)) return;  // zeroed by loop 3
        if (numeric) {
          g = numeric_position_gradient(ctx_, scales_, s);
        } else {
          // Own terms from loop 3 plus every incident element's contribution; a ghost hanging
          // on s hands half of its incident elements' contributions on (ghost_nodes.hpp).
          auto incident = [&](std::int64_t k) {
            Eigen::Vector3d sum = Eigen::Vector3d::Zero();
            for (int d = 0; d < 2; ++d) {
              const std::int64_t id = element_id(k, d);
              const std::int32_t n = mesh.next[id], p = mesh.prev[id];
              if (mesh.edge_active[id]) sum -= vec3(vs_.edge_position, id);  // k is a
              if (p >= 0) {
                const std::int64_t ep = element_id(p, d);
                if (mesh.edge_active[ep] && mesh.next[ep] == k) sum += vec3(vs_.edge_position, ep);
                if (mesh.triple_active[ep] && mesh.next[ep] == k) {  // k is b of the triple at p
                  sum += vec3(vs_.triple_position, 2 * ep + 1);
                }
              }
              if (n >= 0) {
                const std::int64_t tn = element_id(n, d);
                if (mesh.triple_active[tn] && mesh.prev[tn] == k) {  // k is a of the triple at n
                  sum += vec3(vs_.triple_position, 2 * tn);
                }
              }
              if (mesh.triple_active[id]) {  // k is the centre: -(a + b)
                sum -= vec3(vs_.triple_position, 2 * id) + vec3(vs_.triple_position, 2 * id + 1);
              }
            }
            return sum;
          };
          const Eigen::Vector3d sum = Eigen::Vector3d(g) + with_ghost_children(mesh, s, incident);
          g = sum;
        }
        const Eigen::Vector3d gs = g;
        const Eigen::Vector3d z = apply_symmetric(st.preconditioner, s, gs);
        acc.slope += gs.dot(vec3(st.direction, s));
        acc.grad_dot_z += gs.dot(z);
        acc.grad_old_dot_z += vec3(st.gradient_old, s).dot(z);
      });

  const double stretch = run.reduce(edge_value_partials_).value;
  const double bend = run.reduce(triple_value_partials_).value;
  const ResidualSums res = run.reduce(residual_partials_);
  CgSums cg = run.reduce(particle_cg_partials_);  // fixed order: particles, edges, triples
  cg += run.reduce(edge_cg_partials_);
  cg += run.reduce(triple_cg_partials_);
  Evaluation e;
  e.value = scales_.newton * res.newton + scales_.stretch * stretch + scales_.bend * bend +
            scales_.contact * res.contact;
  e.cost = e.value;
  e.residual_sq = res.newton;
  e.residual_max = res.residual_max;
  e.free_particles = res.free_particles;
  e.slope = cg.slope;
  e.grad_dot_z = cg.grad_dot_z;
  e.grad_old_dot_z = cg.grad_old_dot_z;
  e.contact_tested = res.contact_tested;
  e.contact_skipped = res.contact_skipped;
  count_contact_work(e);
  if (omp_get_thread_num() == 0) components_ = {res.newton, stretch, bend, res.contact};
  return e;
}

Eigen::Matrix3d ViolationObjective::diagonal_block(std::int64_t s, ObstacleMask mask) const {
  const ClothMesh& mesh = ctx_.mesh;
  const ClothState& st = ctx_.state;
  auto x = [&](std::int64_t k) { return vec3(st.position, k); };
  const double dt = ctx_.dt(), g_ref = ctx_.gravity_reference();
  auto newton_weight = [&](std::int64_t j) {  // d^2 (Cn |r_j|^2/(m_j g)^2) / dr_j^2, a scalar
    if (!ctx_.is_free(j)) return 0.0;
    const double mg = mesh.mass[j] * g_ref;
    return 2.0 * scales_.newton / (mg * mg);
  };
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  // Gauss-Newton: sum_j c_j J_js^T J_js with J_ss = m/dt^2 I + the edges' geometric
  // stiffness, J_js = -K_e for edge neighbours (triple Hessians are left out), plus the band
  // and non-penetration terms' own Gauss-Newton blocks.
  Eigen::Matrix3d own = identity * (mesh.mass[s] / (dt * dt));
  Eigen::Matrix3d block = Eigen::Matrix3d::Zero();
  auto add_edge = [&](std::int64_t id, std::int64_t other) {
    const EdgeViolation ev = edge_violation(ctx_, id, x, st.edge_force[id]);
    if (!(ev.length > 0.0)) return;
    const Eigen::Matrix3d uu = ev.unit * ev.unit.transpose();
    const Eigen::Matrix3d k = mesh.edge_width[id] * st.edge_force[id] / ev.length * (identity - uu);
    own += k;
    block += newton_weight(other) * k * k;
    if (ev.band.value > 0.0) {
      const double slope =
          ev.band.d_strain / (scales_.tension[element_direction(id)] * mesh.edge_rest[id]);
      block += 2.0 * scales_.stretch * slope * slope * uu;
    }
  };
  auto add_triple = [&](std::int64_t id, int role) {  // role 0 = a, 1 = c, 2 = b
    const TripleViolation tv = triple_violation(ctx_, id, x, st.triple_moment[id]);
    if (tv.angle.degenerate || !(tv.band.value > 0.0)) return;
    const Eigen::Vector3d ga = -tv.angle.a * tv.e1 + tv.angle.bc * tv.e2;
    const Eigen::Vector3d gb = -tv.angle.bc * tv.e1 + tv.angle.c * tv.e2;
    const Eigen::Vector3d grad = role == 0 ? ga : role == 2 ? gb : Eigen::Vector3d(-(ga + gb));
    const double slope =
        tv.band.d_strain / (scales_.moment[element_direction(id)] * mesh.triple_rest(id));
    block += 2.0 * scales_.bend * slope * slope * grad * grad.transpose();
  };
  for (int d = 0; d < 2; ++d) {
    const std::int64_t id = element_id(s, d);
    const std::int32_t n = mesh.next[id], p = mesh.prev[id];
    if (mesh.edge_active[id]) add_edge(id, n);
    if (p >= 0 && mesh.edge_active[element_id(p, d)] && mesh.next[element_id(p, d)] == s) {
      add_edge(element_id(p, d), p);
    }
    if (mesh.triple_active[id]) add_triple(id, 1);
    if (n >= 0 && mesh.triple_active[element_id(n, d)] && mesh.prev[element_id(n, d)] == s) {
      add_triple(element_id(n, d), 0);
    }
    if (p >= 0 && mesh.triple_active[element_id(p, d)] && mesh.next[element_id(p, d)] == s) {
      add_triple(element_id(p, d), 2);
    }
  }
  // J_ss is left unprojected by the supports: the support switches on discontinuously at the
  // contact distance, and the projected block (nearly singular along the normal) sends
  // supported particles across that layer, where E jumps and the line search stalls
  // (measured on a 21x21 box drape: 13 of 20 steps stalled with it, none without).
  block += newton_weight(s) * own.transpose() * own;
  const double distance = ctx_.config.contact.distance;
  for (std::size_t k = 0; k < ctx_.obstacles.size(); ++k) {
    if (!may_touch(mask, k)) continue;
    Eigen::Vector3d normal;
    if (ctx_.obstacles[k].signed_distance(x(s), normal) < distance) {
      block += 2.0 * scales_.contact / (distance * distance) * normal * normal.transpose();
    }
  }
  // A floor far below every physical term keeps the block invertible when weights are zero.
  block += 1e-6 / (scales_.length * scales_.length) * identity;
  return block;
}

void ViolationObjective::refresh_preconditioner(LoopRunner& run) {
  ClothState& st = ctx_.state;
  const ClothMesh& mesh = ctx_.mesh;
  const bool block_jacobi = ctx_.config.solver.preconditioner != Preconditioner::none;
  const double h = scales_.length;
  const double g_ref = ctx_.gravity_reference();
  auto newton_weight = [&](std::int64_t j) {
    if (!ctx_.is_free(j)) return 0.0;
    const double mg = mesh.mass[j] * g_ref;
    return 2.0 * scales_.newton / (mg * mg);
  };
  // Flags, and for the block: mass, x, and of its slot's two ids next, prev, both flags,
  // force, moment, edge rest and width, triple rest read; the inverse (float) written.
  const double block_read = bytes::kDouble + bytes::kVector3 +
                            bytes::kIdsPerSlot * (2 * bytes::kIndex + 2 * bytes::kFlag +
                                                  2 * bytes::kDouble + 3 * bytes::kFloat);
  const LoopBytes block_bytes{.read = bytes::kFlag + (block_jacobi ? block_read : 0.0),
                              .written = bytes::kBlockF};
  run.for_each_prepared(
      ElementKind::particles, block_bytes,
      [&](std::int64_t tile) {
        return block_jacobi && ctx_.broad_phase() ? ctx_.tile_contacts(tile, st.position).mask
                                                  : kEveryObstacle;
      },
      [&](std::int64_t s, ObstacleMask mask) {
        Eigen::Matrix3d inverse = Eigen::Matrix3d::Zero();
        if (ctx_.is_free(s)) {
          inverse = block_jacobi ? Eigen::Matrix3d(diagonal_block(s, mask).inverse())
                                 : Eigen::Matrix3d(Eigen::Matrix3d::Identity() * (h * h));
        }
        store_symmetric(st.preconditioner, s, inverse);
      });
  // Forces: scaled by their references, or the Gauss-Newton diagonal of E (the support
  // projections are left out of the force diagonals). Per element: width, its nodes (next;
  // a triple's prev, rest, moment and positions' share too) and their weights' flags and
  // masses (a slot's share each) read; the inverse written.
  const double weights = block_jacobi ? bytes::kSlotShare * (bytes::kFlag + bytes::kDouble) : 0.0;
  const LoopBytes edge_bytes{.read = bytes::kFloat + bytes::kIndex + weights,
                             .written = bytes::kDouble};
  const LoopBytes triple_bytes{.read = 2 * bytes::kIndex + bytes::kSlotShare * bytes::kVector3 +
                                       2 * bytes::kFloat + bytes::kDouble + weights,
                               .written = bytes::kDouble};
  run.for_each(ElementKind::edges, edge_bytes, [&](std::int64_t id) {
    const double ref = scales_.tension[element_direction(id)];
    if (!block_jacobi) {
      vs_.edge_inverse[id] = ref * ref;
      return;
    }
    const double w = mesh.edge_width[id];
    const double diagonal =
        w * w * (newton_weight(element_slot(id)) + newton_weight(mesh.next[id])) +
        (2.0 * scales_.stretch + 1e-6) / (ref * ref);
    vs_.edge_inverse[id] = 1.0 / diagonal;
  });
  run.for_each(ElementKind::triples, triple_bytes, [&](std::int64_t id) {
    const double ref = scales_.moment[element_direction(id)];
    if (!block_jacobi) {
      vs_.triple_inverse[id] = ref * ref;
      return;
    }
    auto x = [&](std::int64_t k) { return vec3(st.position, k); };
    const TripleViolation tv = triple_violation(ctx_, id, x, st.triple_moment[id]);
    double diagonal = (2.0 * scales_.bend + 1e-6) / (ref * ref);
    if (!tv.angle.degenerate) {
      const Eigen::Vector3d ga = -tv.angle.a * tv.e1 + tv.angle.bc * tv.e2;
      const Eigen::Vector3d gb = -tv.angle.bc * tv.e1 + tv.angle.c * tv.e2;
      const double w = mesh.triple_width(id);
      diagonal += w * w *
                  (newton_weight(mesh.prev[id]) * ga.squaredNorm() +
                   newton_weight(element_slot(id)) * (ga + gb).squaredNorm() +
                   newton_weight(mesh.next[id]) * gb.squaredNorm());
    }
    vs_.triple_inverse[id] = 1.0 / diagonal;
  });
}

double ViolationObjective::update_direction(LoopRunner& run, double beta) {
  ClothState& st = ctx_.state;
  update_position_direction(run, st, beta, particle_dir_partials_);
  auto scalar_update = [&](std::vector<double>& gradient, std::vector<double>& old,
                           std::vector<double>& direction, const std::vector<double>& inverse,
                           std::int64_t id, ScalarSum& acc) {
    const double g = gradient[id];
    direction[id] = -inverse[id] * g + beta * direction[id];
    old[id] = g;
    acc.value += direction[id] * g;
  };
  // Gradient, direction and inverse read; direction and old gradient written.
  const LoopBytes scalar_bytes{.read = 3 * bytes::kDouble, .written = 2 * bytes::kDouble};
  run.for_each<ScalarSum>(ElementKind::edges, &edge_dir_partials_, scalar_bytes,
                          [&](std::int64_t id, ScalarSum& acc) {
                            scalar_update(vs_.edge_gradient, vs_.edge_gradient_old,
                                          vs_.edge_direction, vs_.edge_inverse, id, acc);
                          });
  run.for_each<ScalarSum>(ElementKind::triples, &triple_dir_partials_, scalar_bytes,
                          [&](std::int64_t id, ScalarSum& acc) {
                            scalar_update(vs_.triple_gradient, vs_.triple_gradient_old,
                                          vs_.triple_direction, vs_.triple_inverse, id, acc);
                          });
  return run.reduce(particle_dir_partials_).value + run.reduce(edge_dir_partials_).value +
         run.reduce(triple_dir_partials_).value;
}

void ViolationObjective::move(LoopRunner& run, double delta) {
  ClothState& st = ctx_.state;
  run.for_each(ElementKind::particles, kMoveBytes,
               [&](std::int64_t s) { vec3(st.position, s) += delta * vec3(st.direction, s); });
  refresh_ghosts(run, ctx_.mesh, st.position);
  // The force or moment and its direction read, the force or moment written.
  const LoopBytes force_bytes{.read = 2 * bytes::kDouble, .written = bytes::kDouble};
  run.for_each(ElementKind::edges, force_bytes,
               [&](std::int64_t id) { st.edge_force[id] += delta * vs_.edge_direction[id]; });
  run.for_each(ElementKind::triples, force_bytes,
               [&](std::int64_t id) { st.triple_moment[id] += delta * vs_.triple_direction[id]; });
}

void ViolationObjective::end_step(LoopRunner& run) {
  ClothState& st = ctx_.state;
  // The forces are unknowns: the accepted iterate already holds t^(n+1) and M^(n+1).
  advance_position_history(run, st, ctx_.config.time, ctx_.dt());
}

}  // namespace clothbench::kernels
