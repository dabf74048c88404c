// One cell of `clothbench stress`: simulated step by step with the state checked after every
// step, its figures (first non-finite value, maxima over the run, trends, mass drift, solver work)
// and its verdict.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "harness/run/resident_memory.hpp"
#include "harness/run/verify.hpp"
#include "harness/stress/stress_matrix.hpp"
#include "harness/stress/stress_metrics.hpp"
#include "schedulers/loop_driver.hpp"

namespace clothbench::harness {

/// What one cell measured (SI units). Maxima run over every completed step.
struct StressCellResult {
  std::string name, axis, change;
  int particles_i = 0, particles_j = 0;
  double time_step = 0.0;         ///< s
  double contact_distance = 0.0;  ///< m, the bound of both penetrations
  int steps_planned = 0;
  int steps_completed = 0;                   ///< steps with a finite state
  std::optional<NonFiniteValue> non_finite;  ///< where the run stopped, if it did
  double max_strain = 0.0;
  /// Smallest edge strain over the run (-1: an edge of zero length, two particles together).
  double min_strain = 0.0;
  double max_particle_penetration = 0.0;  ///< m, deepest active particle inside an obstacle
  double max_surface_penetration = 0.0;   ///< m, deepest point of the interpolated surface
  double max_ghost_offset = 0.0;          ///< m, a crack between mesh levels if > 0
  double mass_drift = 0.0;  ///< max over steps of |total mass - density W H| / (density W H)
  /// Per step: the final RMS residual squared (cost / free particles, in weights squared).
  /// Its floor is cost_bound: below it the cost is bounded by the kernel's step rejection.
  Trend cost_trend;
  /// [solver] reject_residual squared: the kernel rejects (and redoes as two half steps) any
  /// step above it until its halvings run out; a step above it was accepted only then.
  double cost_bound = 0.0;
  Trend work_trend;                 ///< solver iterations per step (reported, not judged)
  Trend kinetic_energy_trend;       ///< J, after each step (reported, not judged)
  double max_kinetic_energy = 0.0;  ///< J
  std::string method;               ///< the step minimiser that ran: nonlinear-cg or newton
  std::int64_t cg_iterations = 0;   ///< its iterations (nonlinear CG, or Newton's outer ones)
  std::int64_t linear_iterations = 0;  ///< Newton's inner PCG iterations (0 under CG)
  std::int64_t evaluations = 0;
  int max_step_iterations = 0;      ///< most solver iterations of one step (sub-steps summed)
  std::int64_t rejected_steps = 0;  ///< attempts redone as two half steps
  int unconverged_steps = 0;        ///< steps accepted without reaching the tolerance
  int amrc_checks = 0;
  std::int64_t amrc_refined = 0, amrc_coarsened = 0;
  double step_seconds = 0.0;  ///< the kernel's step time (AMRC included)
  double wall_seconds = 0.0;  ///< the whole cell, per-step checks included
  /// Resident memory from the cell's set-up to its last step: its own peak, as the cells run
  /// one after another in one process (resident_memory.hpp).
  RunMemory memory;
  bool passed = false;
  std::vector<std::string> failures;  ///< one line per failed criterion
  /// The diagnostic snapshot written when the state stopped being finite (JSON and VTK files;
  /// empty when it stayed finite or no snapshot directory was given).
  std::vector<std::filesystem::path> snapshot_files;
};

/// Simulates `cell` with `driver` on the current OpenMP thread count, checking the state after
/// every step. `keep_going` is asked after every step; when it returns false the cell is
/// abandoned and nullopt returned. A cell passes when every step's state passes the one
/// verifier (verify.hpp: finite, mass exact to kMassTolerance, no crack, no particle inside an
/// obstacle), the interpolated surface never reaches the contact distance inside an obstacle,
/// and the step cost stays bounded (judge_stress_cell). When the state stops being finite and
/// `snapshot_dir` is not empty, the state at that step is written there as
/// `<cell name>-non_finite_snapshot.json` and `.vtk` (write_non_finite_snapshot).
std::optional<StressCellResult> run_stress_cell(const StressCell& cell,
                                                schedulers::LoopDriver& driver,
                                                const std::function<bool()>& keep_going,
                                                const std::filesystem::path& snapshot_dir = {});

/// Sets `passed` and `failures` from the figures of `result`: the worst figures of the run
/// pass judge_state (finite, mass exact, no ghost off its edge, no particle inside an
/// obstacle); on top, the interpolated surface's penetration stays below the contact
/// distance and the step cost bounded - it does not grow without bound (Trend::growing) and its last-quarter
/// mean stays at or below cost_bound (above it the steps were accepted only because their
/// halvings ran out: the minimiser no longer controls the step).
void judge_stress_cell(StressCellResult& result);

}  // namespace clothbench::harness
