// Simulation set-up, stepping and verification figures (see simulation.hpp).
#include "kernels/simulation.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>

#include "kernels/line_preconditioner.hpp"
#include "kernels/multigrid_preconditioner.hpp"
#include "kernels/vcycle_preconditioner.hpp"
#include "kernels/newton_minimiser.hpp"
#include "kernels/newton_system.hpp"
#include "kernels/potential_objective.hpp"
#include "kernels/slot_pages.hpp"
#include "kernels/step_context.hpp"
#include "kernels/tilted_plateau.hpp"
#include "kernels/violation_objective.hpp"

namespace clothbench::kernels {

Simulation::Simulation(const SimulationConfig& config)
    : config_(config),
      material_(FabricMaterial::from_kes(config.fabric)),
      mesh_(config.cloth, material_.areal_density) {
  config_.solver = resolved_solver(config_.solver);
  for (const ObstacleConfig& o : config_.obstacles) obstacles_.emplace_back(o);
  check_events();
  state_.allocate(mesh_.slot_count(), config_.solver.method != StepMethod::newton,
                  config_.solver.kernel == ElementKernel::vector &&
                      config_.solver.formulation == Formulation::potential,
                  config_.solver.method == StepMethod::newton,
                  config_.fabric.tension_plateau_slope > 0.0 &&
                      config_.solver.formulation == Formulation::potential);
  place_initial_positions();
  if (const std::vector<ConfigProblem> problems = validate(config_); !problems.empty()) {
    throw std::invalid_argument(problems.front().key + ": " + problems.front().problem + " (" +
                                problems.front().expected + ")");
  }
  if (config_.amrc.enabled) amrc_ = std::make_unique<AdaptiveMesh>(mesh_, config_.amrc.levels);
  const StepContext ctx{mesh_, material_, obstacles_, config_, state_};
  if (config_.solver.formulation == Formulation::violation) {
    objective_ = std::make_unique<ViolationObjective>(ctx);
  } else {
    auto potential = std::make_unique<PotentialObjective>(ctx);
    if (config_.solver.method == StepMethod::newton) newton_objective_ = potential.get();
    objective_ = std::move(potential);
  }
}

Simulation::~Simulation() = default;

void Simulation::place_initial_positions() {
  const ClothConfig& c = config_.cloth;
  const Eigen::Vector3d normal = c.axis_i.cross(c.axis_j).normalized();
  std::mt19937_64 rng(c.initial_seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const double scale = 1.0 + c.initial_stretch;
  for (int i = 0; i < mesh_.size_i(); ++i) {
    for (int j = 0; j < mesh_.size_j(); ++j) {
      const std::int64_t s = mesh_.slot(i, j);
      Eigen::Vector3d x = c.origin + scale * (mesh_.rest_coordinate(0, i) * c.axis_i +
                                              mesh_.rest_coordinate(1, j) * c.axis_j);
      const double bump = unit(rng);  // drawn for every particle: independent of the layout
      if (c.initial_crumple > 0.0) x += c.initial_crumple * bump * normal;
      vec3(state_.position, s) = x;
      vec3(state_.step_start, s) = x;
      vec3(state_.target, s) = x;  // starts at rest
    }
  }
}

StepReport Simulation::step(schedulers::LoopDriver& driver, Instrumentation instrumentation,
                            LoopTimes* times, ChunkTrace* trace) {
  if (driver.space() == schedulers::IterationSpace::active && !lists_built_) rebuild_lists();
  MinimiserSettings settings;
  settings.tolerance = config_.solver.tolerance;
  settings.max_iterations = config_.solver.max_iterations;
  settings.record_values = config_.solver.record_values;
  NewtonSettings newton;
  newton.tolerance = config_.solver.tolerance;
  newton.max_newton_iterations = config_.solver.max_newton_iterations;
  newton.max_linear_iterations = config_.solver.max_linear_iterations;
  newton.record_values = config_.solver.record_values;
  newton.log_iterations = config_.solver.log_iterations;
  newton.smoothing_sweeps = effective_smoothing_sweeps(config_.solver);
  newton.model_refinements = effective_model_refinements(config_.solver);
  newton.smoothing_threshold = config_.solver.smoothing_threshold * config_.solver.tolerance;
  StepReport report;
  const double start = monotonic_seconds();
  // Scripted events are sequential state changes between steps: part of the step's time.
  if (!config_.events.empty()) report.events = apply_events(steps_done_ + 1);
  const ActiveLists* lists = lists_built_ ? &lists_ : nullptr;
  const double full_step = config_.time.step;
  // The time budget: this step's share of what is left, polled after every CG iteration.
  BudgetPoll budget{0.0, 0};
  const bool budgeted = config_.solver.time_budget > 0.0;
  if (budgeted) {
    const int steps_left = std::max(1, planned_steps_ - steps_done_);
    budget.deadline = start + std::max(0.0, config_.solver.time_budget - budget_spent_) / steps_left;
  }
  if (trace != nullptr) trace->begin_step(steps_done_ + 1);
#pragma omp parallel
  {
    LoopRunner run(driver, mesh_, lists, instrumentation, times, trace);
    double first_alpha = first_alpha_;
    MinimiserReport total;
    int sub_steps = 0, rejected = 0;
#pragma omp barrier
    // One attempt at step length dt; a rejected attempt (residual above reject_residual or not
    // finite) leaves the state as it was (end_step not called) and is redone as two half steps.
    // The velocity carried in target - step_start is rescaled to the new step length.
    bool (*poll)(void*) = budgeted ? &BudgetPoll::poll : nullptr;
    auto attempt = [&](auto& self, double dt, int level) -> void {
#pragma omp barrier
      const MinimiserReport r =
          newton_objective_ != nullptr
              ? newton_minimise_step(*newton_objective_, run, newton, dt, poll, &budget)
              : minimise_step(*objective_, run, settings, dt, first_alpha, poll, &budget);
      total.iterations += r.iterations;
      total.linear_iterations += r.linear_iterations;
      total.evaluations += r.evaluations;
      total.restarts += r.restarts;
      total.smoothed += r.smoothed;
      const int attempt = sub_steps + rejected;
      for (NewtonIterationRecord record : r.newton_log) {
        record.attempt = attempt;
        record.dt = dt;
        total.newton_log.push_back(record);
      }
      total.values.insert(total.values.end(), r.values.begin(), r.values.end());
      if (sub_steps == 0 && rejected == 0) total.initial = r.initial;
      const double rms = MinimiserReport::rms(r.final);
      const bool out_of_time = r.reason == StopReason::time_budget && std::isfinite(r.final.value);
      const bool accept = (std::isfinite(r.final.value) && rms <= config_.solver.reject_residual) ||
                          out_of_time || level >= config_.solver.max_step_halvings;
      if (accept) {
        objective_->end_step(run);
        total.final = r.final;
        total.reason = r.reason;
        ++sub_steps;
        return;
      }
      ++rejected;
      rescale_velocity(run, dt, 0.5 * dt);
      self(self, 0.5 * dt, level + 1);
      self(self, 0.5 * dt, level + 1);
      rescale_velocity(run, 0.5 * dt, dt);
    };
    attempt(attempt, full_step, 0);
#pragma omp barrier
    if (omp_get_thread_num() == 0) {
      report.minimiser = total;
      report.sub_steps = sub_steps;
      report.rejected = rejected;
      first_alpha_ = first_alpha;
    }
  }
  if (budgeted) budget_spent_ += monotonic_seconds() - start;
  report.step = ++steps_done_;
  // The AMRC check (criterion, mesh rewrite, list rebuild) belongs to the step's time: it is
  // the sequential overhead the paper's Table 2 accounts for.
  if (amrc_ && config_.amrc.check_every > 0 && steps_done_ % config_.amrc.check_every == 0) {
    report.amrc = adapt();
  }
  report.seconds = monotonic_seconds() - start;
  report.active_elements = active_elements();
  return report;
}

AmrcEvent Simulation::adapt() {
  if (!amrc_) throw std::logic_error("Simulation::adapt: AMRC is off for this scene");
  AmrcEvent event = amrc_->run_event(steps_done_, config_.amrc, mesh_, state_);
  if (event.changed()) {
    const double start = monotonic_seconds();
    lift_out_of_obstacles();
    event.update_seconds += monotonic_seconds() - start;
  }
  if (event.changed() && lists_built_) event.list_seconds = rebuild_lists();
  if (event.changed()) {
    const double start = monotonic_seconds();
    event.released_bytes = after_mesh_change();
    event.update_seconds += monotonic_seconds() - start;
  }
  return event;
}

std::size_t Simulation::after_mesh_change() {
  const std::size_t released = release_unused_pages_ ? release_unused_pages() : 0;
  objective_->mesh_changed();  // after the release: its reads of pages handed back stay free
  return released;
}

std::size_t Simulation::release_unused_pages() {
  const SlotRuns runs = unused_slot_runs(mesh_, shortest_releasable_run(kLargestReleasedSlotBytes));
  // An unused slot's mass is 0 and stays 0 when its page comes back as zeros. The lists (when
  // built) were rebuilt for this mesh already.
  return state_.release_unused(runs) + objective_->release_unused(runs) +
         release_slot_pages(mesh_.mass, 1, runs) + lists_.release_capacity_tails();
}

void Simulation::lift_out_of_obstacles() {
  // New particles start on the old, coarser interpolated surface, which cuts into a curved
  // obstacle; the penalty would kick such a particle out with thousands of weights in the
  // next step. It moves out along the normal to the contact distance (with x^n and x~: its
  // velocity is kept). Particles outside every obstacle are not touched.
  bool moved = false;
  for (std::int64_t s = 0; s < mesh_.slot_count(); ++s) {
    if ((mesh_.flags[s] & (kParticleActive | kParticlePinned)) != kParticleActive) continue;
    for (const Obstacle& o : obstacles_) {
      Eigen::Vector3d normal;
      const double phi = o.signed_distance(vec3(state_.position, s), normal);
      if (!(phi < 0.0)) continue;
      const Eigen::Vector3d shift = (config_.contact.distance - phi) * normal;
      for (auto* v : {&state_.position, &state_.step_start, &state_.target}) vec3(*v, s) += shift;
      moved = true;
    }
  }
  if (!moved) return;
  for (std::int64_t s = 0; s < mesh_.slot_count(); ++s) {  // ghosts back on their midpoints
    if (!(mesh_.flags[s] & kParticleGhost)) continue;
    for (auto* v : {&state_.position, &state_.step_start, &state_.target}) {
      vec3(*v, s) = node_value(mesh_, *v, s);
    }
  }
}

double Simulation::rebuild_lists() {
  const double start = monotonic_seconds();
  lists_.rebuild(mesh_, list_build_);
  lists_built_ = true;
  return monotonic_seconds() - start;
}

AdaptiveMesh& Simulation::begin_tree_edit() {
  if (!amrc_) throw std::logic_error("Simulation::begin_tree_edit: AMRC is off for this scene");
  amrc_->begin_change(mesh_, state_);
  return *amrc_;
}

void Simulation::end_tree_edit() {
  amrc_->finish_change(mesh_, state_);
  lift_out_of_obstacles();
  if (lists_built_) rebuild_lists();
  after_mesh_change();
}

std::vector<double> Simulation::surface_positions() const {
  std::vector<double> x = state_.position;
  if (amrc_) amrc_->interpolate_inactive(mesh_, x);
  return x;
}

void Simulation::rescale_velocity(LoopRunner& run, double from, double to) {
  // target - x^n = keep(from) v from; the step of length `to` wants keep(to) v to.
  const double factor =
      to / from * velocity_keep(config_.time, to) / velocity_keep(config_.time, from);
  const LoopBytes rescale_bytes{.read = 2 * bytes::kVector3, .written = bytes::kVector3};
  run.for_each(ElementKind::particles, rescale_bytes, [&](std::int64_t s) {  // x~, x^n; x~
    auto target = vec3(state_.target, s);
    const auto start = vec3(state_.step_start, s);
    target = start + factor * (target - start);
  });
}

Evaluation Simulation::evaluate(schedulers::LoopDriver& driver, bool refresh_history) {
  if (driver.space() == schedulers::IterationSpace::active && !lists_built_) rebuild_lists();
  Evaluation result;
#pragma omp parallel
  {
    LoopRunner run(driver, mesh_, lists_built_ ? &lists_ : nullptr, Instrumentation::off, nullptr);
    if (refresh_history) {
      refresh_ghosts(run, mesh_, state_.position);
      objective_->prepare_history(run);
    }
    const Evaluation e = objective_->evaluate(run);
    if (omp_get_thread_num() == 0) result = e;
  }
  return result;
}

std::int64_t Simulation::active_elements() const {
  std::int64_t n = 0;
  for (std::int64_t s = 0; s < mesh_.slot_count(); ++s) {
    n += (mesh_.flags[s] & kParticleActive) ? 1 : 0;
    n += mesh_.edge_active[2 * s] + mesh_.edge_active[2 * s + 1];
    n += mesh_.triple_active[2 * s] + mesh_.triple_active[2 * s + 1];
  }
  return n;
}

std::vector<std::array<std::int32_t, 4>> Simulation::surface_quads() const {
  std::vector<std::array<std::int32_t, 4>> quads;
  if (amrc_) {
    for (const TreeCell& c : amrc_->leaves()) {
      const int size = 1 << c.level, i = c.ci * size, j = c.cj * size;
      quads.push_back({mesh_.slot(i, j), mesh_.slot(i + size, j), mesh_.slot(i + size, j + size),
                       mesh_.slot(i, j + size)});
    }
    return quads;
  }
  quads.reserve(static_cast<std::size_t>(mesh_.size_i() - 1) * (mesh_.size_j() - 1));
  for (int i = 0; i + 1 < mesh_.size_i(); ++i) {
    for (int j = 0; j + 1 < mesh_.size_j(); ++j) {
      quads.push_back({mesh_.slot(i, j), mesh_.slot(i + 1, j), mesh_.slot(i + 1, j + 1),
                       mesh_.slot(i, j + 1)});
    }
  }
  return quads;
}

StateDiagnostics Simulation::diagnostics() const {
  StateDiagnostics d;
  const StepContext ctx{mesh_, material_, obstacles_, config_, const_cast<ClothState&>(state_)};
  d.total_mass = mesh_.total_mass();
  d.weight = d.total_mass * config_.time.gravity.norm();
  d.min_particle_distance = std::numeric_limits<double>::infinity();
  const Eigen::Vector3d down = config_.time.gravity.norm() > 0.0
                                   ? Eigen::Vector3d(config_.time.gravity.normalized())
                                   : Eigen::Vector3d(0.0, 0.0, -1.0);
  for (std::int64_t s = 0; s < mesh_.slot_count(); ++s) {
    if (!(mesh_.flags[s] & kParticleActive)) continue;
    ++d.active_particles;
    const Eigen::Vector3d x = vec3(state_.position, s);
    for_each_ghost_child(mesh_, s, [&](std::int64_t g) {
      d.max_ghost_offset = std::max(
          d.max_ghost_offset, (vec3(state_.position, g) - node_value(mesh_, state_.position, g)).norm());
    });
    if (!x.allFinite()) d.finite = false;
    for (const Obstacle& o : obstacles_) {
      d.min_particle_distance = std::min(d.min_particle_distance, o.signed_distance(x));
    }
    if (ctx.is_free(s)) d.contact_force -= contact_penalty(ctx, s, x).gradient;
    for (int k = 0; k < 2; ++k) {
      const std::int64_t id = element_id(s, k);
      if (mesh_.edge_active[id]) {
        ++d.active_edges;
        if (!std::isfinite(state_.edge_force[id])) d.finite = false;
        const double l = (vec3(state_.position, mesh_.next[id]) - x).norm();
        d.max_strain = std::max(d.max_strain, l / mesh_.edge_rest[id] - 1.0);
      }
      if (mesh_.triple_active[id]) {
        ++d.active_triples;
        if (!std::isfinite(state_.triple_moment[id])) d.finite = false;
      }
    }
  }
  if (obstacles_.empty()) d.min_particle_distance = 0.0;
  d.contact_support = -d.contact_force.dot(down);
  // Interpolated surface: bilinear patches sampled at corners, edge midpoints and centres.
  constexpr int kSamples = 4;
  for (const auto& q : surface_quads()) {
    const Eigen::Vector3d p00 = vec3(state_.position, q[0]), p10 = vec3(state_.position, q[1]),
                          p11 = vec3(state_.position, q[2]), p01 = vec3(state_.position, q[3]);
    for (int a = 0; a <= kSamples; ++a) {
      for (int b = 0; b <= kSamples; ++b) {
        const double u = static_cast<double>(a) / kSamples, v = static_cast<double>(b) / kSamples;
        const Eigen::Vector3d p =
            (1 - u) * (1 - v) * p00 + u * (1 - v) * p10 + u * v * p11 + (1 - u) * v * p01;
        for (const Obstacle& o : obstacles_) {
          d.max_surface_penetration = std::max(d.max_surface_penetration, -o.signed_distance(p));
        }
      }
    }
  }
  return d;
}

std::string Simulation::locate_non_finite() const {
  // Built with a stream: GCC 12 warns (-Wrestrict, a known false positive) on chains of
  // std::string concatenations here.
  std::ostringstream out;
  auto at = [&](std::int64_t s) {
    const auto [i, j] = mesh_.grid_of(s);
    out << '(' << i << ", " << j << ')';
  };
  auto value = [&](double v) {
    out << " = " << (std::isnan(v) ? "nan" : v > 0 ? "inf" : "-inf");
  };
  for (std::int64_t s = 0; s < mesh_.slot_count(); ++s) {
    if (!is_node(mesh_.flags[s])) continue;
    for (int k = 0; k < 3; ++k) {
      const double v = state_.position[3 * s + k];
      if (std::isfinite(v)) continue;
      out << ((mesh_.flags[s] & kParticleGhost) ? "position of ghost " : "position of particle ");
      at(s);
      out << " component " << "xyz"[k];
      value(v);
      return out.str();
    }
  }
  for (std::int64_t id = 0; id < 2 * mesh_.slot_count(); ++id) {
    const char direction = element_direction(id) == 0 ? 'i' : 'j';
    if (mesh_.edge_active[id] && !std::isfinite(state_.edge_force[id])) {
      out << "tension of edge ";
      at(element_slot(id));
      out << "->";
      at(mesh_.next[id]);
      out << " along " << direction;
      value(state_.edge_force[id]);
      return out.str();
    }
    if (mesh_.triple_active[id] && !std::isfinite(state_.triple_moment[id])) {
      out << "bending moment of triple centred at ";
      at(element_slot(id));
      out << " along " << direction;
      value(state_.triple_moment[id]);
      return out.str();
    }
  }
  return "";
}

std::vector<double> Simulation::contact_forces() const {
  const StepContext ctx{mesh_, material_, obstacles_, config_, const_cast<ClothState&>(state_)};
  std::vector<double> forces(static_cast<std::size_t>(mesh_.slot_count()), 0.0);
  for (std::int64_t s = 0; s < mesh_.slot_count(); ++s) {
    if (ctx.is_free(s)) forces[s] = contact_penalty(ctx, s, vec3(state_.position, s)).support;
  }
  return forces;
}

const ModelHessian* Simulation::model_hessian() const {
  return newton_objective_ == nullptr ? nullptr : newton_objective_->model_hessian();
}

Simulation::VcycleWork Simulation::vcycle_work() const {
  VcycleWork work;
  const VcyclePreconditioner* v =
      newton_objective_ == nullptr ? nullptr : newton_objective_->vcycle();
  if (v != nullptr) {
    work.factorisations = v->factorisations();
    work.structures = v->structures();
    work.sequential_seconds = v->sequential_seconds();
    work.steps = newton_objective_->vcycle_steps();
  }
  return work;
}

Simulation::MemoryParts Simulation::memory_parts() const {
  MemoryParts parts;
  parts.mesh = mesh_.flags.capacity() + mesh_.mass.capacity() * 8 +
               (mesh_.next.capacity() + mesh_.prev.capacity()) * 4 + mesh_.edge_active.capacity() +
               mesh_.triple_active.capacity() +
               (mesh_.edge_rest.capacity() + mesh_.edge_width.capacity()) * 4;
  parts.state = state_.memory_bytes();
  parts.lists = lists_.memory_bytes();
  parts.amrc = amrc_ ? amrc_->memory_bytes() : 0;
  const VcyclePreconditioner* v =
      newton_objective_ == nullptr ? nullptr : newton_objective_->vcycle();
  parts.vcycle = v == nullptr ? 0 : v->memory_bytes();
  parts.solver = objective_->memory_bytes();
  return parts;
}

std::size_t estimate_memory_bytes(const SimulationConfig& config) {
  const auto n = static_cast<std::size_t>(config.cloth.particles_i) *
                 static_cast<std::size_t>(config.cloth.particles_j);
  // Per slot: state 7 vectors x 24 B + 24 B preconditioner + 8 B contact; per element id
  // (2 per slot) 5 doubles of forces and scratch; mesh: 1 B flags, 8 B mass, per id 8 B
  // neighbours, 2 B flags, 8 B geometry (the grid map and the triples' geometry are computed,
  // ClothMesh::slot, triple_rest); lists
  // 24 B; the AMRC tree 2 B.
  const std::size_t per_slot = 7 * 24 + 24 + 8 + 2 * 5 * 8 + 1 + 8 + 2 * (8 + 2 + 8) + 24 + 2;
  const Preconditioner kind = resolved_preconditioner(config.solver);
  const std::size_t lines =
      kind == Preconditioner::line_solves || kind == Preconditioner::multigrid
          ? n * LinePreconditioner::kBytesPerSlot
          : 0;
  // The multigrid's fine matrix lives only while the coarse operator is built: its triplets
  // (per slot 2 edges of 4 blocks and 2 triples of 9, 9 entries a block, 16 B each) and the
  // compressed matrix (3 rows of 27 entries, 12 B each).
  const std::size_t multigrid =
      kind == Preconditioner::multigrid
          ? n * (MultigridPreconditioner::kBytesPerSlot + (2 * 4 + 2 * 9) * 9 * 16 + 3 * 27 * 12)
          : 0;
  const std::size_t vcycle = kind == Preconditioner::vcycle ? n * VcyclePreconditioner::kBytesPerSlot : 0;
  const std::size_t newton =
      resolved_method(config.solver) == StepMethod::newton ? n * NewtonSystem::kBytesPerSlot : 0;
  // The tilted tension plateau's pieces: 5 doubles an edge id.
  const std::size_t tilted =
      config.fabric.tension_plateau_slope > 0.0 ? n * 2 * kTiltedPieceDoubles * sizeof(double) : 0;
  return n * per_slot + lines + multigrid + vcycle + newton + tilted + (16u << 20);
}

}  // namespace clothbench::kernels
