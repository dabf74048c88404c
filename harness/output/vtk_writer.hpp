// Legacy VTK (ASCII POLYDATA) output of the cloth surface, for ParaView.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace clothbench::harness {

/// A quad surface with named per-point and per-cell fields, all in SI units.
/// Invariants (checked by write_vtk): every quad index is a valid point index, every
/// point field has points.size() entries, every cell field quads.size(), every value finite,
/// field names are non-empty and contain no whitespace.
struct SurfaceMesh {
  std::vector<Eigen::Vector3d> points;             ///< m
  std::vector<std::array<std::int32_t, 4>> quads;  ///< counter-clockwise point indices
  std::vector<std::pair<std::string, std::vector<double>>> point_scalars;
  std::vector<std::pair<std::string, std::vector<Eigen::Vector3d>>> point_vectors;
  std::vector<std::pair<std::string, std::vector<double>>> cell_scalars;
};

/// The legacy VTK text of `mesh` (`# vtk DataFile Version 3.0`, ASCII, DATASET POLYDATA,
/// POLYGONS, POINT_DATA, CELL_DATA). Numbers are printed with round-trip precision.
/// Throws std::invalid_argument naming the field and index of the first non-finite value,
/// bad index or wrong array length: a NaN never reaches a file.
std::string format_vtk(const SurfaceMesh& mesh, std::string_view title);

/// format_vtk written to `path` atomically (write_file_atomically).
void write_vtk(const std::filesystem::path& path, const SurfaceMesh& mesh, std::string_view title);

}  // namespace clothbench::harness
