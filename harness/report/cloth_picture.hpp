// The draped cloth as picture data of bounded size (issue 21): the adaptive mesh's leaves,
// with leaves finer than a picture can show merged into square blocks, or the cloth sampled
// on a coarser grid, so that cloth.dat and gnuplot cost a small fraction of a run whatever
// the mesh size.
#pragma once

#include "harness/output/vtk_writer.hpp"
#include "kernels/simulation.hpp"

namespace clothbench::harness {

/// Most picture cells along either side of the cloth: a picture surface holds at most
/// kPictureCellsPerSide^2 quads (under 8 MB of cloth.dat). 200 still gives a cell every
/// 3-4 pixels of the 1100 x 850 picture; meshes of up to 201 x 201 particles are drawn
/// leaf for leaf.
inline constexpr int kPictureCellsPerSide = 200;

/// Level p of the picture's blocks (2^p x 2^p finest cells): the smallest p >= 0 with
/// ceil(cells_i / 2^p) and ceil(cells_j / 2^p) both at most `max_cells_per_side`.
/// Throws std::invalid_argument when a count is below 1.
int picture_block_level(int cells_i, int cells_j, int max_cells_per_side);

/// The adaptive mesh's leaves as separate quads (four points each, at active particles) with
/// a "mesh_level" point field equal to the quad's level (0 = finest). A leaf of level >= p
/// (picture_block_level of the tree) is one quad; leaves finer than p are drawn as their
/// 2^p x 2^p block (clipped at the cloth's edge), coloured by the finest leaf inside it.
/// The quads tile the cloth exactly, at most max_cells_per_side^2 of them; with p = 0 they
/// are the leaves themselves, in AdaptiveMesh::leaves() order. Empty without AMRC.
SurfaceMesh mesh_levels_picture(const kernels::Simulation& simulation,
                                int max_cells_per_side = kPictureCellsPerSide);

/// The cloth on a grid of at most max_cells_per_side cells a side: every s-th finest grid
/// point along each side (s = ceil(cells / max_cells_per_side), the last row and column at
/// the cloth's edge), at surface_positions(), with a "contact_force_N" point field holding
/// the largest contact force of the finest points around it (so no contact is lost
/// between samples). With s = 1 it is every finest quad, in grid order.
SurfaceMesh grid_picture(const kernels::Simulation& simulation,
                         int max_cells_per_side = kPictureCellsPerSide);

/// The picture of a run's cloth: mesh_levels_picture() with AMRC, else grid_picture().
SurfaceMesh cloth_picture(const kernels::Simulation& simulation,
                          int max_cells_per_side = kPictureCellsPerSide);

}  // namespace clothbench::harness
