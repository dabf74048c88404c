// Running, verifying and reporting one simulation (see run_summary.hpp).
#include "harness/run/run_summary.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include "harness/output/atomic_file.hpp"
#include "harness/run/resident_memory.hpp"

namespace clothbench::harness {

namespace {

std::string vector_text(const Eigen::Vector3d& v) {
  return fmt::format("({:.6g}, {:.6g}, {:.6g})", v.x(), v.y(), v.z());
}

/// The simulation's allocated bytes by part (kernels::Simulation::MemoryParts).
nlohmann::json parts_json(const kernels::Simulation::MemoryParts& p) {
  return {{"mesh", p.mesh}, {"state", p.state},   {"lists", p.lists},
          {"amrc", p.amrc}, {"solver", p.solver}, {"vcycle", p.vcycle}};
}

/// The numeric settings the run's minimiser used, defaults resolved (a scene that says nothing
/// about them runs the revision's defaults, which its text does not show).
nlohmann::json solver_settings_json(const kernels::SolverConfig& solver) {
  nlohmann::json out{{"tolerance", solver.tolerance},
                     {"reject_residual", solver.reject_residual},
                     {"max_step_halvings", solver.max_step_halvings}};
  if (kernels::resolved_method(solver) == kernels::StepMethod::newton) {
    out["max_newton_iterations"] = solver.max_newton_iterations;
    out["max_linear_iterations"] = solver.max_linear_iterations;
    out["smoothing_sweeps"] = kernels::effective_smoothing_sweeps(solver);
    out["model_refinements"] = kernels::effective_model_refinements(solver);
  } else {
    out["max_iterations"] = solver.max_iterations;
  }
  if (kernels::resolved_preconditioner(solver) == kernels::Preconditioner::vcycle) {
    out["coarsest_nodes"] = solver.coarsest_nodes;
    out["vcycle_after"] = solver.vcycle_after;
  }
  return out;
}

}  // namespace

std::string describe_event(const kernels::SceneEvent& e) {
  const std::string until =
      e.until_step > e.step ? fmt::format(" through step {}", e.until_step) : "";
  switch (e.kind) {
    case kernels::SceneEventKind::move_obstacle:
      if (!e.velocity.isZero(0.0)) {
        return fmt::format("move-obstacle: obstacle {} moves at {} m/s{}", e.obstacle,
                           vector_text(e.velocity), until);
      }
      return fmt::format("move-obstacle: obstacle {} moved by {} m", e.obstacle,
                         vector_text(e.displacement));
    case kernels::SceneEventKind::release_pin:
      return fmt::format("release-pin: particle ({}, {}) is free", e.particle_i, e.particle_j);
    case kernels::SceneEventKind::force:
      return fmt::format("force: {} N on particle ({}, {}){}", vector_text(e.force), e.particle_i,
                         e.particle_j, until);
  }
  return "event";
}

RunSummary simulate(kernels::Simulation& simulation, schedulers::LoopDriver& driver, int steps,
                    bool quiet, const StepObserver& observer, kernels::ChunkTrace* trace) {
  RunSummary summary;
  summary.method = kernels::to_string(simulation.config().solver.method);
  const bool newton = simulation.config().solver.method == kernels::StepMethod::newton;
  double cost_sum = 0.0;
  simulation.set_planned_steps(simulation.steps_done() + steps);  // shares a time budget
  for (int k = 0; k < steps; ++k) {
    const kernels::StepReport report =
        simulation.step(driver, kernels::Instrumentation::off, nullptr, trace);
    const kernels::MinimiserReport& m = report.minimiser;
    const ResidentMemory resident = read_resident_memory().value_or(ResidentMemory{});
    StepRecord record{report.step,          m.iterations,
                      m.linear_iterations,  m.evaluations,
                      m.final.cost,         kernels::MinimiserReport::rms(m.final),
                      m.final.residual_max, kernels::to_string(m.reason),
                      report.seconds,       report.active_elements,
                      report.sub_steps,     resident.current_bytes,
                      resident.peak_bytes,  simulation.memory_parts()};
    summary.steps.push_back(record);
    summary.wall_seconds += report.seconds;
    summary.total_iterations += m.iterations;
    summary.total_linear_iterations += m.linear_iterations;
    summary.total_evaluations += m.evaluations;
    summary.rejected_steps += report.rejected;
    cost_sum += m.final.cost / static_cast<double>(std::max<std::int64_t>(1, report.active_elements));
    if (report.amrc) {
      const kernels::AmrcEvent& e = *report.amrc;
      summary.amrc_events.push_back(e);
      summary.amrc_seconds += e.criterion_seconds + e.update_seconds + e.list_seconds;
    }
    for (const int index : report.events) {
      const kernels::SceneEvent& event = simulation.config().events[static_cast<std::size_t>(index)];
      const AppliedEvent applied{report.step, index, describe_event(event)};
      if (!quiet) fmt::print("  event before step {:4d}: {}\n", applied.step, applied.text);
      summary.events.push_back(applied);
    }
    if (!quiet) {
      fmt::print("  step {:4d}  {} {:4d}{}  evaluations {:5d}  cost {:10.4e}  residual rms {:9.3e}"
                 " max {:9.3e}  {:>7.3f} s  {}{}\n",
                 record.step, newton ? "newton" : "iterations", record.iterations,
                 newton ? fmt::format("  linear {:5d}", record.linear_iterations) : "",
                 record.evaluations, record.cost,
                 record.residual_rms, record.residual_max, record.seconds, record.stop,
                 record.sub_steps > 1 ? fmt::format(" ({} sub-steps)", record.sub_steps) : "");
      if (report.amrc) {
        const kernels::AmrcEvent& e = *report.amrc;
        fmt::print("  AMRC after step {:4d}: {} particles, {} edges, {} triples, {} ghosts "
                   "(split {}, merged {}); criterion {:.3f} ms, mesh update {:.3f} ms, "
                   "lists {:.3f} ms{}\n",
                   e.step, e.particles, e.edges, e.triples, e.ghosts, e.refined, e.coarsened,
                   1e3 * e.criterion_seconds, 1e3 * e.update_seconds, 1e3 * e.list_seconds,
                   e.released_bytes > 0
                       ? fmt::format("; unused slots' pages handed back {:.1f} MiB",
                                     static_cast<double>(e.released_bytes) / (1u << 20))
                       : "");
      }
      std::fflush(stdout);  // progress is visible when stdout is a file or a pipe
    }
    // A non-finite value stops the run where it appeared, named by step, element and term.
    std::string where = simulation.locate_non_finite();
    if (where.empty() && (!std::isfinite(m.final.value) || !std::isfinite(m.final.cost))) {
      where = "the step's cost";
    }
    if (!where.empty()) {
      summary.steps.pop_back();  // its figures are not finite: they go to no table
      summary.non_finite = where;
      summary.non_finite_step = record.step;
      summary.verification.fail(fmt::format("step {}: non-finite value: {}", record.step, where));
      fmt::print(stderr, "clothbench: step {}: non-finite value: {}; the run stops here\n",
                 record.step, where);
      break;
    }
    // A Newton iteration's figures are finite when its step was (checked just above).
    for (const kernels::NewtonIterationRecord& iteration : m.newton_log) {
      summary.newton_log.push_back({record.step, iteration});
    }
    if (observer && !observer(simulation, record)) break;
  }
  summary.average_minimised_cost =
      summary.steps.empty() ? 0.0 : cost_sum / static_cast<double>(summary.steps.size());
  summary.final_state = simulation.diagnostics();
  summary.simulation_parts = simulation.memory_parts();
  summary.contact_work = simulation.contact_work();
  summary.vcycle = simulation.vcycle_work();
  // The one verifier (verify.hpp) judges the final state; a non-finite value that stopped
  // the run is already named above, with its step.
  Verification final_check;
  summary.mass_error = verify_state(simulation, simulation.steps_done(), final_check).mass_error;
  for (std::string& failure : final_check.failures) {
    if (summary.non_finite.empty() || failure.find("non-finite") == std::string::npos) {
      summary.verification.fail(std::move(failure));
    }
  }
  return summary;
}

std::string newton_log_csv(const std::vector<NewtonLogRow>& rows) {
  std::string out =
      "step,attempt,dt_s,iteration,rms,forcing,linear_iterations,linear_relative_residual,"
      "refinements,alpha,line_search_evaluations,rms_after_line_search,smoothed_particles,"
      "rms_after,edges_slack,edges_loading,edges_plateau,edges_unloading,edges_changed\n";
  for (const NewtonLogRow& row : rows) {
    const kernels::NewtonIterationRecord& r = row.iteration;
    out += fmt::format("{},{},{:.9g},{},{:.9g},{:.9g},{},{:.9g},{},{:.9g},{},{:.9g},{},{:.9g},",
                       row.step, r.attempt, r.dt, r.iteration, r.rms, r.forcing,
                       r.linear_iterations, r.linear_relative_residual, r.refinements, r.alpha,
                       r.line_search_evaluations, r.rms_line_search, r.smoothed, r.rms_after);
    out += fmt::format("{},{},{},{},{}\n", r.edges_slack, r.edges_loading, r.edges_plateau,
                       r.edges_unloading, r.edges_changed);
  }
  return out;
}

void print_summary(const RunSummary& s) {
  const kernels::StateDiagnostics& d = s.final_state;
  fmt::print("Summary\n");
  fmt::print("  steps                    {}\n", s.steps.size());
  if (s.method == kernels::to_string(kernels::StepMethod::newton)) {
    fmt::print("  Newton iterations        {} ({} linear PCG iterations, {} evaluations)\n",
               s.total_iterations, s.total_linear_iterations, s.total_evaluations);
  } else {
    fmt::print("  CG iterations            {} ({} evaluations)\n", s.total_iterations,
               s.total_evaluations);
  }
  fmt::print("  rejected steps           {} (redone as shorter sub-steps)\n", s.rejected_steps);
  fmt::print("  average minimised cost   {:.6e} (final E per active element, mean over steps)\n",
             s.average_minimised_cost);
  fmt::print("  contact force / weight   {:.6f} ({:.6g} N of {:.6g} N)\n",
             d.weight > 0 ? d.contact_support / d.weight : 0.0, d.contact_support, d.weight);
  fmt::print("  min particle distance    {:.3e} m (to the nearest obstacle)\n",
             d.min_particle_distance);
  fmt::print("  max surface penetration  {:.3e} m (interpolated surface)\n",
             d.max_surface_penetration);
  fmt::print("  max strain               {:.4f}\n", d.max_strain);
  const kernels::ContactWork& w = s.contact_work;
  if (w.tested + w.skipped > 0) {
    fmt::print("  contact narrow phase     {} particle-obstacle tests in {} evaluations ({:.1f} % "
               "ruled out by the broad phase)\n",
               w.tested, w.evaluations,
               100.0 * static_cast<double>(w.skipped) / static_cast<double>(w.tested + w.skipped));
  }
  if (!s.events.empty()) fmt::print("  scripted events          {} applied\n", s.events.size());
  fmt::print("  mass error               {:.3e} (relative)\n", s.mass_error);
  if (!s.amrc_events.empty()) {
    const kernels::AmrcEvent& last = s.amrc_events.back();
    fmt::print("  AMRC                     {} checks, {} active particles at the end; {:.3f} s "
               "({:.3f} % of the run) in criterion + mesh update + list rebuild\n",
               s.amrc_events.size(), last.particles, s.amrc_seconds,
               s.wall_seconds > 0 ? 100.0 * s.amrc_seconds / s.wall_seconds : 0.0);
  }
  if (s.vcycle.factorisations > 0) {
    fmt::print(
        "  V-cycle set-up           {} factorisations, {} structures in {} (sub-)steps; "
        "{:.3f} s ({:.3f} % of the run) on one thread\n",
        s.vcycle.factorisations, s.vcycle.structures, s.vcycle.steps, s.vcycle.sequential_seconds,
        s.wall_seconds > 0 ? 100.0 * s.vcycle.sequential_seconds / s.wall_seconds : 0.0);
  }
  fmt::print("  memory                   {:.1f} MiB simulation, {:.1f} MiB peak resident\n",
             static_cast<double>(s.simulation_parts.total()) / (1 << 20),
             static_cast<double>(s.peak_resident_bytes) / (1 << 20));
  fmt::print("  wall time                {:.3f} s ({} threads{})\n", s.wall_seconds, s.threads,
             s.oversubscribed ? ", oversubscribed" : "");
  const Disturbance& disturbance = s.disturbance;
  fmt::print("  timing                   {} (CPU {:.0f} % of wall x {} cores, {} involuntary "
             "context switches, load {:.2f} -> {:.2f}, OMP_WAIT_POLICY {})\n",
             disturbance.disturbed ? "DISTURBED" : "undisturbed", 100.0 * disturbance.cpu_share,
             disturbance.usable_cores, disturbance.involuntary_switches, disturbance.load_before,
             disturbance.load_after, disturbance.wait_policy);
  for (const std::string& r : disturbance.reasons) fmt::print("  disturbed: {}\n", r);
  for (const std::string& f : s.verification.failures) fmt::print("  check failed: {}\n", f);
  fmt::print("Verification: {}\n", s.verification.passed ? "PASSED" : "FAILED");
}

nlohmann::json summary_json(const RunSummary& s, const Scene& scene, const std::string& scheduler) {
  auto known = [](std::uint64_t bytes) {
    return bytes > 0 ? nlohmann::json(bytes) : nlohmann::json();
  };
  nlohmann::json steps = nlohmann::json::array();
  for (const StepRecord& r : s.steps) {
    steps.push_back({{"step", r.step},
                     {"iterations", r.iterations},
                     {"linear_iterations", r.linear_iterations},
                     {"evaluations", r.evaluations},
                     {"cost", r.cost},
                     {"residual_rms", r.residual_rms},
                     {"residual_max", r.residual_max},
                     {"stop", r.stop},
                     {"seconds", r.seconds},
                     {"active_elements", r.active_elements},
                     {"sub_steps", r.sub_steps},
                     {"resident_bytes", known(r.resident_bytes)},
                     {"peak_resident_bytes", known(r.peak_resident_bytes)},
                     {"simulation_bytes", r.simulation_parts.total()},
                     {"simulation_bytes_by_part", parts_json(r.simulation_parts)}});
  }
  const kernels::StateDiagnostics& d = s.final_state;
  // After a non-finite value the state's figures are null (the failure says where it began).
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  nlohmann::json doc = {
      {"schema", "clothbench.run"},
      {"schema_version", 1},
      {"scene",
       {{"name", scene.name},
        {"file", scene.file.string()},
        {"hash", scene.source_sha256_or_fnv},
        {"source", scene.source_text}}},
      {"scheduler", scheduler},
      {"threads", s.threads},
      {"oversubscribed", s.oversubscribed},
      {"wall_seconds", s.wall_seconds},
      {"disturbance", disturbance_json(s.disturbance)},
      {"average_minimised_cost", num(s.average_minimised_cost)},
      {"solver",
       {{"formulation", kernels::to_string(scene.simulation.solver.formulation)},
        {"gradient", kernels::to_string(scene.simulation.solver.gradient)},
        {"method", s.method},
        {"kernel", kernels::to_string(scene.simulation.solver.kernel)},
        {"preconditioner",
         kernels::to_string(kernels::resolved_preconditioner(scene.simulation.solver))},
        {"settings", solver_settings_json(scene.simulation.solver)}}},
      // Model variants a scene opted into (0: MODEL.md's own law).
      {"model", {{"tension_plateau_slope", scene.simulation.fabric.tension_plateau_slope}}},
      {"cg_iterations", s.total_iterations},
      {"linear_iterations", s.total_linear_iterations},
      {"evaluations", s.total_evaluations},
      {"rejected_steps", s.rejected_steps},
      {"contact_support_n", num(d.contact_support)},
      {"weight_n", num(d.weight)},
      {"min_particle_distance_m", num(d.min_particle_distance)},
      {"max_surface_penetration_m", num(d.max_surface_penetration)},
      {"max_strain", num(d.max_strain)},
      {"mass_error", num(s.mass_error)},
      {"active",
       {{"particles", d.active_particles},
        {"edges", d.active_edges},
        {"triples", d.active_triples}}},
      {"memory",
       {{"simulation_bytes", s.simulation_parts.total()},
        {"simulation_bytes_by_part", parts_json(s.simulation_parts)},
        {"peak_resident_bytes", s.peak_resident_bytes}}},
      {"verification", {{"passed", s.verification.passed}, {"failures", s.verification.failures}}},
      {"steps", steps}};
  if (!s.events.empty()) {
    nlohmann::json events = nlohmann::json::array();
    for (const AppliedEvent& e : s.events) {
      events.push_back({{"step", e.step}, {"index", e.index}, {"text", e.text}});
    }
    doc["events"] = events;
  }
  doc["contact_work"] = {{"tested", s.contact_work.tested},
                         {"skipped", s.contact_work.skipped},
                         {"evaluations", s.contact_work.evaluations}};
  if (s.vcycle.factorisations > 0) {
    doc["vcycle_setup"] = {
        {"factorisations", s.vcycle.factorisations},
        {"structures", s.vcycle.structures},
        {"steps", s.vcycle.steps},
        {"sequential_seconds", s.vcycle.sequential_seconds},
        {"share_of_wall", s.wall_seconds > 0 ? s.vcycle.sequential_seconds / s.wall_seconds : 0.0}};
  }
  if (!s.non_finite.empty()) doc["non_finite"] = {{"step", s.non_finite_step}, {"where", s.non_finite}};
  if (scene.simulation.amrc.enabled) {
    nlohmann::json events = nlohmann::json::array();
    for (const kernels::AmrcEvent& e : s.amrc_events) {
      events.push_back({{"step", e.step},
                        {"particles", e.particles},
                        {"edges", e.edges},
                        {"triples", e.triples},
                        {"ghosts", e.ghosts},
                        {"refined", e.refined},
                        {"coarsened", e.coarsened},
                        {"criterion_seconds", e.criterion_seconds},
                        {"update_seconds", e.update_seconds},
                        {"list_seconds", e.list_seconds},
                        {"released_bytes", e.released_bytes}});
    }
    doc["amrc"] = {{"levels", scene.simulation.amrc.levels},
                   {"check_every", scene.simulation.amrc.check_every},
                   {"refine_threshold", scene.simulation.amrc.refine_threshold},
                   {"coarsen_threshold", scene.simulation.amrc.coarsen_threshold},
                   {"seconds", s.amrc_seconds},
                   {"share_of_wall", s.wall_seconds > 0 ? s.amrc_seconds / s.wall_seconds : 0.0},
                   {"events", events}};
  }
  // A NaN must never reach a result file: JSON would silently write null for it.
  auto check = [](const nlohmann::json& j, const auto& self, const std::string& path) -> void {
    if (j.is_number_float() && !std::isfinite(j.get<double>())) {
      throw std::runtime_error("non-finite value in result field " + path);
    }
    if (j.is_object()) {
      for (auto it = j.begin(); it != j.end(); ++it) self(it.value(), self, path + "." + it.key());
    } else if (j.is_array()) {
      for (std::size_t i = 0; i < j.size(); ++i) self(j[i], self, path + "[" + std::to_string(i) + "]");
    }
  };
  check(doc, check, "run");
  return doc;
}

nlohmann::json non_finite_snapshot(const RunSummary& summary, const kernels::Simulation& simulation) {
  const kernels::ClothState& st = simulation.state();
  auto finite_or_null = [](const std::vector<double>& values) {
    nlohmann::json out = nlohmann::json::array();
    for (double v : values) out.push_back(std::isfinite(v) ? nlohmann::json(v) : nlohmann::json());
    return out;
  };
  return {{"schema", "clothbench.non_finite_snapshot"},
          {"schema_version", 1},
          {"step", summary.non_finite_step},
          {"where", summary.non_finite},
          {"particles", {simulation.mesh().size_i(), simulation.mesh().size_j()}},
          {"position_m", finite_or_null(st.position)},
          {"edge_force_n_per_m", finite_or_null(st.edge_force)},
          {"triple_moment_n", finite_or_null(st.triple_moment)},
          {"note", "slot-ordered arrays (3 per slot, 2 per slot); null marks a non-finite value"}};
}

namespace {

/// 1 for a pinned slot, 0 otherwise: the `pinned` field of both surfaces.
std::vector<double> pinned_field(const kernels::ClothMesh& mesh) {
  std::vector<double> pinned(static_cast<std::size_t>(mesh.slot_count()));
  for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
    pinned[static_cast<std::size_t>(s)] = (mesh.flags[s] & kernels::kParticlePinned) ? 1.0 : 0.0;
  }
  return pinned;
}

}  // namespace

SurfaceMesh non_finite_surface(const kernels::Simulation& simulation) {
  const kernels::ClothMesh& mesh = simulation.mesh();
  const kernels::ClothState& st = simulation.state();
  const auto slots = static_cast<std::size_t>(mesh.slot_count());
  SurfaceMesh out;
  out.points.reserve(slots);
  std::vector<double> flag(slots, 0.0);
  std::array<std::vector<double>, 2> edge_force, triple_moment;
  for (int d = 0; d < 2; ++d) {
    edge_force[d].assign(slots, 0.0);
    triple_moment[d].assign(slots, 0.0);
  }
  for (std::size_t s = 0; s < slots; ++s) {
    Eigen::Vector3d p = kernels::vec3(st.position, static_cast<std::int64_t>(s));
    int bits = 0;
    if (!p.allFinite()) {
      bits |= 1;
      for (int k = 0; k < 3; ++k) p[k] = std::isfinite(p[k]) ? p[k] : 0.0;
    }
    out.points.push_back(p);
    for (int d = 0; d < 2; ++d) {
      const auto id =
          static_cast<std::size_t>(kernels::element_id(static_cast<std::int64_t>(s), d));
      const double t = st.edge_force[id], m = st.triple_moment[id];
      if (std::isfinite(t)) edge_force[d][s] = t; else bits |= 2;
      if (std::isfinite(m)) triple_moment[d][s] = m; else bits |= 4;
    }
    flag[s] = bits;
  }
  out.quads = simulation.surface_quads();
  out.point_scalars.emplace_back("non_finite", std::move(flag));
  out.point_scalars.emplace_back("pinned", pinned_field(mesh));
  out.point_scalars.emplace_back("edge_force_i_N_per_m", std::move(edge_force[0]));
  out.point_scalars.emplace_back("edge_force_j_N_per_m", std::move(edge_force[1]));
  out.point_scalars.emplace_back("triple_moment_i_N", std::move(triple_moment[0]));
  out.point_scalars.emplace_back("triple_moment_j_N", std::move(triple_moment[1]));
  return out;
}

std::vector<std::filesystem::path> write_non_finite_snapshot(const std::filesystem::path& dir,
                                                             const std::string& stem,
                                                             const RunSummary& summary,
                                                             const kernels::Simulation& simulation,
                                                             std::string_view title) {
  const std::filesystem::path json_file = dir / (stem + ".json");
  const std::filesystem::path vtk_file = dir / (stem + ".vtk");
  write_file_atomically(json_file, non_finite_snapshot(summary, simulation).dump() + "\n");
  write_vtk(vtk_file, non_finite_surface(simulation),
            fmt::format("{}: state at step {} ({})", title, summary.non_finite_step,
                        summary.non_finite));
  return {json_file, vtk_file};
}

SurfaceMesh surface_mesh(const kernels::Simulation& simulation) {
  const kernels::ClothMesh& mesh = simulation.mesh();
  const std::vector<double> positions = simulation.surface_positions();
  SurfaceMesh out;
  out.points.reserve(static_cast<std::size_t>(mesh.slot_count()));
  std::vector<double> contact = simulation.contact_forces();
  for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
    out.points.emplace_back(kernels::vec3(positions, s));
  }
  out.quads = simulation.surface_quads();
  out.point_scalars.emplace_back("contact_force_N", std::move(contact));
  out.point_scalars.emplace_back("pinned", pinned_field(mesh));
  if (const kernels::AdaptiveMesh* tree = simulation.adaptive_mesh()) {
    // Level of each point: the finest leaf it touches (0 = finest mesh).
    std::vector<double> level(static_cast<std::size_t>(mesh.slot_count()), 0.0);
    for (int i = 0; i < mesh.size_i(); ++i) {
      for (int j = 0; j < mesh.size_j(); ++j) {
        int finest = tree->levels();
        for (int fi = std::max(0, i - 1); fi <= std::min(i, tree->cells_i() - 1); ++fi) {
          for (int fj = std::max(0, j - 1); fj <= std::min(j, tree->cells_j() - 1); ++fj) {
            finest = std::min(finest, tree->leaf_level(fi, fj));
          }
        }
        level[static_cast<std::size_t>(mesh.slot(i, j))] = finest;
      }
    }
    out.point_scalars.emplace_back("mesh_level", std::move(level));
  }
  return out;
}

std::string solver_name(const std::string& method) {
  if (method.empty()) return "";
  return method == kernels::to_string(kernels::StepMethod::newton) ? "Newton" : "CG";
}

std::string solver_iterations(const RunSummary& summary) {
  const std::string name = solver_name(summary.method);
  if (name == "Newton") {
    return fmt::format("Newton {} (PCG {})", summary.total_iterations,
                       summary.total_linear_iterations);
  }
  return name.empty() ? std::to_string(summary.total_iterations)
                      : fmt::format("{} {}", name, summary.total_iterations);
}

}  // namespace clothbench::harness
