// The cloth picture's data (cloth.dat) is bounded whatever the mesh size (issue 21): a
// 1001 x 1001 mesh at its finest gives a few MB, not 100 MB; the picture still covers the
// whole cloth, a small mesh is drawn leaf for leaf, and a block of leaves finer than the
// picture shows the finest of them. Without AMRC the cloth is sampled on a bounded grid.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "harness/report/cloth_picture.hpp"
#include "harness/report/sweep_plots.hpp"
#include "kernels/amrc.hpp"

namespace {

using clothbench::harness::cloth_picture;
using clothbench::harness::cloth_plot_data;
using clothbench::harness::grid_picture;
using clothbench::harness::kPictureCellsPerSide;
using clothbench::harness::mesh_levels_picture;
using clothbench::harness::picture_block_level;
using clothbench::harness::SurfaceMesh;
namespace kernels = clothbench::kernels;

/// A flat 1 m x 1 m sheet of `particles`^2 particles with AMRC of `levels` levels, every
/// leaf at the finest level (as a run starts).
kernels::SimulationConfig sheet(int particles, int levels) {
  kernels::SimulationConfig c;
  c.cloth.particles_i = c.cloth.particles_j = particles;
  c.cloth.size_i = c.cloth.size_j = 1.0;
  c.amrc.enabled = true;
  c.amrc.levels = levels;
  return c;
}

/// Merges every leaf group it can whose cells lie in the half i < cells_i / 2 (2:1 balance
/// keeps a band of finer leaves next to the finest half): a tree of every level.
void coarsen_half(kernels::Simulation& sim) {
  kernels::AdaptiveMesh& tree = sim.begin_tree_edit();
  for (int level = 1; level <= tree.levels(); ++level) {
    const int size = 1 << level;
    for (int ci = 0; (ci + 1) * size <= tree.cells_i() / 2; ++ci) {
      for (int cj = 0; cj * size < tree.cells_j(); ++cj) tree.coarsen({level, ci, cj}, sim.mesh());
    }
  }
  sim.end_tree_edit();
}

/// Area of the picture's quads (m^2; each planar on a flat sheet).
double total_area(const SurfaceMesh& picture) {
  double area = 0.0;
  for (const auto& q : picture.quads) {
    const auto& p = picture.points;
    area += 0.5 * (p[q[2]] - p[q[0]]).cross(p[q[3]] - p[q[1]]).norm();
  }
  return area;
}

/// The "mesh_level" value of quad `q` (the same at its four points).
double quad_level(const SurfaceMesh& picture, std::size_t q) {
  return picture.point_scalars.at(0).second.at(4 * q);
}

TEST(ClothPicture, BlockLevelKeepsEachSideWithinTheLimit) {
  EXPECT_EQ(picture_block_level(64, 64, 200), 0);
  EXPECT_EQ(picture_block_level(200, 200, 200), 0);
  EXPECT_EQ(picture_block_level(201, 8, 200), 1);
  EXPECT_EQ(picture_block_level(1000, 1000, 200), 3);  // 125 per side; 2^2 blocks leave 250
  EXPECT_EQ(picture_block_level(8, 1000, 200), 3);
  EXPECT_EQ(picture_block_level(40, 40, 4), 4);  // ceil(40 / 16) = 3
  EXPECT_THROW(picture_block_level(0, 8, 200), std::invalid_argument);
  EXPECT_THROW(picture_block_level(8, 8, 0), std::invalid_argument);
}

// The paper's 1001 x 1001 mesh as a run starts (10^6 finest leaves): 125 x 125 quads and a
// few MB of cloth.dat instead of 10^6 quads and ~100 MB; they still cover the whole cloth.
TEST(ClothPicture, AMillionCellMeshGivesAFewMegabytes) {
  const kernels::Simulation sim(sheet(1001, 3));
  ASSERT_EQ(sim.adaptive_mesh()->leaves().size(), 1000u * 1000u);
  const SurfaceMesh picture = mesh_levels_picture(sim);
  EXPECT_LE(picture.quads.size(), static_cast<std::size_t>(kPictureCellsPerSide) *
                                      static_cast<std::size_t>(kPictureCellsPerSide));
  EXPECT_EQ(picture.quads.size(), 125u * 125u);
  const std::string data = cloth_plot_data(picture);
  EXPECT_LE(data.size(), 8'000'000u) << "cloth.dat of " << picture.quads.size() << " quads";
  EXPECT_NEAR(total_area(picture), 1.0, 1e-9);
  for (std::size_t q = 0; q < picture.quads.size(); ++q) ASSERT_EQ(quad_level(picture, q), 0.0);
}

// Up to kPictureCellsPerSide cells a side, the picture is the leaves themselves (as before
// issue 21): same corners, same level, same order.
TEST(ClothPicture, SmallMeshIsDrawnLeafForLeaf) {
  kernels::Simulation sim(sheet(65, 3));
  coarsen_half(sim);
  const std::vector<kernels::TreeCell> leaves = sim.adaptive_mesh()->leaves();
  ASSERT_LT(leaves.size(), 64u * 64u);  // the half did coarsen
  const SurfaceMesh picture = mesh_levels_picture(sim);
  ASSERT_EQ(picture.quads.size(), leaves.size());
  for (std::size_t q = 0; q < leaves.size(); ++q) {
    const kernels::TreeCell& leaf = leaves[q];
    const int size = 1 << leaf.level, i = leaf.ci * size, j = leaf.cj * size;
    const Eigen::Vector3d corner = kernels::vec3(sim.state().position, sim.mesh().slot(i, j));
    const Eigen::Vector3d opposite =
        kernels::vec3(sim.state().position, sim.mesh().slot(i + size, j + size));
    EXPECT_EQ(picture.points[picture.quads[q][0]], corner) << "leaf " << q;
    EXPECT_EQ(picture.points[picture.quads[q][2]], opposite) << "leaf " << q;
    EXPECT_EQ(quad_level(picture, q), leaf.level) << "leaf " << q;
  }
  EXPECT_NEAR(total_area(picture), 1.0, 1e-9);
}

// Leaves finer than the picture's blocks are drawn as their block, coloured by the finest
// leaf inside; coarser leaves stay whole; together they tile the cloth.
TEST(ClothPicture, FineLeavesMergeIntoBlocksAtTheirFinestLevel) {
  kernels::Simulation sim(sheet(129, 3));  // 128 cells a side; 32 a side: blocks of 4 x 4
  coarsen_half(sim);
  sim.begin_tree_edit().refine_to_particle(21, 63);  // finest leaves amid coarse ones
  sim.end_tree_edit();
  const kernels::AdaptiveMesh& tree = *sim.adaptive_mesh();
  const SurfaceMesh picture = mesh_levels_picture(sim, 32);
  EXPECT_LE(picture.quads.size(), 32u * 32u);
  EXPECT_NEAR(total_area(picture), 1.0, 1e-9);
  const double spacing = sim.mesh().spacing(0);
  int levels_seen = 0;
  bool mixed_block = false;  // a block holding leaves of two levels
  for (std::size_t q = 0; q < picture.quads.size(); ++q) {
    // The finest cells under the quad, from its corners on the flat sheet (origin -0.5, -0.5).
    const Eigen::Vector3d& low = picture.points[picture.quads[q][0]];
    const Eigen::Vector3d& high = picture.points[picture.quads[q][2]];
    const int i0 = static_cast<int>(std::lround((low.x() + 0.5) / spacing));
    const int j0 = static_cast<int>(std::lround((low.y() + 0.5) / spacing));
    const int i1 = static_cast<int>(std::lround((high.x() + 0.5) / spacing));
    const int j1 = static_cast<int>(std::lround((high.y() + 0.5) / spacing));
    int finest = tree.levels(), coarsest = 0;
    for (int fi = i0; fi < i1; ++fi) {
      for (int fj = j0; fj < j1; ++fj) {
        finest = std::min(finest, tree.leaf_level(fi, fj));
        coarsest = std::max(coarsest, tree.leaf_level(fi, fj));
      }
    }
    mixed_block = mixed_block || finest != coarsest;
    EXPECT_EQ(quad_level(picture, q), finest) << "quad " << q;
    levels_seen |= 1 << finest;
  }
  EXPECT_EQ(levels_seen & 0b1001, 0b1001) << "blocks at level 0 and leaves at level 3";
  EXPECT_TRUE(mixed_block);

  // Blocks larger than the tree's roots, clipped at the cloth's edge: 40 cells, 4 a side.
  const kernels::Simulation small(sheet(41, 3));
  const SurfaceMesh coarse = mesh_levels_picture(small, 4);
  EXPECT_EQ(coarse.quads.size(), 9u);  // blocks of 16 cells: 16 + 16 + 8 a side
  EXPECT_NEAR(total_area(coarse), 1.0, 1e-9);
}

// Without AMRC (sweep pictures): 1001^2 particles give 200 x 200 quads, every 5th point;
// 33^2 give every finest quad. Both cover the cloth and carry the contact force field.
TEST(ClothPicture, GridPictureIsBoundedAndCoversTheCloth) {
  kernels::SimulationConfig big = sheet(1001, 3);
  big.amrc.enabled = false;
  const kernels::Simulation sim(big);
  const SurfaceMesh picture = cloth_picture(sim);
  EXPECT_EQ(picture.quads.size(), 200u * 200u);
  EXPECT_LE(cloth_plot_data(picture).size(), 8'000'000u);
  EXPECT_NEAR(total_area(picture), 1.0, 1e-9);
  ASSERT_EQ(picture.point_scalars.size(), 1u);
  EXPECT_EQ(picture.point_scalars[0].first, "contact_force_N");

  kernels::SimulationConfig small = sheet(33, 3);
  small.amrc.enabled = false;
  const SurfaceMesh fine = grid_picture(kernels::Simulation(small));
  EXPECT_EQ(fine.quads.size(), 32u * 32u);
  EXPECT_NEAR(total_area(fine), 1.0, 1e-9);
  // 30 cells, 4 a side: every 8th point, the last block clipped at the edge.
  const SurfaceMesh clipped = grid_picture(kernels::Simulation(sheet(31, 1)), 4);
  EXPECT_EQ(clipped.quads.size(), 16u);
  EXPECT_NEAR(total_area(clipped), 1.0, 1e-9);
}

}  // namespace
