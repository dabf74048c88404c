// The measured record of one simulation run, its verification, and its text/JSON/VTK forms.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "harness/output/vtk_writer.hpp"
#include "harness/run/disturbance.hpp"
#include "harness/run/verify.hpp"
#include "harness/scene/scene.hpp"
#include "kernels/simulation.hpp"

namespace clothbench::harness {

/// One step's line of the run record.
struct StepRecord {
  int step = 0;
  int iterations = 0;         ///< nonlinear CG iterations, or Newton iterations
  int linear_iterations = 0;  ///< Newton: inner PCG iterations (0 for nonlinear CG)
  int evaluations = 0;
  double cost = 0.0;          ///< final E of the step
  double residual_rms = 0.0;  ///< sqrt(En / free particles)
  double residual_max = 0.0;
  std::string stop;
  double seconds = 0.0;
  std::int64_t active_elements = 0;
  int sub_steps = 1;  ///< accepted sub-steps (rejected steps are redone with half the length)
  /// The process's resident set when the step ended and its high-water mark then (VmRSS and
  /// VmHWM; 0 where /proc cannot be read, null in the JSON), and the simulation's own allocated
  /// bytes by part (mesh, state, lists, AMRC, solver, V-cycle; their total is the JSON's
  /// `simulation_bytes`): the step whose high-water mark rises set it, the part that grew how.
  std::uint64_t resident_bytes = 0;
  std::uint64_t peak_resident_bytes = 0;
  kernels::Simulation::MemoryParts simulation_parts;
};

/// A scripted scene event as the run applied it.
struct AppliedEvent {
  int step = 0;       ///< the step it was applied before
  int index = 0;      ///< its place among the scene's [[event]] tables
  std::string text;   ///< e.g. "force (0, 0, 0.05) N on particle (16, 16) through step 30"
};

/// Everything a run measured.
/// One row of `clothbench run --newton-log`: a Newton iteration of a step.
struct NewtonLogRow {
  int step = 0;
  kernels::NewtonIterationRecord iteration;
};

struct RunSummary {
  std::vector<StepRecord> steps;
  /// Every Newton iteration, when the solver recorded them (SolverConfig::log_iterations).
  std::vector<NewtonLogRow> newton_log;
  double wall_seconds = 0.0;             ///< all steps
  double average_minimised_cost = 0.0;   ///< mean over steps of final E / active elements
  kernels::StateDiagnostics final_state;
  double mass_error = 0.0;               ///< |total mass - density W H| / (density W H)
  std::int64_t total_iterations = 0;
  std::int64_t total_linear_iterations = 0;
  std::int64_t total_evaluations = 0;
  std::string method;  ///< kernels::to_string(StepMethod) of the run
  std::int64_t rejected_steps = 0;
  int threads = 1;
  bool oversubscribed = false;
  std::uint64_t peak_resident_bytes = 0;
  kernels::Simulation::MemoryParts simulation_parts;  ///< after the last step
  std::vector<kernels::AmrcEvent> amrc_events;  ///< every AMRC check, in order
  std::vector<AppliedEvent> events;             ///< every scripted event that began, in order
  kernels::ContactWork contact_work;            ///< narrow-phase contact pairs, all evaluations
  double amrc_seconds = 0.0;  ///< criterion + mesh update + list rebuild, all events
  kernels::Simulation::VcycleWork vcycle;      ///< the V-cycle's set-up (zeros without one)
  /// Where the first non-finite value appeared ("" if none): the run stopped at that step.
  std::string non_finite;
  int non_finite_step = 0;
  Verification verification;
  /// Whether other work on the machine disturbed the run (set by `clothbench run`).
  Disturbance disturbance;
};

/// Called after every finite step with the simulation and the step's record; returning false
/// stops the run there (the summary then holds the steps done so far).
using StepObserver = std::function<bool(const kernels::Simulation&, const StepRecord&)>;

/// Runs `steps` steps, verifying the state after each; stops early on a non-finite state
/// (or when `observer`, if given, returns false). `trace`, when given (started for the
/// team), records every loop and chunk of the steps (kernels/chunk_trace.hpp).
RunSummary simulate(kernels::Simulation& simulation, schedulers::LoopDriver& driver, int steps,
                    bool quiet, const StepObserver& observer = {},
                    kernels::ChunkTrace* trace = nullptr);
/// One line describing a scripted event (what the run prints when it begins).
std::string describe_event(const kernels::SceneEvent& event);
/// `clothbench run --newton-log`: a header line, then one line per Newton iteration (step,
/// attempt, dt_s, iteration, rms, forcing, linear_iterations, linear_relative_residual,
/// refinements, alpha, line_search_evaluations, rms_after_line_search, smoothed_particles,
/// rms_after, edges_slack, edges_loading, edges_plateau, edges_unloading, edges_changed; see
/// kernels::NewtonIterationRecord).
std::string newton_log_csv(const std::vector<NewtonLogRow>& rows);
/// Prints the summary block and the `Verification: PASSED/FAILED` line.
void print_summary(const RunSummary& summary);
/// The state when a non-finite value appeared, as JSON (non-finite entries become null).
nlohmann::json non_finite_snapshot(const RunSummary& summary, const kernels::Simulation& simulation);
/// The same state as a surface for ParaView: every slot's position (the raw state, as in the
/// JSON; a non-finite coordinate is written as 0), the current surface's quads, and per point
/// `non_finite` (the sum of 1: position, 2: an edge force at this slot, 4: a triple moment at
/// this slot - the slot whose element_id holds it), `pinned`, and the element values at the
/// slot (`edge_force_i_N_per_m`, `edge_force_j_N_per_m`, `triple_moment_i_N`,
/// `triple_moment_j_N`; a non-finite value written as 0 and flagged). No NaN reaches the file.
SurfaceMesh non_finite_surface(const kernels::Simulation& simulation);
/// Writes the diagnostic snapshot of a run stopped by a non-finite value: `<stem>.json`
/// (non_finite_snapshot) and `<stem>.vtk` (non_finite_surface) in `dir`, each atomically.
/// Returns the files written, in that order.
std::vector<std::filesystem::path> write_non_finite_snapshot(const std::filesystem::path& dir,
                                                             const std::string& stem,
                                                             const RunSummary& summary,
                                                             const kernels::Simulation& simulation,
                                                             std::string_view title);
/// The run as JSON (no machine block; the caller adds it).
nlohmann::json summary_json(const RunSummary& summary, const Scene& scene,
                            const std::string& scheduler);
/// The current cloth surface with contact force and mesh level per point.
SurfaceMesh surface_mesh(const kernels::Simulation& simulation);
/// Peak resident set size of this process (bytes): VmHWM, as in each step's record.
std::uint64_t peak_resident_bytes();
/// Thread count to use: `requested` (>0) or the OpenMP default; throws std::invalid_argument
/// naming `flag` when it exceeds the hardware threads and oversubscription is not allowed.
int resolve_threads(int requested, bool allow_oversubscribe, const char* flag);
/// The memory a simulation of `scene` needs (bytes, kernels::estimate_memory_bytes). Throws
/// SceneError `FILE:LINE:COLUMN: [cloth] particles: ...` (the position of that value in the
/// scene file) when it exceeds 90 % of this machine's memory.
std::uint64_t check_memory(const Scene& scene);

/// How the reports name a run's step solver ("Newton", "CG"; "" for a record without one).
std::string solver_name(const std::string& method);

/// A run's solver iterations for a table cell: "Newton 392 (PCG 731)" or "CG 47904".
std::string solver_iterations(const RunSummary& summary);

}  // namespace clothbench::harness
