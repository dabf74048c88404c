// The loader's start-inside-an-obstacle check (harness/scene/initial_overlap.hpp): the
// branch-and-bound search finds the same deepest particle as visiting every particle, for
// every obstacle kind, and the loader accepts a cloth that only touches an obstacle.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <limits>
#include <random>
#include <string>

#include "harness/scene/initial_overlap.hpp"
#include "harness/scene/scene.hpp"

namespace {

namespace fs = std::filesystem;
using clothbench::harness::parse_scene;
using clothbench::harness::SceneError;
using clothbench::harness::scene_detail::deepest_initial_overlap;
using clothbench::kernels::ClothConfig;
using clothbench::kernels::Obstacle;
using clothbench::kernels::ObstacleConfig;
using clothbench::kernels::ObstacleKind;
using testing::HasSubstr;
using testing::StartsWith;

const fs::path kPresets = fs::path(CLOTHBENCH_SOURCE_DIR) / "tests/data/scenes/presets.toml";

/// Start position of particle (i, j) displaced by t * initial_crumple along the normal.
Eigen::Vector3d start_position(const ClothConfig& c, int i, int j, double t) {
  const double scale = 1.0 + c.initial_stretch;
  const Eigen::Vector3d normal = c.axis_i.cross(c.axis_j).normalized();
  return c.origin +
         scale * (i * c.size_i / (c.particles_i - 1) * c.axis_i +
                  j * c.size_j / (c.particles_j - 1) * c.axis_j) +
         t * c.initial_crumple * normal;
}

/// Deepest signed distance over every particle, the crumple sampled at 401 points.
double brute_force_minimum(const ClothConfig& c, const Obstacle& obstacle) {
  double minimum = std::numeric_limits<double>::infinity();
  const int samples = c.initial_crumple > 0 ? 401 : 1;
  for (int i = 0; i < c.particles_i; ++i) {
    for (int j = 0; j < c.particles_j; ++j) {
      for (int s = 0; s < samples; ++s) {
        const double t = samples == 1 ? 0.0 : -1.0 + 2.0 * s / (samples - 1);
        minimum = std::min(minimum, obstacle.signed_distance(start_position(c, i, j, t)));
      }
    }
  }
  return minimum;
}

Eigen::Vector3d random_unit(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  Eigen::Vector3d v(normal(rng), normal(rng), normal(rng));
  return v.normalized();
}

TEST(InitialOverlap, AgreesWithVisitingEveryParticle) {
  std::mt19937_64 rng(20240611);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int overlapping = 0, clear = 0;
  for (int trial = 0; trial < 400; ++trial) {
    ClothConfig cloth;
    cloth.particles_i = 2 + static_cast<int>(unit(rng) * 30);
    cloth.particles_j = 2 + static_cast<int>(unit(rng) * 30);
    cloth.size_i = 0.2 + unit(rng);
    cloth.size_j = 0.2 + unit(rng);
    cloth.axis_i = random_unit(rng);
    cloth.axis_j = cloth.axis_i.cross(random_unit(rng)).normalized();
    cloth.origin = Eigen::Vector3d(unit(rng) - 1.0, unit(rng) - 1.0, unit(rng) - 1.0);
    cloth.initial_stretch = trial % 3 == 0 ? 0.2 * unit(rng) : 0.0;
    cloth.initial_crumple = trial % 4 == 0 ? 0.05 * unit(rng) : 0.0;

    ObstacleConfig config;
    config.kind = static_cast<ObstacleKind>(trial % 4);
    config.center = Eigen::Vector3d(unit(rng) - 0.5, unit(rng) - 0.5, unit(rng) - 0.5);
    config.normal = random_unit(rng);
    config.axis = random_unit(rng);
    config.half_extents =
        Eigen::Vector3d(0.05 + 0.5 * unit(rng), 0.05 + 0.5 * unit(rng), 0.05 + 0.5 * unit(rng));
    config.radius = 0.05 + 0.5 * unit(rng);
    config.half_length = 0.05 + 0.5 * unit(rng);
    const Obstacle obstacle(config);

    std::int64_t budget = std::int64_t{1} << 30;
    const auto found = deepest_initial_overlap(cloth, obstacle, budget);
    const double minimum = brute_force_minimum(cloth, obstacle);
    const std::string where = "trial " + std::to_string(trial);
    // The search stops refining at 0.1 % of the depth; sampling the crumple at 401 points
    // overestimates a minimum of the (1-Lipschitz) distance by at most crumple / 400.
    const double slack = 1e-9 + 1e-3 * std::abs(minimum) + 3e-3 * cloth.initial_crumple;
    if (minimum < -slack) {
      ++overlapping;
      ASSERT_TRUE(found.has_value()) << where << ": missed a particle " << -minimum << " m deep";
      EXPECT_TRUE(found->complete) << where;
      EXPECT_NEAR(found->depth, -minimum, slack) << where;
      // The reported particle really is that deep.
      double deepest = std::numeric_limits<double>::infinity();
      for (int s = 0; s <= 400; ++s) {
        const double t = cloth.initial_crumple > 0 ? -1.0 + s / 200.0 : 0.0;
        deepest = std::min(deepest,
                           obstacle.signed_distance(start_position(cloth, found->i, found->j, t)));
      }
      EXPECT_NEAR(-deepest, found->depth, slack) << where;
      EXPECT_LT((found->position - start_position(cloth, found->i, found->j, 0.0)).norm(), 1e-12)
          << where;
    } else if (minimum > slack) {
      ++clear;
      EXPECT_FALSE(found.has_value()) << where << ": reported " << found->depth << " m deep";
    }
  }
  EXPECT_GT(overlapping, 50);  // both outcomes are well represented
  EXPECT_GT(clear, 50);
}

TEST(InitialOverlap, HugeGridStaysWithinItsBudget) {
  ClothConfig cloth;
  cloth.particles_i = cloth.particles_j = 1'000'000;
  cloth.size_i = cloth.size_j = 1.0;
  cloth.origin = Eigen::Vector3d(-0.5, -0.5, 0.0);
  ObstacleConfig sphere;
  sphere.kind = ObstacleKind::sphere;
  sphere.center = Eigen::Vector3d(0.1234, -0.321, 0.0);
  sphere.radius = 0.3;
  std::int64_t budget = std::int64_t{1} << 18;
  const auto found = deepest_initial_overlap(cloth, Obstacle(sphere), budget);
  ASSERT_TRUE(found.has_value());
  EXPECT_NEAR(found->depth, 0.3, 1e-3 * 0.3);  // the particle nearest the centre
  EXPECT_TRUE(found->complete);

  // Every particle inside a box that holds the whole cloth: still bounded.
  ObstacleConfig box;
  box.kind = ObstacleKind::box;
  box.half_extents = Eigen::Vector3d(2.0, 2.0, 0.5);
  budget = std::int64_t{1} << 18;
  const auto inside = deepest_initial_overlap(cloth, Obstacle(box), budget);
  ASSERT_TRUE(inside.has_value());
  EXPECT_NEAR(inside->depth, 0.5, 1e-3 * 0.5);
}

TEST(InitialOverlap, LoaderAcceptsACloth) {
  // Lying exactly on a box top (touching) and exactly on a plane both load.
  EXPECT_NO_THROW((void)parse_scene(
      "[cloth]\nparticles = [9, 9]\nsize_m = [0.2, 0.2]\norigin_m = [-0.1, -0.1, 0.25]\n"
      "[[obstacle]]\nkind = \"box\"\ncenter_m = [0, 0, 0.125]\nhalf_extents_m = [0.25, 0.25, "
      "0.125]\n"
      "[[obstacle]]\nkind = \"plane\"\ncenter_m = [0, 0, 0.25]\n",
      "touching.toml", kPresets));
}

TEST(InitialOverlap, LoaderRejectsAClothOnTheWrongSideOfAPlaneOrThroughACylinder) {
  try {
    (void)parse_scene(
        "[cloth]\nparticles = [3, 3]\norigin_m = [0, 0, 1]\n\n"
        "[[obstacle]]\nkind = \"plane\"\ncenter_m = [0, 0, 2]\n",
        "below.toml", kPresets);
    FAIL() << "a cloth 1 m below a floor loaded";
  } catch (const SceneError& error) {
    EXPECT_THAT(error.what(), StartsWith("below.toml:5:1: [obstacle[0]] center_m: the cloth starts "
                                         "inside this plane: particle (0, 0) at (0, 0, 1) m is 1 m "
                                         "deep"));
  }
  try {
    (void)parse_scene(
        "[cloth]\nparticles = [11, 11]\norigin_m = [-0.5, -0.5, 0]\n"
        "[[obstacle]]\nkind = \"cylinder\"\naxis = [1, 0, 0]\nradius_m = 0.05\n"
        "half_length_m = 2\n",
        "rod.toml", kPresets);
    FAIL() << "a rod through the cloth loaded";
  } catch (const SceneError& error) {
    EXPECT_THAT(error.what(), StartsWith("rod.toml:4:1: [obstacle[0]] center_m: the cloth starts "
                                         "inside this cylinder: particle ("));
    EXPECT_THAT(error.what(), HasSubstr(" m is 0.05 m deep"));
  }
}

}  // namespace
