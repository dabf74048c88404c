// One cloth simulation: builds mesh, material, obstacles and state from a SimulationConfig
// and advances it step by step through a scheduler (MODEL.md sections 1-5 and 7).
#pragma once

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

/// What one step did.
struct StepReport {
  int step = 0;                 ///< 1-based index of the completed step
  MinimiserReport minimiser;    ///< iterations, evaluations, costs, stop reason
  double seconds = 0.0;         ///< wall time of the step, its AMRC check included
  int sub_steps = 1;            ///< accepted sub-steps (more than 1 after a rejection)
  int rejected = 0;             ///< rejected attempts
  std::int64_t active_elements = 0;  ///< active particles + edges + triples
  std::optional<AmrcEvent> amrc;     ///< the AMRC check that followed the step, if one ran
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

class Simulation {
 public:
  explicit Simulation(const SimulationConfig& config);
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;
  ~Simulation();

  /// Advances one step. Runs one OpenMP parallel region with the current thread count;
  /// `times` (may be null) must hold one entry per thread of that team.
  StepReport step(schedulers::LoopDriver& driver, Instrumentation instrumentation = Instrumentation::off,
                  LoopTimes* times = nullptr);

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
  /// How the Active-Lists are rebuilt after an AMRC event (parallel prefix sum by default).
  void set_list_build(ListBuild build) { list_build_ = build; }
  /// Rebuilds the Active-Lists now (used by benchmarks); returns seconds.
  double rebuild_lists();
  [[nodiscard]] const ActiveLists* active_lists() const { return lists_built_ ? &lists_ : nullptr; }
  /// Bytes held by mesh, state and lists.
  [[nodiscard]] std::size_t memory_bytes() const;
  /// Active particles + edges + triples.
  [[nodiscard]] std::int64_t active_elements() const;

 private:
  void place_initial_positions();
  /// After an AMRC event: moves every free particle found inside an obstacle out along the
  /// obstacle's normal to the contact distance (x, x^n and x~ alike) and puts the ghosts back
  /// on their parents' midpoints. A state with no particle inside an obstacle is unchanged.
  void lift_out_of_obstacles();
  /// target = step_start + factor (target - step_start): the carried velocity for a new step
  /// length (called by every thread of the step's region).
  void rescale_velocity(LoopRunner& run, double factor);

  SimulationConfig config_;
  FabricMaterial material_;
  ClothMesh mesh_;
  std::vector<Obstacle> obstacles_;
  ClothState state_;
  ActiveLists lists_;
  bool lists_built_ = false;
  ListBuild list_build_ = ListBuild::parallel_prefix_sum;
  std::unique_ptr<AdaptiveMesh> amrc_;
  std::unique_ptr<StepObjective> objective_;
  double first_alpha_ = 1.0;
  int steps_done_ = 0;
};

/// Upper estimate of the memory a simulation of `config` needs (bytes), before allocating.
std::size_t estimate_memory_bytes(const SimulationConfig& config);

}  // namespace clothbench::kernels
