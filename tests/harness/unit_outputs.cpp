// Outputs: atomic file replacement, the legacy VTK writer and the cloth picture.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <system_error>

#include "harness/output/atomic_file.hpp"
#include "harness/output/vtk_writer.hpp"
#include "harness/report/sweep_plots.hpp"

namespace {

namespace fs = std::filesystem;
using clothbench::harness::SurfaceMesh;
using clothbench::harness::write_file_atomically;
using clothbench::harness::write_vtk;
using testing::HasSubstr;

// A fresh, empty directory per test, removed afterwards.
class OutputTest : public testing::Test {
 protected:
  void SetUp() override {
    const auto* info = testing::UnitTest::GetInstance()->current_test_info();
    directory_ = fs::temp_directory_path() /
                 (std::string("clothbench-") + info->name() + "-" + std::to_string(::getpid()));
    fs::remove_all(directory_);
    fs::create_directories(directory_);
  }
  void TearDown() override { fs::remove_all(directory_); }

  static std::string read(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream out;
    out << in.rdbuf();
    return out.str();
  }
  // Files in the directory other than `except` (temporary files left behind).
  std::vector<std::string> others(const fs::path& except) const {
    std::vector<std::string> names;
    for (const auto& entry : fs::directory_iterator(directory_)) {
      if (entry.path() != except) names.push_back(entry.path().filename().string());
    }
    return names;
  }

  fs::path directory_;
};

// A 3 x 3 grid of points (2 x 2 quads) with one field of each kind.
SurfaceMesh grid3x3() {
  SurfaceMesh mesh;
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i)
      mesh.points.emplace_back(0.1 * i, 0.1 * j, 0.01 * (i + j) + 1.0 / 3.0);
  }
  for (int j = 0; j < 2; ++j) {
    for (int i = 0; i < 2; ++i) {
      const int a = 3 * j + i;
      mesh.quads.push_back({a, a + 1, a + 4, a + 3});
    }
  }
  std::vector<double> height;
  std::vector<Eigen::Vector3d> velocity;
  for (const auto& p : mesh.points) {
    height.push_back(p.z());
    velocity.emplace_back(p.x(), -p.y(), 1e-300);
  }
  mesh.point_scalars.emplace_back("height", height);
  mesh.point_vectors.emplace_back("velocity", velocity);
  mesh.cell_scalars.emplace_back("cost", std::vector<double>{0.0, -1.5, 2e-17, 1e22});
  return mesh;
}

TEST_F(OutputTest, AtomicWriteCreatesParentsAndReplacesContent) {
  const fs::path file = directory_ / "a" / "b" / "out.txt";
  write_file_atomically(file, "first");
  EXPECT_EQ(read(file), "first");
  write_file_atomically(file, "second, longer");
  EXPECT_EQ(read(file), "second, longer");
  write_file_atomically(file, "");
  EXPECT_EQ(read(file), "");
  EXPECT_TRUE(others(directory_ / "a").empty());
  EXPECT_EQ(fs::directory_iterator(directory_ / "a" / "b")->path().filename().string(), "out.txt");
}

TEST_F(OutputTest, AtomicWriteFailureLeavesTheOldFileAndNoTemporary) {
  const fs::path file = directory_ / "result.json";
  write_file_atomically(file, "old content");
  // Make the write itself fail part-way: a file-size limit below the new content's size
  // (works as root too, unlike a read-only directory). SIGXFSZ would kill the process.
  rlimit saved{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &saved), 0);
  auto* previous = std::signal(SIGXFSZ, SIG_IGN);
  rlimit small = saved;
  small.rlim_cur = 4096;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  std::string message;
  try {
    write_file_atomically(file, std::string(1 << 20, 'x'));
  } catch (const std::system_error& error) {
    message = error.what();
  }
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &saved), 0);
  std::signal(SIGXFSZ, previous);
  EXPECT_THAT(message, HasSubstr(file.string()));
  EXPECT_EQ(read(file), "old content");
  EXPECT_TRUE(others(file).empty()) << "temporary file left behind";
}

TEST_F(OutputTest, AtomicWriteIntoAFileAsDirectoryNamesThePath) {
  const fs::path blocker = directory_ / "blocker";
  write_file_atomically(blocker, "x");
  const fs::path file = blocker / "sub" / "out.txt";
  try {
    write_file_atomically(file, "y");
    FAIL() << "wrote below a regular file";
  } catch (const std::system_error& error) {
    EXPECT_THAT(error.what(), HasSubstr(file.string()));
  }
  EXPECT_EQ(read(blocker), "x");
}

TEST_F(OutputTest, VtkGridRoundTrips) {
  const SurfaceMesh mesh = grid3x3();
  const fs::path file = directory_ / "grid.vtk";
  write_vtk(file, mesh, "grid\nwith a newline");
  std::istringstream in(read(file));
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "# vtk DataFile Version 3.0");
  std::getline(in, line);
  EXPECT_EQ(line, "grid with a newline");
  std::getline(in, line);
  EXPECT_EQ(line, "ASCII");
  std::getline(in, line);
  EXPECT_EQ(line, "DATASET POLYDATA");

  std::string word, type;
  std::size_t count = 0, size = 0;
  in >> word >> count >> type;
  EXPECT_EQ(word, "POINTS");
  EXPECT_EQ(count, 9u);
  EXPECT_EQ(type, "double");
  for (const auto& p : mesh.points) {
    double x, y, z;
    in >> x >> y >> z;
    EXPECT_EQ(x, p.x());  // round-trip precision: exact
    EXPECT_EQ(y, p.y());
    EXPECT_EQ(z, p.z());
  }
  in >> word >> count >> size;
  EXPECT_EQ(word, "POLYGONS");
  EXPECT_EQ(count, 4u);
  EXPECT_EQ(size, 20u);
  for (const auto& q : mesh.quads) {
    int n, a, b, c, d;
    in >> n >> a >> b >> c >> d;
    EXPECT_EQ(n, 4);
    EXPECT_EQ((std::array<std::int32_t, 4>{a, b, c, d}), q);
  }
  in >> word >> count;
  EXPECT_EQ(word, "POINT_DATA");
  EXPECT_EQ(count, 9u);
  std::string name, lookup, table;
  int components = 0;
  in >> word >> name >> type >> components >> lookup >> table;
  EXPECT_EQ(word + " " + name + " " + type, "SCALARS height double");
  EXPECT_EQ(components, 1);
  EXPECT_EQ(lookup + " " + table, "LOOKUP_TABLE default");
  for (const double h : mesh.point_scalars[0].second) {
    double v;
    in >> v;
    EXPECT_EQ(v, h);
  }
  in >> word >> name >> type;
  EXPECT_EQ(word + " " + name + " " + type, "VECTORS velocity double");
  for (const auto& expected : mesh.point_vectors[0].second) {
    double x, y, z;
    in >> x >> y >> z;
    EXPECT_EQ(Eigen::Vector3d(x, y, z), expected);
  }
  in >> word >> count;
  EXPECT_EQ(word, "CELL_DATA");
  EXPECT_EQ(count, 4u);
  in >> word >> name >> type >> components >> lookup >> table;
  EXPECT_EQ(word + " " + name, "SCALARS cost");
  for (const double c : mesh.cell_scalars[0].second) {
    double v;
    in >> v;
    EXPECT_EQ(v, c);
  }
  in >> word;
  EXPECT_TRUE(in.eof()) << "trailing content: " << word;
}

// write_vtk must throw invalid_argument mentioning every fragment and leave `file` as it was.
void expect_rejected(const fs::path& file, const SurfaceMesh& mesh,
                     std::vector<std::string> fragments) {
  try {
    write_vtk(file, mesh, "t");
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& error) {
    for (const auto& fragment : fragments) EXPECT_THAT(error.what(), HasSubstr(fragment));
  }
}

TEST_F(OutputTest, VtkRejectsNonFiniteValuesNamingFieldAndIndex) {
  const fs::path file = directory_ / "grid.vtk";
  write_file_atomically(file, "previous");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  {
    SurfaceMesh mesh = grid3x3();
    mesh.point_scalars[0].second[4] = nan;
    expect_rejected(file, mesh, {"'height'", "index 4"});
  }
  {
    SurfaceMesh mesh = grid3x3();
    mesh.point_vectors[0].second[7].y() = inf;
    expect_rejected(file, mesh, {"'velocity'", "index 7"});
  }
  {
    SurfaceMesh mesh = grid3x3();
    mesh.cell_scalars[0].second[3] = -inf;
    expect_rejected(file, mesh, {"'cost'", "index 3"});
  }
  {
    SurfaceMesh mesh = grid3x3();
    mesh.points[8].z() = nan;
    expect_rejected(file, mesh, {"'points'", "index 8"});
  }
  EXPECT_EQ(read(file), "previous");
  EXPECT_TRUE(others(file).empty());
}

TEST_F(OutputTest, VtkChecksLengthsIndicesAndNames) {
  const fs::path file = directory_ / "grid.vtk";
  {
    SurfaceMesh mesh = grid3x3();
    mesh.point_scalars[0].second.pop_back();
    expect_rejected(file, mesh, {"'height'", "8 values, expected 9"});
  }
  {
    SurfaceMesh mesh = grid3x3();
    mesh.cell_scalars[0].second.push_back(1.0);
    expect_rejected(file, mesh, {"'cost'", "5 values, expected 4"});
  }
  {
    SurfaceMesh mesh = grid3x3();
    mesh.quads[2][1] = 9;
    expect_rejected(file, mesh, {"quad 2", "point 9"});
  }
  {
    SurfaceMesh mesh = grid3x3();
    mesh.point_scalars[0].first = "two words";
    expect_rejected(file, mesh, {"'two words'"});
  }
  EXPECT_FALSE(fs::exists(file));
}

// The cloth picture picks its colour field and, for mesh levels, one colour per level with
// integer tics; with gnuplot present it also draws the PNG.
TEST_F(OutputTest, ClothPictureColoursMeshLevelsDiscretely) {
  SurfaceMesh mesh = grid3x3();
  EXPECT_EQ(clothbench::harness::cloth_colour_field(mesh), "");
  mesh.point_scalars.emplace_back("contact_force_N", std::vector<double>(9, 0.0));
  EXPECT_EQ(clothbench::harness::cloth_colour_field(mesh), "");
  mesh.point_scalars.back().second[4] = 0.5;
  EXPECT_EQ(clothbench::harness::cloth_colour_field(mesh), "contact_force_N");
  mesh.point_scalars.emplace_back("mesh_level", std::vector<double>{0, 0, 1, 0, 3, 1, 2, 2, 3});
  EXPECT_EQ(clothbench::harness::cloth_colour_field(mesh), "mesh_level");

  const auto outcome = clothbench::harness::plot_cloth(mesh, "levels", directory_);
  const std::string script = read(directory_ / "cloth.gp");
  EXPECT_THAT(script, HasSubstr("set cbrange [-0.5:3.5]"));
  EXPECT_THAT(script, HasSubstr("set palette maxcolors 4"));
  EXPECT_THAT(script, HasSubstr("mesh level (0 = finest)"));
  // cloth.dat: one 2 x 2 patch per quad, the level as the fourth column.
  const std::string data = read(directory_ / "cloth.dat");
  EXPECT_EQ(std::count(data.begin(), data.end(), '\n'), 4 * (4 + 1 + 2));
  if (clothbench::harness::gnuplot_available()) {
    EXPECT_TRUE(outcome.problems.empty()) << outcome.problems.front();
    EXPECT_TRUE(fs::exists(directory_ / "cloth.png"));
  }
}

}  // namespace
