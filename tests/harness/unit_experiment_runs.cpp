// The pieces of `clothbench experiment` that are pure functions: surface sampling and
// distance between grids of different sizes, and the Pareto front.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "harness/experiment/experiment_runs.hpp"

namespace {

using clothbench::harness::pareto_front;
using clothbench::harness::surface_error;
using clothbench::harness::SurfaceSample;

// A grid of n x n points on z = f(u, v) over the unit square.
template <class F>
SurfaceSample grid(int n, F f) {
  SurfaceSample s;
  s.size_i = s.size_j = n;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const double u = static_cast<double>(i) / (n - 1), v = static_cast<double>(j) / (n - 1);
      s.points.emplace_back(u, v, f(u, v));
    }
  }
  return s;
}

TEST(ExperimentRuns, BilinearSurfacesCompareExactlyAcrossGrids) {
  // A bilinear surface is reproduced exactly by any grid: zero distance between 5 x 5 and 9 x 9.
  auto bilinear = [](double u, double v) { return 0.3 + 0.2 * u - 0.1 * v + 0.5 * u * v; };
  const auto coarse = grid(5, bilinear), fine = grid(9, bilinear);
  const auto e = surface_error(coarse, fine);
  EXPECT_LT(e.rms, 1e-15);
  EXPECT_LT(e.max, 1e-15);
  EXPECT_NEAR(coarse.at(0.375, 0.625).z(), bilinear(0.375, 0.625), 1e-15);
}

TEST(ExperimentRuns, SurfaceErrorIsRmsAndMaxOverTheReferencePoints) {
  const auto flat = grid(3, [](double, double) { return 0.0; });
  auto bumped = flat;
  bumped.points[4].z() = 0.3;  // the centre point of 9
  const auto e = surface_error(bumped, flat);
  EXPECT_DOUBLE_EQ(e.max, 0.3);
  EXPECT_NEAR(e.rms, std::sqrt(0.09 / 9), 1e-15);
  // Sampled on a finer reference grid the bump is seen through bilinear interpolation.
  const auto fine = grid(5, [](double, double) { return 0.0; });
  const auto f = surface_error(bumped, fine);
  EXPECT_DOUBLE_EQ(f.max, 0.3);
  EXPECT_GT(f.rms, 0.0);
  EXPECT_LT(f.rms, e.max);
}

TEST(ExperimentRuns, ParetoFrontKeepsOnlyUndominatedPoints) {
  const std::vector<double> time = {1.0, 2.0, 3.0, 0.5, 2.5, NAN, 4.0};
  const std::vector<double> error = {5.0, 3.0, 3.5, 9.0, 1.0, 0.1, 1.0};
  // 3 (fastest), 0, 1, 4 (most accurate); 2 is beaten by 1, 6 by 4, 5 is not finite.
  EXPECT_EQ(pareto_front(time, error), (std::vector<std::size_t>{3, 0, 1, 4}));
  EXPECT_TRUE(pareto_front({}, {}).empty());
}

}  // namespace
