// Legacy VTK writer: validate everything first, then format, then write atomically.
#include "harness/output/vtk_writer.hpp"

#include <fmt/format.h>

#include <cmath>
#include <iterator>
#include <stdexcept>

#include "harness/output/atomic_file.hpp"

namespace clothbench::harness {
namespace {

[[noreturn]] void invalid(std::string message) {
  throw std::invalid_argument("VTK output: " + message);
}

void check_name(const std::string& kind, const std::string& name) {
  if (name.empty()) invalid(fmt::format("a {} field has an empty name", kind));
  for (const char c : name) {
    if (c <= ' ' || c == 0x7f)
      invalid(
          fmt::format("{} field name '{}' contains whitespace or a control character", kind, name));
  }
}

void check_scalars(const std::string& kind, const std::string& name,
                   const std::vector<double>& values, std::size_t expected) {
  check_name(kind, name);
  if (values.size() != expected) {
    invalid(fmt::format("{} field '{}' has {} values, expected {}", kind, name, values.size(),
                        expected));
  }
  for (std::size_t k = 0; k < values.size(); ++k) {
    if (!std::isfinite(values[k]))
      invalid(fmt::format("{} field '{}' has {} at index {}", kind, name, values[k], k));
  }
}

void check_vectors(const std::string& kind, const std::string& name,
                   const std::vector<Eigen::Vector3d>& values, std::size_t expected) {
  check_name(kind, name);
  if (values.size() != expected) {
    invalid(fmt::format("{} field '{}' has {} values, expected {}", kind, name, values.size(),
                        expected));
  }
  for (std::size_t k = 0; k < values.size(); ++k) {
    if (!values[k].allFinite()) {
      invalid(fmt::format("{} field '{}' has ({}, {}, {}) at index {}", kind, name, values[k].x(),
                          values[k].y(), values[k].z(), k));
    }
  }
}

void check(const SurfaceMesh& mesh) {
  check_vectors("point", "points", mesh.points, mesh.points.size());
  const auto count = static_cast<std::int64_t>(mesh.points.size());
  for (std::size_t q = 0; q < mesh.quads.size(); ++q) {
    for (const std::int32_t index : mesh.quads[q]) {
      if (index < 0 || index >= count) {
        invalid(fmt::format("quad {} refers to point {} of {}", q, index, count));
      }
    }
  }
  for (const auto& [name, values] : mesh.point_scalars)
    check_scalars("point", name, values, mesh.points.size());
  for (const auto& [name, values] : mesh.point_vectors)
    check_vectors("point", name, values, mesh.points.size());
  for (const auto& [name, values] : mesh.cell_scalars)
    check_scalars("cell", name, values, mesh.quads.size());
}

}  // namespace

std::string format_vtk(const SurfaceMesh& mesh, std::string_view title) {
  check(mesh);
  // The title is one line of at most 255 characters.
  std::string header(title.substr(0, 255));
  for (char& c : header) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  fmt::memory_buffer out;
  auto it = std::back_inserter(out);
  fmt::format_to(it, "# vtk DataFile Version 3.0\n{}\nASCII\nDATASET POLYDATA\n", header);
  fmt::format_to(it, "POINTS {} double\n", mesh.points.size());
  for (const auto& p : mesh.points) fmt::format_to(it, "{} {} {}\n", p.x(), p.y(), p.z());
  fmt::format_to(it, "POLYGONS {} {}\n", mesh.quads.size(), mesh.quads.size() * 5);
  for (const auto& q : mesh.quads) fmt::format_to(it, "4 {} {} {} {}\n", q[0], q[1], q[2], q[3]);
  if (!mesh.point_scalars.empty() || !mesh.point_vectors.empty()) {
    fmt::format_to(it, "POINT_DATA {}\n", mesh.points.size());
    for (const auto& [name, values] : mesh.point_scalars) {
      fmt::format_to(it, "SCALARS {} double 1\nLOOKUP_TABLE default\n", name);
      for (const double v : values) fmt::format_to(it, "{}\n", v);
    }
    for (const auto& [name, values] : mesh.point_vectors) {
      fmt::format_to(it, "VECTORS {} double\n", name);
      for (const auto& v : values) fmt::format_to(it, "{} {} {}\n", v.x(), v.y(), v.z());
    }
  }
  if (!mesh.cell_scalars.empty()) {
    fmt::format_to(it, "CELL_DATA {}\n", mesh.quads.size());
    for (const auto& [name, values] : mesh.cell_scalars) {
      fmt::format_to(it, "SCALARS {} double 1\nLOOKUP_TABLE default\n", name);
      for (const double v : values) fmt::format_to(it, "{}\n", v);
    }
  }
  return fmt::to_string(out);
}

void write_vtk(const std::filesystem::path& path, const SurfaceMesh& mesh, std::string_view title) {
  write_file_atomically(path, format_vtk(mesh, title));
}

}  // namespace clothbench::harness
