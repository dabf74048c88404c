// Internal to harness/scene: does a scene's cloth start inside one of its obstacles? A cloth
// that starts inside a solid is pushed out by the contact penalty in the first step with
// forces far beyond anything the fabric model is meant to see, so the loader rejects it.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>

#include "kernels/obstacle.hpp"
#include "kernels/simulation_config.hpp"

namespace clothbench::harness::scene_detail {

/// The deepest cloth particle found inside an obstacle at the start of a run.
struct InitialOverlap {
  int i = 0;  ///< grid coordinates of that particle
  int j = 0;
  Eigen::Vector3d position;  ///< its unperturbed start position, m
  double depth = 0.0;        ///< how far inside the obstacle it can start, m (> 0)
  double flat_depth = 0.0;   ///< the same without initial_crumple_m (<= 0: outside when flat)
  bool complete = true;      ///< false when the search budget ran out: depth is a lower bound
};

/// Particles deeper than this (m) count as inside; the cloth may start touching a surface.
inline constexpr double kOverlapTolerance = 1e-9;

/// Searches the start positions of `cloth` (the flat grid origin + (1 + initial_stretch)
/// (i h_i axis_i + j h_j axis_j), each displaced by up to +-initial_crumple_m along the
/// cloth's normal, as kernels::Simulation places them) for the particle deepest inside
/// `obstacle`. nullopt when no particle can start more than kOverlapTolerance inside.
/// A branch-and-bound over blocks of the grid with the obstacle's broad-phase bound: cost
/// grows with the overlapping part of the grid, not with the grid; `budget` (blocks visited,
/// shared across calls) bounds it for absurd sizes.
std::optional<InitialOverlap> deepest_initial_overlap(const kernels::ClothConfig& cloth,
                                                      const kernels::Obstacle& obstacle,
                                                      std::int64_t& budget);

}  // namespace clothbench::harness::scene_detail
