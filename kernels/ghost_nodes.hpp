// Ghost particles of the adaptive mesh (MODEL.md section 6, paper Fig. 4).
//
// A ghost sits in the middle of a coarse cell's side where the neighbouring cells are finer.
// It is never simulated: its position is the midpoint of its two parents (prev and next along
// the direction it hangs on), and any force on it is handed half to each parent. With the
// tree 2:1-balanced across sides the parents are always particles (a ghost parent would need
// a leaf two levels finer beside a coarse one); the rules still recurse, as a safeguard that
// costs nothing for chains of length one.
//
// Both rules are written as *gathers* (a ghost reads its parents, a parent reads its ghost
// children), so the parallel loops keep their write-own-slot-only structure.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <span>

#include "kernels/cloth_mesh.hpp"
#include "kernels/cloth_state.hpp"

namespace clothbench::kernels {

/// Value of an interleaved xyz array at node s: stored for active particles, the midpoint of
/// the parents' values (recursively) for ghosts. Reads only active particles' entries.
inline Eigen::Vector3d node_value(const ClothMesh& mesh, std::span<const double> values,
                                  std::int64_t s) {
  const int d = ghost_direction(mesh.flags[s]);
  if (d < 0) return vec3(values, s);
  const std::int64_t id = element_id(s, d);
  return 0.5 * (node_value(mesh, values, mesh.prev[id]) + node_value(mesh, values, mesh.next[id]));
}

/// Calls f(child) for each ghost whose parent is node s (at most one per side per direction).
template <class F>
inline void for_each_ghost_child(const ClothMesh& mesh, std::int64_t s, F&& f) {
  for (int d = 0; d < 2; ++d) {
    const std::int64_t id = element_id(s, d);
    const std::int32_t n = mesh.next[id], p = mesh.prev[id];
    if (n >= 0 && ghost_direction(mesh.flags[n]) == d) f(n);
    if (p >= 0 && ghost_direction(mesh.flags[p]) == d) f(p);
  }
}

/// own(s) plus half of every ghost child's total (recursively): what node s receives from the
/// forces acting on it and on the ghosts that hang on it.
template <class Own>
inline Eigen::Vector3d with_ghost_children(const ClothMesh& mesh, std::int64_t s, const Own& own) {
  Eigen::Vector3d total = own(s);
  for_each_ghost_child(mesh, s, [&](std::int64_t child) {
    total += 0.5 * with_ghost_children(mesh, child, own);
  });
  return total;
}

/// Weight with which ghost g follows a move of active particle s (0 if it does not).
inline double ghost_weight(const ClothMesh& mesh, std::int64_t g, std::int64_t s) {
  if (g == s) return 1.0;
  const int d = ghost_direction(mesh.flags[g]);
  if (d < 0) return 0.0;
  const std::int64_t id = element_id(g, d);
  return 0.5 * (ghost_weight(mesh, mesh.prev[id], s) + ghost_weight(mesh, mesh.next[id], s));
}

}  // namespace clothbench::kernels
