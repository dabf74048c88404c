// The draped cloth as picture data of bounded size (see cloth_picture.hpp).
#include "harness/report/cloth_picture.hpp"

#include <algorithm>
#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "kernels/amrc.hpp"

namespace clothbench::harness {

int picture_block_level(int cells_i, int cells_j, int max_cells_per_side) {
  if (cells_i < 1 || cells_j < 1 || max_cells_per_side < 1) {
    throw std::invalid_argument("picture_block_level: cells (" + std::to_string(cells_i) + ", " +
                                std::to_string(cells_j) + ") and cells per side (" +
                                std::to_string(max_cells_per_side) + ") must be at least 1");
  }
  auto blocks = [](int cells, int p) { return (cells + (1 << p) - 1) >> p; };
  int p = 0;
  while (blocks(cells_i, p) > max_cells_per_side || blocks(cells_j, p) > max_cells_per_side) ++p;
  return p;
}

SurfaceMesh mesh_levels_picture(const kernels::Simulation& simulation, int max_cells_per_side) {
  SurfaceMesh out;
  const kernels::AdaptiveMesh* tree = simulation.adaptive_mesh();
  if (tree == nullptr) return out;
  const kernels::ClothMesh& mesh = simulation.mesh();
  const std::vector<double>& position = simulation.state().position;
  const int cells_i = tree->cells_i(), cells_j = tree->cells_j();
  const int p = picture_block_level(cells_i, cells_j, max_cells_per_side);
  const int block = 1 << p;
  const int blocks_i = (cells_i + block - 1) / block, blocks_j = (cells_j + block - 1) / block;

  std::vector<double> level;
  // One quad from grid point (i0, j0) to (i1, j1): corners counter-clockwise, as the leaves'.
  auto add_quad = [&](int i0, int j0, int i1, int j1, int quad_level) {
    const auto first = static_cast<std::int32_t>(out.points.size());
    for (const auto& [i, j] : {std::pair{i0, j0}, {i1, j0}, {i1, j1}, {i0, j1}}) {
      out.points.emplace_back(kernels::vec3(position, mesh.slot(i, j)));
    }
    out.quads.push_back({first, first + 1, first + 2, first + 3});
    level.insert(level.end(), 4, static_cast<double>(quad_level));
  };
  // A leaf of level >= p covers whole blocks: it is drawn as itself. A block holding a leaf
  // finer than p holds only such leaves; it is drawn once, at its finest leaf's level.
  std::vector<int> finest_in_block(static_cast<std::size_t>(blocks_i) * blocks_j, -1);
  for (const kernels::TreeCell& leaf : tree->leaves()) {
    const int size = 1 << leaf.level, i = leaf.ci * size, j = leaf.cj * size;
    if (leaf.level >= p) {
      add_quad(i, j, i + size, j + size, leaf.level);
      continue;
    }
    int& finest = finest_in_block[static_cast<std::size_t>(i >> p) * blocks_j + (j >> p)];
    finest = finest < 0 ? leaf.level : std::min(finest, leaf.level);
  }
  for (int bi = 0; bi < blocks_i; ++bi) {
    for (int bj = 0; bj < blocks_j; ++bj) {
      const int finest = finest_in_block[static_cast<std::size_t>(bi) * blocks_j + bj];
      if (finest < 0) continue;
      // Block corners are multiples of 2^p or the cloth's edge: corners of leaves, so active.
      add_quad(bi * block, bj * block, std::min(cells_i, (bi + 1) * block),
               std::min(cells_j, (bj + 1) * block), finest);
    }
  }
  out.point_scalars.emplace_back("mesh_level", std::move(level));
  return out;
}

SurfaceMesh grid_picture(const kernels::Simulation& simulation, int max_cells_per_side) {
  if (max_cells_per_side < 1) {
    throw std::invalid_argument("grid_picture: cells per side (" +
                                std::to_string(max_cells_per_side) + ") must be at least 1");
  }
  const kernels::ClothMesh& mesh = simulation.mesh();
  const int cells_i = mesh.size_i() - 1, cells_j = mesh.size_j() - 1;
  const int stride_i = (cells_i + max_cells_per_side - 1) / max_cells_per_side;
  const int stride_j = (cells_j + max_cells_per_side - 1) / max_cells_per_side;
  const int nodes_i = (cells_i + stride_i - 1) / stride_i + 1;
  const int nodes_j = (cells_j + stride_j - 1) / stride_j + 1;
  const std::vector<double> position = simulation.surface_positions();
  const std::vector<double> contact = simulation.contact_forces();

  SurfaceMesh out;
  std::vector<double> force(static_cast<std::size_t>(nodes_i) * nodes_j, 0.0);
  auto node = [&](int a, int b) { return static_cast<std::size_t>(a) * nodes_j + b; };
  for (int a = 0; a < nodes_i; ++a) {
    for (int b = 0; b < nodes_j; ++b) {
      const int i = std::min(cells_i, a * stride_i), j = std::min(cells_j, b * stride_j);
      out.points.emplace_back(kernels::vec3(position, mesh.slot(i, j)));
    }
  }
  for (int i = 0; i <= cells_i; ++i) {  // each finest point to its nearest picture point
    const int a = std::min(nodes_i - 1, (i + stride_i / 2) / stride_i);
    for (int j = 0; j <= cells_j; ++j) {
      const int b = std::min(nodes_j - 1, (j + stride_j / 2) / stride_j);
      double& f = force[node(a, b)];
      f = std::max(f, contact[static_cast<std::size_t>(mesh.slot(i, j))]);
    }
  }
  for (int a = 0; a + 1 < nodes_i; ++a) {
    for (int b = 0; b + 1 < nodes_j; ++b) {
      out.quads.push_back({static_cast<std::int32_t>(node(a, b)),
                           static_cast<std::int32_t>(node(a + 1, b)),
                           static_cast<std::int32_t>(node(a + 1, b + 1)),
                           static_cast<std::int32_t>(node(a, b + 1))});
    }
  }
  out.point_scalars.emplace_back("contact_force_N", std::move(force));
  return out;
}

SurfaceMesh cloth_picture(const kernels::Simulation& simulation, int max_cells_per_side) {
  return simulation.adaptive_mesh() != nullptr ? mesh_levels_picture(simulation, max_cells_per_side)
                                               : grid_picture(simulation, max_cells_per_side);
}

}  // namespace clothbench::harness
