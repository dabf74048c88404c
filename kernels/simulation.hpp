// One cloth simulation: builds mesh, material, obstacles and state from a SimulationConfig
// and advances it step by step through a scheduler (MODEL.md sections 1-5 and 7).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "kernels/active_lists.hpp"
#include "kernels/amrc.hpp"
#include "kernels/cg_minimiser.hpp"
#include "kernels/cloth_mesh.hpp"
#include "kernels/cloth_state.hpp"
#include "kernels/kes_material.hpp"
#include "kernels/loop_runner.hpp"
#include "kernels/obstacle.hpp"
#include "kernels/simulation_config.hpp"
#include "kernels/step_objective.hpp"

namespace clothbench::kernels {

class ModelHessian;
class PotentialObjective;

/// What one step did.
struct StepReport {
  int step = 0;                 ///< 1-based index of the completed step
  MinimiserReport minimiser;    ///< iterations, evaluations, costs, stop reason
  double seconds = 0.0;         ///< wall time of the step, its AMRC check included
  int sub_steps = 1;            ///< accepted sub-steps (more than 1 after a rejection)
  int rejected = 0;             ///< rejected attempts
  std::int64_t active_elements = 0;  ///< active particles + edges + triples
  std::optional<AmrcEvent> amrc;     ///< the AMRC check that followed the step, if one ran
  /// Scripted events (indices into SimulationConfig::events) that began before this step.
  std::vector<int> events;
};

/// Verification figures of the current state.
struct StateDiagnostics {
  bool finite = true;                    ///< every position and force is finite
  double total_mass = 0.0;               ///< kg, active particles
  double weight = 0.0;                   ///< N, total mass * |g|
  Eigen::Vector3d contact_force = Eigen::Vector3d::Zero();  ///< summed penalty force, N
  double contact_support = 0.0;          ///< contact force along -g, N
  double min_particle_distance = 0.0;    ///< min signed distance of active particles to obstacles, m
  double max_surface_penetration = 0.0;  ///< max depth of the interpolated surface inside an obstacle, m
  double max_strain = 0.0;               ///< max edge strain
  double max_ghost_offset = 0.0;         ///< max distance of a ghost from its parents' midpoint, m
  std::int64_t active_particles = 0, active_edges = 0, active_triples = 0;
};

/// The time-budget poll of one step: thread 0's clock decides, every thread gets the answer
/// (called by every thread of the step's region at the same point of the CG loop).
struct BudgetPoll {
  double deadline;
  int expired;
  static bool poll(void* self) {
    auto* b = static_cast<BudgetPoll*>(self);
#pragma omp barrier
#pragma omp single
    b->expired = monotonic_seconds() >= b->deadline ? 1 : 0;
    return b->expired != 0;  // the single's closing barrier publishes it
  }
};

class Simulation {
 public:
  explicit Simulation(const SimulationConfig& config);
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;
  ~Simulation();

  /// Advances one step. Runs one OpenMP parallel region with the current thread count;
  /// `times` (may be null) must hold one entry per thread of that team, and so must `trace`
  /// (may be null: then nothing is recorded; ChunkTrace::start sets the team size).
  StepReport step(schedulers::LoopDriver& driver, Instrumentation instrumentation = Instrumentation::off,
                  LoopTimes* times = nullptr, ChunkTrace* trace = nullptr);

  /// Evaluates the objective and its gradient at the current unknowns (no step taken).
  /// Used by the gradient tests and benchmarks; the gradient is then in state().gradient.
  /// `refresh_history` recomputes the per-step constants from the element forces first (needed
  /// after editing state() by hand; a benchmark of the evaluation alone passes false).
  Evaluation evaluate(schedulers::LoopDriver& driver, bool refresh_history = true);

  [[nodiscard]] StateDiagnostics diagnostics() const;
  /// The first non-finite value of the state, named by element kind, grid position and term
  /// (e.g. "tension of edge (3, 4)->(3, 5) along j = nan"), or "" when every value is finite.
  /// Scans active particles' positions, then edge tensions, then triple moments.
  [[nodiscard]] std::string locate_non_finite() const;
  /// Normal support force of every slot at the current positions (N; 0 off contact).
  [[nodiscard]] std::vector<double> contact_forces() const;
  [[nodiscard]] const ClothMesh& mesh() const { return mesh_; }
  [[nodiscard]] const ClothState& state() const { return state_; }
  [[nodiscard]] ClothState& state() { return state_; }
  [[nodiscard]] const SimulationConfig& config() const { return config_; }
  [[nodiscard]] const FabricMaterial& material() const { return material_; }
  [[nodiscard]] const std::vector<Obstacle>& obstacles() const { return obstacles_; }
  [[nodiscard]] int steps_done() const { return steps_done_; }
  /// Quads of the current mesh (the leaves on an adaptive mesh) as corner slots in
  /// (i,j), (i+s,j), (i+s,j+s), (i,j+s) order.
  [[nodiscard]] std::vector<std::array<std::int32_t, 4>> surface_quads() const;
  /// Positions of every slot, inactive ones interpolated on the current (adaptive) surface:
  /// the cloth sampled at every finest grid point.
  [[nodiscard]] std::vector<double> surface_positions() const;
  /// The quadtree, or null when AMRC is off.
  [[nodiscard]] const AdaptiveMesh* adaptive_mesh() const { return amrc_.get(); }
  /// Runs an AMRC check now (normally done by step() every check_every steps) and rebuilds
  /// the Active-Lists if they are in use. Throws std::logic_error when AMRC is off.
  AmrcEvent adapt();
  /// Hand-driven tree edits (tests): begin_tree_edit() returns the tree to refine/coarsen;
  /// end_tree_edit() rewrites the mesh, carries the unknowns across and rebuilds the lists.
  AdaptiveMesh& begin_tree_edit();
  void end_tree_edit();
  /// Steps the caller will run in all (shares the [solver] time budget; default 1: the whole
  /// remaining budget goes to the next step).
  void set_planned_steps(int steps) { planned_steps_ = std::max(1, steps); }

  // --- scripted scene events (MODEL.md 8; simulation_events.cpp) -------------------------
  // step() applies SimulationConfig::events itself, before the step they are due at; these
  // also serve hand-driven tests. All act between steps, outside the parallel loops.

  /// Translates obstacle `index` by `displacement` (m). Throws std::out_of_range.
  void move_obstacle(int index, const Eigen::Vector3d& displacement);
  /// Frees the pinned particle (i, j), at rest where it is. Throws std::invalid_argument when
  /// it is not pinned (or outside the grid).
  void release_pin(int i, int j);
  /// Sets the external force on particle (i, j) (N), replacing any previous one; a zero
  /// force clears it. It acts once the particle is free (not while pinned). With AMRC the
  /// leaves around the particle are split until it is active, and it is kept active (like a
  /// pin) while the force acts. Throws std::invalid_argument outside the grid.
  void set_external_force(int i, int j, const Eigen::Vector3d& force);
  void clear_external_force(int i, int j) { set_external_force(i, j, Eigen::Vector3d::Zero()); }

  /// Switches the contact broad phase (ContactConfig::broad_phase) on or off; results are
  /// bit-identical either way, only the work differs.
  void set_broad_phase(bool on) { config_.contact.broad_phase = on; }
  /// Narrow-phase contact pairs tested / skipped over every evaluation so far.
  [[nodiscard]] const ContactWork& contact_work() const { return objective_->contact_work(); }
  /// The Newton model as last assembled (null unless the method is Newton; tests).
  [[nodiscard]] const ModelHessian* model_hessian() const;
  /// The V-cycle preconditioner's set-up so far (all zero without one).
  struct VcycleWork {
    std::int64_t factorisations = 0;  ///< one per model assembly (Newton iteration, refinement)
    std::int64_t structures = 0;      ///< hierarchies made anew (after topology changes)
    double sequential_seconds = 0.0;  ///< set-up time spent on one thread
    std::int64_t steps = 0;           ///< (sub-)steps whose solves needed it (vcycle_after)
  };
  [[nodiscard]] VcycleWork vcycle_work() const;

  /// How the Active-Lists are rebuilt after an AMRC event (parallel prefix sum by default).
  void set_list_build(ListBuild build) { list_build_ = build; }
  /// Whether the pages of unused slots are handed back after every AMRC event that changed
  /// the mesh (slot_pages.hpp; on by default). Off keeps every page: the same results, bit for
  /// bit (tests compare the two).
  void set_release_unused_pages(bool on) { release_unused_pages_ = on; }
  /// Hands back now the pages of the slots that are neither particle nor ghost, of the arrays
  /// that are not read there (ClothState::release_unused, the objective's, the masses), and the
  /// pages of the Active-Lists' capacity beyond their entries; returns the bytes. Done by
  /// adapt() and end_tree_edit() when the setting is on.
  std::size_t release_unused_pages();
  /// Rebuilds the Active-Lists now (used by benchmarks); returns seconds.
  double rebuild_lists();
  [[nodiscard]] const ActiveLists* active_lists() const { return lists_built_ ? &lists_ : nullptr; }
  /// Bytes held by each part of the simulation: the capacity of its arrays, pages handed back
  /// to the system included (the resident set is the process's, run_summary.hpp).
  struct MemoryParts {
    std::size_t mesh = 0;    ///< flags, masses, neighbours, element flags and geometry
    std::size_t state = 0;   ///< ClothState: positions, gradients, forces, scratch, breakpoints
    std::size_t lists = 0;   ///< the Active-Lists
    std::size_t amrc = 0;    ///< the AMRC tree and its marks
    std::size_t solver = 0;  ///< the objective's own: model Hessian, line factors, PCG arrays
    std::size_t vcycle = 0;  ///< the V-cycle's hierarchy (levels, Galerkin rows, factors)
    [[nodiscard]] std::size_t total() const {
      return mesh + state + lists + amrc + solver + vcycle;
    }
  };
  [[nodiscard]] MemoryParts memory_parts() const;
  /// Bytes held by the whole simulation (memory_parts().total()).
  [[nodiscard]] std::size_t memory_bytes() const { return memory_parts().total(); }
  /// Active particles + edges + triples.
  [[nodiscard]] std::int64_t active_elements() const;

 private:
  void place_initial_positions();
  /// Throws std::invalid_argument for an event the kernel cannot apply (the scene loader
  /// reports the same cases at their file position).
  void check_events() const;
  /// Applies the configured events due before step `step`; returns those that begin there.
  std::vector<int> apply_events(int step);
  /// Slot of grid point (i, j); throws std::invalid_argument naming `what` outside the grid.
  [[nodiscard]] std::int64_t grid_slot(int i, int j, const char* what) const;
  /// After an AMRC event: moves every free particle found inside an obstacle out along the
  /// obstacle's normal to the contact distance (x, x^n and x~ alike) and puts the ghosts back
  /// on their parents' midpoints. A state with no particle inside an obstacle is unchanged.
  void lift_out_of_obstacles();
  /// After an AMRC event that changed the mesh: hands back the unused slots' pages (when the
  /// setting is on; returns the bytes) and lets the objective forget the inactive elements.
  std::size_t after_mesh_change();
  /// The carried velocity (target - step_start) of a step of length `from` made that of a step
  /// of length `to`: scaled by the length and by the damping rate (called by every thread of
  /// the step's region).
  void rescale_velocity(LoopRunner& run, double from, double to);

  SimulationConfig config_;
  FabricMaterial material_;
  ClothMesh mesh_;
  std::vector<Obstacle> obstacles_;
  ClothState state_;
  ActiveLists lists_;
  bool lists_built_ = false;
  ListBuild list_build_ = ListBuild::parallel_prefix_sum;
  bool release_unused_pages_ = true;
  std::unique_ptr<AdaptiveMesh> amrc_;
  std::unique_ptr<StepObjective> objective_;
  /// The objective again when the method is Newton (potential formulation only), else null.
  PotentialObjective* newton_objective_ = nullptr;
  double first_alpha_ = 1.0;
  int steps_done_ = 0;
  int planned_steps_ = 1;
  double budget_spent_ = 0.0;  ///< wall seconds of the steps so far, when a budget is set
};

/// Upper estimate of the memory a simulation of `config` needs (bytes), before allocating.
std::size_t estimate_memory_bytes(const SimulationConfig& config);

}  // namespace clothbench::kernels
