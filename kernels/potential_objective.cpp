// The `potential` formulation's loops (see potential_objective.hpp). Loop order per
// evaluation: edges, triples (write own scratch slots), particles (gather) — MODEL.md 7.
#include "kernels/potential_objective.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <stdexcept>
#include <utility>
#include <vector>

#include "kernels/potential_elements.hpp"
#include "kernels/vector_lanes_args.hpp"

namespace clothbench::kernels {

namespace {
// LoopBytes (loop_bytes.hpp) of loops written twice (scalar and vector kernels), and what the
// diagonal blocks read.
/// Energies and force densities: the edge's terms read, w t / l written.
constexpr LoopBytes kEdgeEvaluation{.read = kEdgeTermRead, .written = bytes::kDouble};
/// Energies and gradient coefficients: the triple's terms read, w M (A, Bc, C) written.
constexpr LoopBytes kTripleEvaluation{.read = kTripleTermRead, .written = 3 * bytes::kDouble};
/// What diagonal_block reads of a particle: mass, position, and of its slot's two ids what
/// edge_term and triple_term read (next once) and both element flags.
constexpr double kDiagonalBlockRead =
    bytes::kDouble + bytes::kVector3 +
    bytes::kIdsPerSlot * (kEdgeTermData + kTripleTermData - bytes::kIndex + 2 * bytes::kFlag);
}  // namespace

PotentialObjective::PotentialObjective(const StepContext& ctx)
    : ctx_(ctx),
      edge_partials_(ctx.mesh.tile_count()),
      triple_partials_(ctx.mesh.tile_count()),
      scalar_partials_(ctx.mesh.tile_count()),
      census_partials_(ctx.mesh.tile_count()),
      gather_partials_(ctx.mesh.tile_count()),
      precondition_partials_(ctx.mesh.tile_count()) {
  const Preconditioner kind = ctx.config.solver.preconditioner;
  if (kind == Preconditioner::line_solves || kind == Preconditioner::multigrid) {
    lines_ = std::make_unique<LinePreconditioner>(ctx.mesh);  // the multigrid's smoother
    if (kind == Preconditioner::line_solves) {
      line_z_.assign(3 * static_cast<std::size_t>(ctx.mesh.slot_count()), 0.0);
    }
  }
  if (ctx.config.solver.method == StepMethod::newton)
    newton_ = std::make_unique<NewtonSystem>(ctx.mesh, ctx.state);
  if (kind == Preconditioner::multigrid) {
    if (newton_ == nullptr) {
      throw std::invalid_argument(
          "the multigrid preconditioner needs method = \"newton\" (kernels::validate)");
    }
    multigrid_ = std::make_unique<MultigridPreconditioner>();
  }
  if (kind == Preconditioner::vcycle) {
    if (newton_ == nullptr) {
      throw std::invalid_argument(
          "the v-cycle preconditioner needs method = \"newton\" (kernels::validate)");
    }
    vcycle_ = std::make_unique<VcyclePreconditioner>();
    vcycle_->set_coarsest_nodes(ctx.config.solver.coarsest_nodes);
    vcycle_on_.store(ctx.config.solver.vcycle_after == 0, std::memory_order_relaxed);
  }
}

PotentialObjective::~PotentialObjective() = default;

void PotentialObjective::begin_step(LoopRunner& run) {
  ClothState& st = ctx_.state;
  prepare_history(run);
  run.for_each_prepared(
      ElementKind::particles, kInitialGuessBytes,
      [&](std::int64_t tile) {  // broad phase of the targets the projection starts from
        return ctx_.broad_phase() ? ctx_.tile_contacts(tile, st.target).mask : kEveryObstacle;
      },
      [&](std::int64_t s, ObstacleMask mask) {
        if (ctx_.is_free(s)) vec3(st.position, s) = initial_guess(ctx_, s, 1.0, mask);
      });
  refresh_ghosts(run, ctx_.mesh, st.position);
  // The colouring follows the active set (AMRC) and the pins (scripted events): it is made
  // again only when they changed.
  if (newton_ != nullptr && effective_smoothing_sweeps(ctx_.config.solver) > 0) {
    colour_for_smoothing(run);
  }
  if (newton_ != nullptr) {
    const bool from_start = vcycle_ != nullptr && ctx_.config.solver.vcycle_after == 0;
    vcycle_on_.store(from_start, std::memory_order_relaxed);
    if (from_start) {
#pragma omp master
      ++vcycle_steps_;
    }
    assemble_newton(run, /*new_step=*/true);
  } else {
    refresh_preconditioner(run);
  }
}

Eigen::Matrix3d PotentialObjective::edge_tangent(std::int64_t id, LocalTerms* terms) const {
  const ClothMesh& mesh = ctx_.mesh;
  const ClothState& st = ctx_.state;
  auto x = [&](std::int64_t k) { return vec3(st.position, k); };
  const EdgeTerm e = edge_term(ctx_, id, x, terms);
  if (e.length <= 0.0) return Eigen::Matrix3d::Zero();
  const Eigen::Vector3d u = (x(mesh.next[id]) - x(element_slot(id))) / e.length;
  const double w = mesh.edge_width[id];
  const Eigen::Matrix3d uu = u * u.transpose();
  return w * (e.slope / mesh.edge_rest[id]) * uu +
         w * std::max(e.force, 0.0) / e.length * (Eigen::Matrix3d::Identity() - uu);
}

Eigen::Matrix3d PotentialObjective::diagonal_block(std::int64_t s, ObstacleMask mask,
                                                   LocalTerms* terms) const {
  const ClothMesh& mesh = ctx_.mesh;
  const ClothState& st = ctx_.state;
  auto x = [&](std::int64_t k) { return vec3(st.position, k); };
  const double dt = ctx_.dt();
  Eigen::Matrix3d h = Eigen::Matrix3d::Identity() * (mesh.mass[s] / (dt * dt));
  auto add_triple = [&](std::int64_t id, int role) {  // role 0 = a, 1 = c, 2 = b
    const TripleTerm t = triple_term(ctx_, id, x, terms);
    if (t.angle.degenerate || t.slope <= 0.0) return;
    const std::int64_t c = element_slot(id);
    const Eigen::Vector3d e1 = x(c) - x(mesh.prev[id]), e2 = x(mesh.next[id]) - x(c);
    const Eigen::Vector3d ga = -t.angle.a * e1 + t.angle.bc * e2;
    const Eigen::Vector3d gb = -t.angle.bc * e1 + t.angle.c * e2;
    const Eigen::Vector3d grad = role == 0 ? ga : role == 2 ? gb : Eigen::Vector3d(-(ga + gb));
    h += mesh.triple_width(id) * t.slope / mesh.triple_rest(id) * grad * grad.transpose();
  };
  for (int d = 0; d < 2; ++d) {
    const std::int64_t id = element_id(s, d);
    const std::int32_t n = mesh.next[id], p = mesh.prev[id];
    if (mesh.edge_active[id]) h += edge_tangent(id, terms);
    if (p >= 0 && mesh.edge_active[element_id(p, d)] && mesh.next[element_id(p, d)] == s) {
      h += edge_tangent(element_id(p, d), terms);
    }
    if (mesh.triple_active[id]) add_triple(id, 1);
    if (n >= 0 && mesh.triple_active[element_id(n, d)] && mesh.prev[element_id(n, d)] == s) {
      add_triple(element_id(n, d), 0);
    }
    if (p >= 0 && mesh.triple_active[element_id(p, d)] && mesh.next[element_id(p, d)] == s) {
      add_triple(element_id(p, d), 2);
    }
  }
  h += contact_penalty(ctx_, s, x(s), mask).stiffness;
  return h;
}

void PotentialObjective::refresh_preconditioner(LoopRunner& run) {
  if (newton_ != nullptr) {
    assemble_newton(run);
    return;
  }
  ClothState& st = ctx_.state;
  const bool block_jacobi = ctx_.config.solver.preconditioner != Preconditioner::none;
  // Without block Jacobi the unknowns are positions in units of the finest spacing h:
  // P^-1 = h^2 I (MODEL.md 5, scaled unknowns).
  const double h = std::min(ctx_.mesh.spacing(0), ctx_.mesh.spacing(1));
  LinePreconditioner* lines = lines_.get();
  // Flags and the diagonal block's data read; the inverse (float) and the lines' block written.
  const LoopBytes block_bytes{
      .read = bytes::kFlag + (block_jacobi ? kDiagonalBlockRead : 0.0),
      .written = bytes::kBlockF + (lines != nullptr ? bytes::kBlockD : 0.0)};
  run.for_each_prepared(
      ElementKind::particles, block_bytes,
      [&](std::int64_t tile) {
        return block_jacobi && ctx_.broad_phase() ? ctx_.tile_contacts(tile, st.position).mask
                                                  : kEveryObstacle;
      },
      [&](std::int64_t s, ObstacleMask mask) {
        Eigen::Matrix3d inverse = Eigen::Matrix3d::Zero();
        if (ctx_.is_free(s)) {
          if (lines != nullptr) {
            const Eigen::Matrix3d block = diagonal_block(s, mask);
            inverse = block.inverse();
            store_symmetric(lines->diagonal_block, s, block);
          } else {
            inverse = block_jacobi ? Eigen::Matrix3d(diagonal_block(s, mask).inverse())
                                   : Eigen::Matrix3d(Eigen::Matrix3d::Identity() * (h * h));
          }
        }
        store_symmetric(st.preconditioner, s, inverse);
      });
  if (lines == nullptr) return;
  run.for_each(ElementKind::edges, LoopBytes{.read = kEdgeTermRead, .written = bytes::kBlockD},
               [&](std::int64_t id) { store_symmetric(lines->edge_block, id, edge_tangent(id)); });
  lines->factor(run, ctx_);
}

void PotentialObjective::precondition(LoopRunner& run, Evaluation& e) {
  if (lines_ == nullptr) return;
  ClothState& st = ctx_.state;
  lines_->apply(run, ctx_, st.gradient, line_z_);
  const bool history = !st.gradient_old.empty();
  run.for_each<GatherSums>(ElementKind::particles, &precondition_partials_,
                           LoopBytes{.read = 3 * bytes::kVector3},  // z, g, g_old
                           [&](std::int64_t s, GatherSums& acc) {
                             const Eigen::Vector3d z = vec3(line_z_, s);
                             acc.grad_dot_z += vec3(st.gradient, s).dot(z);
                             if (history) acc.grad_old_dot_z += vec3(st.gradient_old, s).dot(z);
                           });
  const GatherSums p = run.reduce(precondition_partials_);
  e.grad_dot_z = p.grad_dot_z;
  e.grad_old_dot_z = p.grad_old_dot_z;
}

double PotentialObjective::local_energy(std::int64_t s, const Eigen::Vector3d& xs,
                                        LocalTerms* terms) const {
  const ClothMesh& mesh = ctx_.mesh;
  const ClothState& st = ctx_.state;
  // The nodes that move with s: s itself and the ghosts hanging on it (recursively), each by
  // its interpolation weight; the energy is summed over every element touching one of them,
  // each element once.
  thread_local std::vector<std::pair<std::int64_t, double>> movers;
  thread_local std::vector<std::int64_t> edges, triples;
  movers.assign(1, {s, 1.0});
  for (std::size_t k = 0; k < movers.size(); ++k) {
    for_each_ghost_child(mesh, movers[k].first, [&](std::int64_t child) {
      for (const auto& m : movers) {
        if (m.first == child) return;
      }
      movers.emplace_back(child, ghost_weight(mesh, child, s));
    });
  }
  const Eigen::Vector3d shift = xs - vec3(st.position, s);
  auto x = [&](std::int64_t k) -> Eigen::Vector3d {
    for (const auto& [node, weight] : movers) {
      if (node == k) return k == s ? xs : Eigen::Vector3d(vec3(st.position, k) + weight * shift);
    }
    return vec3(st.position, k);
  };
  edges.clear();
  triples.clear();
  for (const auto& mover : movers) {
    for_each_element_at(
        mesh, mover.first, [&](std::int64_t id) { edges.push_back(id); },
        [&](std::int64_t id) { triples.push_back(id); });
  }
  for (auto* list : {&edges, &triples}) {
    std::sort(list->begin(), list->end());
    list->erase(std::unique(list->begin(), list->end()), list->end());
  }
  const double dt = ctx_.dt(), m = mesh.mass[s];
  double energy = 0.5 * m / (dt * dt) * (xs - vec3(st.target, s)).squaredNorm() -
                  m * ctx_.config.time.gravity.dot(xs - vec3(st.step_start, s)) +
                  contact_penalty(ctx_, s, xs).energy;
  if (ctx_.is_forced(s)) energy -= ctx_.external_force(s).dot(xs - vec3(st.step_start, s));
  for (std::int64_t id : edges) energy += edge_term(ctx_, id, x, terms).energy;
  for (std::int64_t id : triples) energy += triple_term(ctx_, id, x, terms).energy;
  return energy;
}

Eigen::Vector3d PotentialObjective::own_gradient(std::int64_t s, const Eigen::Vector3d& xs,
                                                 const ContactPenalty& contact) const {
  const ClothState& st = ctx_.state;
  const double dt = ctx_.dt(), m = ctx_.mesh.mass[s];
  return m / (dt * dt) * (xs - vec3(st.target, s)) - m * ctx_.config.time.gravity +
         contact.gradient;
}

Eigen::Vector3d PotentialObjective::numeric_gradient(std::int64_t s) const {
  const double h = ctx_.config.solver.numeric_step *
                   std::min(ctx_.mesh.spacing(0), ctx_.mesh.spacing(1));
  const Eigen::Vector3d xs = vec3(ctx_.state.position, s);
  Eigen::Vector3d g;
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d plus = xs, minus = xs;
    plus[k] += h;
    minus[k] -= h;
    g[k] = (local_energy(s, plus) - local_energy(s, minus)) / (plus[k] - minus[k]);
  }
  return g;
}

Evaluation PotentialObjective::evaluate(LoopRunner& run) {
  ClothState& st = ctx_.state;
  const ClothMesh& mesh = ctx_.mesh;
  auto x = [&](std::int64_t k) { return vec3(st.position, k); };
  const bool numeric = ctx_.config.solver.gradient == GradientMode::numeric;
  const bool history = !st.gradient_old.empty();  // nonlinear CG's g_old (none under Newton)

  if (ctx_.config.solver.kernel == ElementKernel::vector) {
    evaluate_elements_vector(run);
  } else {
    run.for_each<ScalarSum>(ElementKind::edges, &edge_partials_, kEdgeEvaluation,
                            [&](std::int64_t id, ScalarSum& acc) {
                              const EdgeTerm e = edge_term(ctx_, id, x);
                              st.edge_scratch[id] = e.force_density;
                              acc.value += e.energy;
                            });
    run.for_each<ScalarSum>(ElementKind::triples, &triple_partials_, kTripleEvaluation,
                            [&](std::int64_t id, ScalarSum& acc) {
                              const TripleTerm t = triple_term(ctx_, id, x);
                              double* k = &st.triple_scratch[3 * id];
                              k[0] = t.coefficient[0];
                              k[1] = t.coefficient[1];
                              k[2] = t.coefficient[2];
                              acc.value += t.energy;
                            });
  }
  const double dt = ctx_.dt();
  const double g_ref = ctx_.gravity_reference();
  const Eigen::Vector3d gravity = ctx_.config.time.gravity;
  // The broad phase runs at the start of each tile, on the positions this loop reads.
  const bool broad_phase = ctx_.broad_phase();
  const auto obstacles = static_cast<std::int64_t>(ctx_.obstacles.size());
  auto prepare = [&](std::int64_t tile, GatherSums& acc) {
    if (!broad_phase) return kEveryObstacle;
    const TileContacts c = ctx_.tile_contacts(tile, st.position);
    acc.contact_tested += c.tested;
    acc.contact_skipped += c.skipped;
    return c.mask;
  };
  // Flags, mass, x~, x^n, the gather (x included), P^-1, d, g_old read; g written.
  const LoopBytes gather_bytes{.read = bytes::kFlag + bytes::kDouble + 4 * bytes::kVector3 +
                                       kGatherElasticRead + bytes::kBlockF,
                               .written = bytes::kVector3};
  if (ctx_.config.solver.kernel == ElementKernel::vector && !numeric) {
    evaluate_particles_vector(run, prepare, gather_bytes);
  } else {
    run.for_each_prepared<GatherSums>(
        ElementKind::particles, &gather_partials_, gather_bytes, prepare,
        [&](std::int64_t s, GatherSums& acc, ObstacleMask mask) {
          auto g = vec3(st.gradient, s);
          if (!ctx_.is_free(s)) {
            g.setZero();
            return;
          }
          const double m = mesh.mass[s];
          const Eigen::Vector3d xs = x(s);
          const Eigen::Vector3d offset = xs - vec3(st.target, s);
          const ContactPenalty contact = contact_penalty(ctx_, s, xs, mask);
          if (!broad_phase) acc.contact_tested += obstacles;
          acc.energy += 0.5 * m / (dt * dt) * offset.squaredNorm() -
                        m * gravity.dot(xs - vec3(st.step_start, s)) + contact.energy;
          g = numeric ? numeric_gradient(s)
                      : Eigen::Vector3d(own_gradient(s, xs, contact) +
                                        gather_elastic_gradient(mesh, st, s, x));
          if (ctx_.is_forced(s)) {  // the scripted force f: -f . (x - x^n) in Phi
            const Eigen::Vector3d f = ctx_.external_force(s);
            acc.energy -= f.dot(xs - vec3(st.step_start, s));
            if (!numeric) g -= f;
          }
          const Eigen::Vector3d z = apply_symmetric(st.preconditioner, s, g);
          const double ratio = g.norm() / (m * g_ref);
          acc.residual_sq += ratio * ratio;
          acc.residual_max = std::max(acc.residual_max, ratio);
          acc.slope += g.dot(vec3(st.direction, s));
          acc.grad_dot_z += g.dot(z);
          if (history) acc.grad_old_dot_z += vec3(st.gradient_old, s).dot(z);
          acc.free_particles += 1;
        });
  }
  const double edges = run.reduce(edge_partials_).value;
  const double triples = run.reduce(triple_partials_).value;
  const GatherSums p = run.reduce(gather_partials_);
  Evaluation e;
  e.value = p.energy + edges + triples;
  e.slope = p.slope;
  e.grad_dot_z = p.grad_dot_z;
  e.grad_old_dot_z = p.grad_old_dot_z;
  e.residual_sq = p.residual_sq;
  e.residual_max = p.residual_max;
  e.cost = p.residual_sq;
  e.free_particles = p.free_particles;
  e.contact_tested = p.contact_tested;
  e.contact_skipped = p.contact_skipped;
  count_contact_work(e);
  return e;
}

void PotentialObjective::evaluate_elements_vector(LoopRunner& run) {
  ClothState& st = ctx_.state;
  const ClothMesh& mesh = ctx_.mesh;
  const vector::ElementLanesKernels& lanes = vector::element_lanes_kernels();
  const vector::EdgeLanesArgs edges = vector::edge_lanes_args(mesh, st, ctx_.material);
  const vector::TripleLanesArgs triples = vector::triple_lanes_args(mesh, st, ctx_.material);
  run.for_each_tile<ScalarSum>(
      ElementKind::edges, &edge_partials_, kEdgeEvaluation,
      [&](std::int64_t, const std::int32_t* ids, std::int64_t count, ScalarSum& acc) {
        acc.value += lanes.edges(edges, ids, count);
      });
  run.for_each_tile<ScalarSum>(
      ElementKind::triples, &triple_partials_, kTripleEvaluation,
      [&](std::int64_t, const std::int32_t* ids, std::int64_t count, ScalarSum& acc) {
        acc.value += lanes.triples(triples, ids, count);
      });
}

template <class Prepare>
void PotentialObjective::evaluate_particles_vector(LoopRunner& run, Prepare& prepare,
                                                   LoopBytes bytes) {
  ClothState& st = ctx_.state;
  const ClothMesh& mesh = ctx_.mesh;
  const vector::ElementLanesKernels& lanes = vector::element_lanes_kernels();
  const vector::ParticleLanesArgs args = vector::particle_lanes_args(
      mesh, st, ctx_.config.time.gravity, ctx_.gravity_reference(), ctx_.dt());
  auto x = [&](std::int64_t k) { return vec3(st.position, k); };
  const bool broad_phase = ctx_.broad_phase();
  const auto obstacles = static_cast<std::int64_t>(ctx_.obstacles.size());
  const bool ghosts = mesh.ghost_count() > 0;
  const bool forced = !st.external_forces.empty();
  run.for_each_tile<GatherSums>(
      ElementKind::particles, &gather_partials_, bytes,
      [&](std::int64_t tile, const std::int32_t* slots, std::int64_t count, GatherSums& acc) {
        const ObstacleMask mask = prepare(tile, acc);
        // The terms that stay scalar (ParticleLanesKernels::particles' `extra`), per position.
        thread_local std::vector<double> extra;
        const bool scalar_terms = (mask != 0 && obstacles > 0) || ghosts || forced;
        if (scalar_terms) extra.assign(4 * static_cast<std::size_t>(count), 0.0);
        for (std::int64_t q = 0; q < (scalar_terms ? count : 0); ++q) {
          const std::int64_t s = slots[q];
          if (!ctx_.is_free(s)) continue;
          Eigen::Map<Eigen::Vector3d> g(&extra[4 * q]);
          double& energy = extra[4 * q + 3];
          if (mask != 0) {
            const ContactPenalty contact = contact_penalty(ctx_, s, x(s), mask);
            g = contact.gradient;
            energy = contact.energy;
          }
          if (ctx_.is_forced(s)) {
            const Eigen::Vector3d f = ctx_.external_force(s);
            g -= f;
            energy -= f.dot(x(s) - vec3(st.step_start, s));
          }
          for_each_ghost_child(mesh, s, [&](std::int64_t child) {
            g += 0.5 * gather_elastic_gradient(mesh, st, child, x);
          });
        }
        const vector::ParticleLanesSums sums =
            lanes.particles(args, slots, scalar_terms ? extra.data() : nullptr, count);
        for (std::int64_t q = 0; q < count; ++q) acc.free_particles += ctx_.is_free(slots[q]);
        if (!broad_phase) acc.contact_tested += obstacles * acc.free_particles;
        acc.energy += sums.energy;
        acc.residual_sq += sums.residual_sq;
        acc.residual_max = std::max(acc.residual_max, sums.residual_max);
        acc.slope += sums.slope;
        acc.grad_dot_z += sums.grad_dot_z;
        acc.grad_old_dot_z += sums.grad_old_dot_z;
      });
}

double PotentialObjective::update_direction(LoopRunner& run, double beta) {
  ClothState& st = ctx_.state;
  update_position_direction(run, st, beta, scalar_partials_,
                            lines_ != nullptr ? &line_z_ : nullptr);
  return run.reduce(scalar_partials_).value;
}

void PotentialObjective::move(LoopRunner& run, double delta) {
  ClothState& st = ctx_.state;
  run.for_each(ElementKind::particles, kMoveBytes,
               [&](std::int64_t s) { vec3(st.position, s) += delta * vec3(st.direction, s); });
  refresh_ghosts(run, ctx_.mesh, st.position);
}

void PotentialObjective::prepare_history(LoopRunner& run) {
  ClothState& st = ctx_.state;
  if (tilted_plateau(ctx_.material)) {
    // Each edge's law for the step from its force and strain at the step's start: x^n's share,
    // next, the rest length and the force read; the pieces written.
    const LoopBytes plateau_bytes{
        .read = bytes::kSlotShare * bytes::kVector3 + bytes::kIndex + bytes::kFloat +
                bytes::kDouble,
        .written = kTiltedPieceDoubles * bytes::kDouble};
    run.for_each(ElementKind::edges, plateau_bytes, [&](std::int64_t id) {
      const std::int64_t a = element_slot(id), b = ctx_.mesh.next[id];
      const double previous_strain =
          (vec3(st.step_start, b) - vec3(st.step_start, a)).norm() / ctx_.mesh.edge_rest[id] -
          1.0;
      tilted_pieces(ctx_.material.tensile[element_direction(id)], st.edge_force[id],
                    previous_strain, &st.edge_plateau[kTiltedPieceDoubles * id]);
    });
  }
  // The moment read, its two breakpoints written, and under the vector kernel (whose state
  // holds triple_offloading) what the off-loading potentials take from them.
  const bool offloading = !st.triple_offloading.empty();
  const LoopBytes history_bytes{.read = bytes::kDouble,
                                .written = (offloading ? 4 : 2) * bytes::kDouble};
  run.for_each(ElementKind::triples, history_bytes, [&](std::int64_t id) {
    const BendingBand& band = ctx_.material.bending[element_direction(id)];
    bending_breakpoints(band, st.triple_moment[id], &st.triple_breakpoints[2 * id]);
    if (offloading) {
      bending_offloading(band, st.triple_moment[id], &st.triple_breakpoints[2 * id],
                         &st.triple_offloading[2 * id]);
    }
  });
}

void PotentialObjective::end_step(LoopRunner& run) {
  ClothState& st = ctx_.state;
  auto x = [&](std::int64_t k) { return vec3(st.position, k); };
  // Each element term reads only its own previous force, so it can be replaced in place.
  const LoopBytes edge_bytes{.read = kEdgeTermRead, .written = bytes::kDouble};
  run.for_each(ElementKind::edges, edge_bytes,
               [&](std::int64_t id) { st.edge_force[id] = edge_term(ctx_, id, x).force; });
  const LoopBytes triple_bytes{.read = kTripleTermRead, .written = bytes::kDouble};
  run.for_each(ElementKind::triples, triple_bytes,
               [&](std::int64_t id) { st.triple_moment[id] = triple_term(ctx_, id, x).moment; });
  advance_position_history(run, st, ctx_.config.time, ctx_.dt());
}

}  // namespace clothbench::kernels
