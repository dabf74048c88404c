// Running and judging one stress cell (see stress_cell.hpp).
#include "harness/stress/stress_cell.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

#include "harness/run/run_summary.hpp"
#include "harness/run/verify.hpp"
#include "kernels/simulation.hpp"

namespace clothbench::harness {
namespace {

/// Kinetic energy of the active particles after a step (J): the step's displacement is
/// (x~ - x^n) / (1 - c_damp), the velocity that over dt.
double kinetic_energy(const kernels::Simulation& simulation) {
  const kernels::ClothMesh& mesh = simulation.mesh();
  const kernels::ClothState& st = simulation.state();
  const kernels::TimeConfig& time = simulation.config().time;
  const double scale = 1.0 / ((1.0 - time.damping) * time.step);
  double energy = 0.0;
  for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
    if (!(mesh.flags[s] & kernels::kParticleActive)) continue;
    const Eigen::Vector3d v =
        scale * (kernels::vec3(st.target, s) - kernels::vec3(st.step_start, s));
    energy += 0.5 * mesh.mass[s] * v.squaredNorm();
  }
  return energy;
}

/// Smallest strain of the active edges (-1 for an edge of zero length).
double min_edge_strain(const kernels::Simulation& simulation) {
  const kernels::ClothMesh& mesh = simulation.mesh();
  const std::vector<double>& x = simulation.state().position;
  double smallest = 0.0;
  for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
    if (!mesh.edge_active[id]) continue;
    const double length =
        (kernels::vec3(x, mesh.next[id]) - kernels::vec3(x, kernels::element_slot(id))).norm();
    smallest = std::min(smallest, length / mesh.edge_rest[id] - 1.0);
  }
  return smallest;
}

}  // namespace

void judge_stress_cell(StressCellResult& r) {
  r.failures.clear();
  // What every run is checked for (verify.hpp), judged on the worst figure of every step.
  StateFigures worst;
  worst.finite = !r.non_finite.has_value();
  if (r.non_finite) worst.non_finite = r.non_finite->text;
  worst.mass_error = r.mass_drift;
  worst.ghost_offset = r.max_ghost_offset;
  worst.particle_penetration = r.max_particle_penetration;
  worst.max_strain = r.max_strain;
  for (std::string& failure : judge_state(worst)) {
    // The non-finite value stopped the run at its step; the others are maxima over the run.
    r.failures.push_back(failure.starts_with("non-finite")
                             ? fmt::format("step {}: {}", r.non_finite->step, failure)
                             : std::move(failure));
  }
  // Stricter for a cell: the interpolated surface, not only the particles, stays out of the
  // contact layer's depth.
  if (!(r.max_surface_penetration < r.contact_distance)) {
    r.failures.push_back(
        fmt::format("the interpolated surface went {:.3g} m into an obstacle (contact distance "
                    "{:g} m)",
                    r.max_surface_penetration, r.contact_distance));
  }
  if (r.cost_trend.growing) {
    r.failures.push_back(fmt::format(
        "the step cost grows without bound: last-quarter mean {:.3g} vs first-quarter mean {:.3g}",
        r.cost_trend.quarter_mean[3], r.cost_trend.quarter_mean[0]));
  }
  // Growth implies leaving the bound (its floor is the bound); the bound alone also catches a
  // cost that stays far above it without growing.
  if (!r.cost_trend.growing && r.cost_trend.assessed &&
      !(r.cost_trend.quarter_mean[3] <= r.cost_bound)) {
    r.failures.push_back(fmt::format(
        "the step cost left its bound: last-quarter mean {:.3g} (RMS residual {:.3g} weights) "
        "above the step-rejection level {:.3g}: those steps were accepted only because their "
        "halvings ran out",
        r.cost_trend.quarter_mean[3], std::sqrt(r.cost_trend.quarter_mean[3]), r.cost_bound));
  }
  r.passed = r.failures.empty();
}

std::optional<StressCellResult> run_stress_cell(const StressCell& cell,
                                                schedulers::LoopDriver& driver,
                                                const std::function<bool()>& keep_going,
                                                const std::filesystem::path& snapshot_dir) {
  const auto start = std::chrono::steady_clock::now();
  const kernels::SimulationConfig& config = cell.scene.simulation;
  StressCellResult r;
  r.name = cell.name;
  r.axis = cell.axis;
  r.change = cell.change;
  r.particles_i = config.cloth.particles_i;
  r.particles_j = config.cloth.particles_j;
  r.time_step = config.time.step;
  r.contact_distance = config.contact.distance;
  r.steps_planned = cell.scene.steps;

  const RunMemoryProbe memory;  // the cell's peak includes building its simulation
  kernels::Simulation simulation(config);
  std::vector<double> cost, work, energy;
  bool abandoned = false;
  const StepObserver observe = [&](const kernels::Simulation& sim, const StepRecord& step) {
    const kernels::StateDiagnostics d = sim.diagnostics();
    r.max_strain = std::max(r.max_strain, d.max_strain);
    r.min_strain = std::min(r.min_strain, min_edge_strain(sim));
    const StateFigures f = measure_state(sim, d);  // the one verifier's figures
    r.max_particle_penetration = std::max(r.max_particle_penetration, f.particle_penetration);
    r.max_surface_penetration = std::max(r.max_surface_penetration, d.max_surface_penetration);
    r.max_ghost_offset = std::max(r.max_ghost_offset, f.ghost_offset);
    r.mass_drift = std::max(r.mass_drift, f.mass_error);
    cost.push_back(step.residual_rms * step.residual_rms);
    work.push_back(step.iterations);
    energy.push_back(kinetic_energy(sim));
    r.max_kinetic_energy = std::max(r.max_kinetic_energy, energy.back());
    r.max_step_iterations = std::max(r.max_step_iterations, step.iterations);
    if (step.stop != "converged") ++r.unconverged_steps;
    if (!keep_going()) {
      abandoned = true;
      return false;
    }
    return true;
  };
  const RunSummary summary = simulate(simulation, driver, cell.scene.steps, true, observe);
  if (abandoned) return std::nullopt;

  r.steps_completed = static_cast<int>(summary.steps.size());
  if (!summary.non_finite.empty()) {
    r.non_finite = parse_non_finite(summary.non_finite_step, summary.non_finite);
    if (!snapshot_dir.empty()) {
      r.snapshot_files =
          write_non_finite_snapshot(snapshot_dir, cell.name + "-non_finite_snapshot", summary,
                                    simulation, "clothbench stress cell " + cell.name);
    }
  }
  // An accepted step's RMS residual stays below reject_residual unless its halvings ran out:
  // below that level the cost is bounded by the kernel's step rejection.
  r.cost_bound = config.solver.reject_residual * config.solver.reject_residual;
  r.cost_trend = trend_of(cost, r.cost_bound);
  r.work_trend = trend_of(work, 0.0);
  r.kinetic_energy_trend = trend_of(energy, 0.0);
  r.method = kernels::to_string(kernels::resolved_method(config.solver));
  r.cg_iterations = summary.total_iterations;
  r.linear_iterations = summary.total_linear_iterations;
  r.evaluations = summary.total_evaluations;
  r.rejected_steps = summary.rejected_steps;
  r.amrc_checks = static_cast<int>(summary.amrc_events.size());
  for (const kernels::AmrcEvent& e : summary.amrc_events) {
    r.amrc_refined += e.refined;
    r.amrc_coarsened += e.coarsened;
  }
  r.step_seconds = summary.wall_seconds;
  r.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  r.memory = memory.finish();
  judge_stress_cell(r);
  return r;
}

}  // namespace clothbench::harness
