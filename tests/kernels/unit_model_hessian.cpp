// The Newton solver's model Hessian (kernels/model_hessian.hpp): the exact second derivative
// of Phi where the model is exact; secants to where the last direction reaches, with a memory
// of earlier stiffness; bending at least its secant from zero curvature (along the turning
// vector only until the floor is released there); symmetric and positive
// definite on random states with ghosts; its sparse matrix equal to the matrix-free product;
// and contact stiffness wherever the last direction would make a contact, stored only there.
#include <gtest/gtest.h>

#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <span>
#include <utility>

#include "kernels/potential_elements.hpp"
#include "newton_fixtures.hpp"

namespace clothbench {
namespace {

/// The model stores its coefficients rounded to float: a stored coefficient is within one
/// rounding (2^-24 relative) of the double it was computed as, two after the memory's scaling;
/// float's epsilon (2^-23) covers both.
constexpr double kStored = std::numeric_limits<float>::epsilon();

using testing::dot;
using testing::grade_and_randomise;
using testing::graded_config;
using testing::ModelFixture;
using testing::newton_config;
using testing::random_free_vector;
using testing::small_drape;

/// A flat n x n sheet stretched by 2 % in both directions with two pinned corners: every edge
/// on its loading branch, every triple straight, no obstacle.
kernels::SimulationConfig stretched_flat_sheet(int n) {
  kernels::SimulationConfig c;
  c.cloth.particles_i = c.cloth.particles_j = n;
  c.cloth.block_size = 4;
  c.cloth.size_i = c.cloth.size_j = 0.1;
  c.cloth.origin = {-0.05, -0.05, 0.0};
  c.cloth.pinned = {{0, 0}, {n - 1, n - 1}};
  c.cloth.initial_stretch = 0.02;
  c.time.step = 0.004;
  return newton_config(c);
}

/// Largest difference between the model's 3x3 blocks and central differences of the analytic
/// gradient, relative to each column's diagonal entry (at least 1 N/m), over every column.
double worst_block_difference(ModelFixture& f) {
  kernels::ClothState& st = f.sim.state();
  const std::vector<double> x0 = st.position;
  const double h = 1e-8;  // m, against a spacing of 1.7 cm
  double worst = 0.0;
  for (std::int64_t s = 0; s < f.sim.mesh().slot_count(); ++s) {
    if (!f.ctx.is_free(s)) continue;
    for (int k = 0; k < 3; ++k) {
      std::vector<double> unit(x0.size(), 0.0);
      unit[3 * s + k] = 1.0;
      const std::vector<double> model = f.product(unit);
      st.position = x0;
      st.position[3 * s + k] += h;
      const std::vector<double> plus = f.gradient();
      st.position = x0;
      st.position[3 * s + k] -= h;
      const std::vector<double> minus = f.gradient();
      st.position = x0;
      const double scale = std::max(1.0, std::abs(model[3 * s + k]));
      for (std::int64_t r = 0; r < f.sim.mesh().slot_count(); ++r) {
        if (!f.ctx.is_free(r)) continue;
        Eigen::Vector3d numeric, analytic;
        for (int c = 0; c < 3; ++c) {
          numeric[c] = (plus[3 * r + c] - minus[3 * r + c]) / (2.0 * h);
          analytic[c] = model[3 * r + c];
        }
        worst = std::max(worst, (numeric - analytic).norm() / scale);
      }
    }
  }
  return worst;
}

TEST(ModelHessian, EqualsTheFiniteDifferenceJacobianOfTheGradientWhereTheModelIsExact) {
  // Edges in tension on their loading branch; triples straight, first with no previous moment
  // (the bending plateau: no bending stiffness), then with one (the loading branch as soon as
  // they bend: the Gauss-Newton term is the exact second derivative at zero curvature).
  for (bool bent_before : {false, true}) {
    ModelFixture f(stretched_flat_sheet(7));
    kernels::ClothState& st = f.sim.state();
    if (bent_before) {
      for (double& m : st.triple_moment) m = 2.0 * f.sim.material().bending[0].hb;
    }
    f.assemble();
    st.target = st.position;  // the inertia term's Hessian does not depend on x~
    const std::vector<double> e_z = [&] {
      std::vector<double> v(st.position.size(), 0.0);
      v[3 * f.sim.mesh().slot(3, 3) + 2] = 1.0;
      return v;
    }();
    const double out_of_plane = f.product(e_z)[3 * f.sim.mesh().slot(3, 3) + 2];
    const double inertia = f.sim.mesh().mass[f.sim.mesh().slot(3, 3)] / (0.004 * 0.004);
    if (bent_before) {
      EXPECT_GT(out_of_plane, 1.5 * inertia) << "bending stiffness is in the model";
    }
    EXPECT_LT(worst_block_difference(f), 1e-6) << (bent_before ? "loading" : "plateau");
  }
}

TEST(ModelHessian, TakesTheSecantToWhereTheLastDirectionReachesAndRemembersItsStiffness) {
  constexpr double keep = kernels::ModelHessian::kStiffnessMemory;
  // Every edge of the 2 % stretched sheet on its plateau (previous force between the unloading
  // and loading curves): the tangent is 0. A last direction that stretches the sheet by 3 %
  // more takes every edge past the plateau: the model's axial stiffness is the secant there.
  // Then, with no direction, the next assembly keeps kStiffnessMemory of it, and a new step
  // reaches no further than the tangent but still remembers.
  ModelFixture f(stretched_flat_sheet(7));
  kernels::ClothState& st = f.sim.state();
  const kernels::ClothMesh& mesh = f.sim.mesh();
  auto x = [&](std::int64_t k) { return kernels::vec3(st.position, k); };
  std::vector<std::int64_t> edges;
  for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
    if (!mesh.edge_active[id]) continue;
    edges.push_back(id);
    const auto& band = f.sim.material().tensile[kernels::element_direction(id)];
    const double strain = kernels::edge_term(f.ctx, id, x).strain;
    st.edge_force[id] = 0.5 * (band.loading(strain) + band.unloading(strain));
  }
  ASSERT_FALSE(edges.empty());
  auto axial = [&](std::int64_t id) {  // u^T K_e u of the assembled model
    const Eigen::Vector3d e = x(mesh.next[id]) - x(kernels::element_slot(id));
    const Eigen::Vector3d u = e.normalized();
    return u.dot(f.objective.model_hessian()->edge_block(f.ctx, id) * u);
  };
  f.assemble();
  for (std::int64_t id : edges) {
    ASSERT_EQ(kernels::edge_term(f.ctx, id, x).slope, 0.0) << "edge " << id << " on its plateau";
    EXPECT_EQ(axial(id), 0.0) << "edge " << id;
  }
  std::fill(st.direction.begin(), st.direction.end(), 0.0);
  for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
    if (f.ctx.is_free(s)) kernels::vec3(st.direction, s) = 0.03 * x(s);  // centred sheet
  }
  auto reached = [&](std::int64_t k) -> Eigen::Vector3d {
    // The fixture's pins stay: only free particles move.
    return x(k) + kernels::vec3(st.direction, k);
  };
  std::vector<double> secant(static_cast<std::size_t>(2 * mesh.slot_count()), 0.0);
  for (std::int64_t id : edges) {
    const kernels::EdgeTerm now = kernels::edge_term(f.ctx, id, x);
    const kernels::EdgeTerm far = kernels::edge_term(f.ctx, id, reached);
    secant[id] = mesh.edge_width[id] * (far.force - now.force) / (far.strain - now.strain) /
                 mesh.edge_rest[id];
  }
  f.assemble();
  int past_plateau = 0;
  for (std::int64_t id : edges) {
    EXPECT_NEAR(axial(id), secant[id], kStored * secant[id]) << "edge " << id;
    if (secant[id] > 0.0) ++past_plateau;
  }
  EXPECT_GT(past_plateau, static_cast<int>(edges.size()) / 2);
  std::fill(st.direction.begin(), st.direction.end(), 0.0);
  f.assemble();
  for (std::int64_t id : edges) {
    EXPECT_NEAR(axial(id), keep * secant[id], kStored * secant[id]) << "edge " << id;
  }
  // A step's first assembly does not reach along the previous step's direction.
  for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
    if (f.ctx.is_free(s)) kernels::vec3(st.direction, s) = 0.03 * x(s);
  }
  f.run([&](kernels::LoopRunner& r) { f.objective.assemble_newton(r, /*new_step=*/true); });
  for (std::int64_t id : edges) {
    EXPECT_NEAR(axial(id), keep * keep * secant[id], 2 * kStored * secant[id]) << "edge " << id;
  }
}

TEST(ModelHessian, BendingStiffnessIsAtLeastTheSecantFromZeroCurvature) {
  // The sheet rolled onto a cylinder of radius 2 cm about the j axis (curvature 50 1/m, five
  // times kappa0) with every previous moment above the band: the triples along i are on their
  // loading branch, whose concave curve puts the tangent below the secant M / kappa. The
  // straight triples along j (previous moment, no curvature) take the slope at zero.
  ModelFixture f(stretched_flat_sheet(7));
  kernels::ClothState& st = f.sim.state();
  const kernels::ClothMesh& mesh = f.sim.mesh();
  const double radius = 0.02;
  for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
    const double arc = st.position[3 * s];
    st.position[3 * s] = radius * std::sin(arc / radius);
    st.position[3 * s + 2] = radius * (1.0 - std::cos(arc / radius));
  }
  for (double& m : st.triple_moment) m = 1e3 * f.sim.material().bending[0].hb;
  std::fill(st.direction.begin(), st.direction.end(), 0.0);  // no reach
  f.assemble();
  auto x = [&](std::int64_t k) { return kernels::vec3(st.position, k); };
  int bent = 0, straight = 0;
  for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
    if (!mesh.triple_active[id]) continue;
    const kernels::TripleTerm t = kernels::triple_term(f.ctx, id, x);
    const auto& band = f.sim.material().bending[kernels::element_direction(id)];
    const double at_zero = band.curves(std::numeric_limits<double>::min()).upper_slope;
    const double scale = mesh.triple_width(id) / mesh.triple_rest(id);
    const double model = f.objective.model_hessian()->bending_stiffness(id);
    if (t.curvature > 3.0 * band.kappa0) {
      ASSERT_NEAR(t.moment, band.loading(t.curvature), 1e-12 * t.moment) << "loading branch";
      ASSERT_LT(t.slope, 0.99 * t.moment / t.curvature) << "triple " << id;
      EXPECT_NEAR(model, scale * std::min(t.moment / t.curvature, at_zero), kStored * model)
          << "triple " << id;
      ++bent;
    } else if (t.curvature < 1e-6) {
      EXPECT_NEAR(model, scale * at_zero, 1e-6 * model) << "triple " << id;
      ++straight;
    }
  }
  EXPECT_GE(bent, 5 * 7);
  EXPECT_GE(straight, 7 * 5);
}

TEST(ModelHessian, ReleasedBendingFloorLeavesOnlyTheBandSlopeAlongTheTurningVector) {
  // The rolled sheet of the test above, assembled twice from the same state: with the floor
  // along the turning vector (isotropic, c J^T J) and without it. Across the turning vector both
  // keep c; along it the second keeps only the band's slope (the loading branch's tangent,
  // below M / kappa there), so the two matrices differ by exactly
  // sum over triples of (c_along - c) (J^T k)(J^T k)^T, k the unit turning vector.
  kernels::SimulationConfig config = stretched_flat_sheet(7);
  ModelFixture isotropic(config), released(config);
  for (ModelFixture* f : {&isotropic, &released}) {
    kernels::ClothState& st = f->sim.state();
    const double radius = 0.02;
    for (std::int64_t s = 0; s < f->sim.mesh().slot_count(); ++s) {
      const double arc = st.position[3 * s];
      st.position[3 * s] = radius * std::sin(arc / radius);
      st.position[3 * s + 2] = radius * (1.0 - std::cos(arc / radius));
    }
    for (double& m : st.triple_moment) m = 1e3 * f->sim.material().bending[0].hb;
    std::fill(st.direction.begin(), st.direction.end(), 0.0);  // no reach
  }
  isotropic.assemble(/*floor_along=*/true);
  released.assemble(/*floor_along=*/false);
  const kernels::ClothMesh& mesh = released.sim.mesh();
  const kernels::ClothState& st = released.sim.state();
  const kernels::ModelHessian& h0 = *isotropic.objective.model_hessian();
  const kernels::ModelHessian& h1 = *released.objective.model_hessian();
  auto x = [&](std::int64_t k) { return kernels::vec3(st.position, k); };
  std::int64_t unknowns = 0;
  const std::vector<std::int64_t> index = kernels::free_unknowns(released.ctx, &unknowns);
  Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(3 * unknowns, 3 * unknowns);
  int anisotropic = 0;
  for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
    if (!mesh.triple_active[id]) continue;
    EXPECT_EQ(h0.bending_stiffness(id), h1.bending_stiffness(id)) << "triple " << id;
    EXPECT_EQ(h0.bending_along(id), h0.bending_stiffness(id)) << "triple " << id;
    const kernels::TripleTerm t = kernels::triple_term(released.ctx, id, x);
    const double scale = mesh.triple_width(id) / mesh.triple_rest(id);
    if (t.curvature > 3.0 * released.sim.material().bending[0].kappa0) {
      EXPECT_NEAR(h1.bending_along(id), scale * t.slope, kStored * scale * t.slope) << id;
      EXPECT_LT(h1.bending_along(id), 0.99 * h1.bending_stiffness(id)) << "triple " << id;
      ++anisotropic;
    } else {
      EXPECT_EQ(h1.bending_along(id), h1.bending_stiffness(id)) << "straight triple " << id;
    }
    // J^T k by node (previous, centre, next): J_a = P1/|e1|, J_b = P2/|e2|, J_c = -(J_a + J_b).
    const std::int64_t node[3] = {mesh.prev[id], kernels::element_slot(id), mesh.next[id]};
    const Eigen::Vector3d e1 = x(node[1]) - x(node[0]), e2 = x(node[2]) - x(node[1]);
    const Eigen::Vector3d u1 = e1.normalized(), u2 = e2.normalized();
    const Eigen::Vector3d turning = u2 - u1;
    if (!(turning.norm() > 0.0)) continue;
    const Eigen::Vector3d k = turning.normalized();
    const Eigen::Vector3d ja = (k - u1 * u1.dot(k)) / e1.norm();
    const Eigen::Vector3d jb = (k - u2 * u2.dot(k)) / e2.norm();
    const Eigen::Vector3d w[3] = {ja, -(ja + jb), jb};
    const double difference = h1.bending_along(id) - h1.bending_stiffness(id);
    for (int r = 0; r < 3; ++r) {
      for (int q = 0; q < 3; ++q) {
        if (index[node[r]] < 0 || index[node[q]] < 0) continue;
        expected.block<3, 3>(3 * index[node[r]], 3 * index[node[q]]) +=
            difference * w[r] * w[q].transpose();
      }
    }
  }
  EXPECT_GE(anisotropic, 5 * 7);
  const Eigen::MatrixXd m0 = Eigen::MatrixXd(h0.matrix(isotropic.ctx, index, unknowns));
  const Eigen::MatrixXd m1 = Eigen::MatrixXd(h1.matrix(released.ctx, index, unknowns));
  // Bending is small beside the edges' stiffness: the difference must still be far above the
  // rounding the comparison allows.
  const double allowed = 1e-12 * m0.cwiseAbs().maxCoeff();
  ASSERT_GT(expected.cwiseAbs().maxCoeff(), 1e6 * allowed);
  EXPECT_LE((m1 - m0 - expected).cwiseAbs().maxCoeff(), allowed);
  // The matrix-free product and the V-cycle's rows agree with the matrix (the tests below run
  // both models on random states).
  for (unsigned seed : {7u, 8u}) {
    const std::vector<double> v = random_free_vector(released.sim, seed);
    const std::vector<double> hv = released.product(v);
    Eigen::VectorXd packed(3 * unknowns);
    for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
      if (index[s] >= 0) packed.segment<3>(3 * index[s]) = Eigen::Vector3d(&v[3 * s]);
    }
    const Eigen::VectorXd mv = m1 * packed;
    for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
      if (index[s] < 0) continue;
      EXPECT_LT((mv.segment<3>(3 * index[s]) - Eigen::Vector3d(&hv[3 * s])).norm(),
                1e-12 * mv.cwiseAbs().maxCoeff())
          << "slot " << s;
    }
  }
}

TEST(ModelHessian, IsSymmetricAndPositiveDefiniteOnRandomStatesWithGhosts) {
  const kernels::SimulationConfig c = graded_config();
  for (unsigned seed : {1u, 2u, 3u}) {
    ModelFixture f(c);
    grade_and_randomise(f, seed);
    if (HasFatalFailure()) return;
    f.assemble(/*floor_along=*/seed != 2u);  // seed 2: bending's floor released along k
    for (unsigned k = 0; k < 4; ++k) {
      const std::vector<double> x = random_free_vector(f.sim, 10 * seed + k);
      const std::vector<double> y = random_free_vector(f.sim, 100 * seed + k);
      const std::vector<double> hx = f.product(x), hy = f.product(y);
      const double xhy = dot(x, hy), yhx = dot(y, hx);
      EXPECT_NEAR(xhy, yhx, 1e-12 * std::sqrt(dot(x, hx) * dot(y, hy))) << "seed " << seed;
      EXPECT_GT(dot(x, hx), 0.0) << "seed " << seed;
    }
  }
}

TEST(ModelHessian, ItsSparseMatrixEqualsTheMatrixFreeProductWithGhostsAndPins) {
  // The explicit matrix (the multigrid's fine operator) against apply(), on graded meshes with
  // ghosts, random states (edges on every branch, bent triples) and a pinned corner.
  const kernels::SimulationConfig c = graded_config();
  for (unsigned seed : {4u, 5u}) {
    ModelFixture f(c);
    grade_and_randomise(f, seed);
    if (HasFatalFailure()) return;
    for (double& m : f.sim.state().triple_moment) m = 2.0 * f.sim.material().bending[0].hb;
    f.assemble(/*floor_along=*/seed == 4u);  // seed 5: bending's floor released along k
    std::int64_t unknowns = 0;
    const std::vector<std::int64_t> index = kernels::free_unknowns(f.ctx, &unknowns);
    ASSERT_GT(unknowns, 0);
    const Eigen::SparseMatrix<double> m =
        f.objective.model_hessian()->matrix(f.ctx, index, unknowns);
    EXPECT_LT((m - Eigen::SparseMatrix<double>(m.transpose())).norm(), 1e-12 * m.norm());
    for (unsigned k = 0; k < 3; ++k) {
      const std::vector<double> v = random_free_vector(f.sim, 1000 * seed + k);
      const std::vector<double> hv = f.product(v);
      Eigen::VectorXd packed(3 * unknowns);
      for (std::int64_t s = 0; s < f.sim.mesh().slot_count(); ++s) {
        if (index[s] >= 0) packed.segment<3>(3 * index[s]) = Eigen::Vector3d(&v[3 * s]);
      }
      const Eigen::VectorXd mv = m * packed;
      double worst = 0.0, scale = 0.0;
      for (std::int64_t s = 0; s < f.sim.mesh().slot_count(); ++s) {
        if (index[s] < 0) continue;
        worst = std::max(worst, (mv.segment<3>(3 * index[s]) - Eigen::Vector3d(&hv[3 * s])).norm());
        scale = std::max(scale, Eigen::Vector3d(&hv[3 * s]).norm());
      }
      EXPECT_LT(worst, 1e-12 * scale) << "seed " << seed;
    }
  }
}

TEST(ModelHessian, ItsProductNeedsNoWorkSpaceSoThePcgVectorsMayLiveInTheScratch) {
  // NewtonSystem keeps the inner PCG's search direction and product in the two halves of the
  // state's triple_scratch (and the residual in edge_scratch): H v must read neither. The
  // product with v and y there, and every other scratch entry NaN, has the bits of the
  // product with v and y apart, on a graded mesh with ghosts.
  ModelFixture f(graded_config());
  grade_and_randomise(f, 4u);
  if (HasFatalFailure()) return;
  f.assemble();
  const std::vector<double> v = random_free_vector(f.sim, 77);
  const std::vector<double> reference = f.product(v);
  kernels::ClothState& st = f.sim.state();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::fill(st.edge_scratch.begin(), st.edge_scratch.end(), nan);
  std::fill(st.triple_scratch.begin(), st.triple_scratch.end(), nan);
  const std::size_t n = v.size();
  ASSERT_GE(st.triple_scratch.size(), 2 * n);
  const std::span<double> vs(st.triple_scratch.data(), n), ys(st.triple_scratch.data() + n, n);
  std::copy(v.begin(), v.end(), vs.begin());
  f.run(
      [&](kernels::LoopRunner& r) { (void)f.objective.model_hessian()->apply(r, f.ctx, vs, ys); });
  int compared = 0;
  for (std::int64_t s = 0; s < f.sim.mesh().slot_count(); ++s) {
    if ((f.sim.mesh().flags[s] & kernels::kParticleActive) == 0) continue;
    for (int k = 0; k < 3; ++k) {
      const auto e = static_cast<std::size_t>(3 * s + k);
      ASSERT_EQ(ys[e], reference[e]) << "slot " << s << " component " << k;
      ++compared;
    }
  }
  EXPECT_GT(compared, 0);
  EXPECT_GT(f.sim.mesh().ghost_count(), 0);
}

TEST(ModelHessian, SeesTheContactsTheLastDirectionWouldMake) {
  // The small drape 3 mm above its obstacles, then a last direction that lowers the whole
  // cloth by 5 mm: a translation, so no element's strain or curvature changes, and only the
  // particles that x + p takes within the contact distance of an obstacle gain k n n^T there.
  ModelFixture f(newton_config(small_drape()));
  kernels::ClothState& st = f.sim.state();
  const kernels::ClothMesh& mesh = f.sim.mesh();
  const double d = f.sim.config().contact.distance;
  const Eigen::Vector3d lower(0.0, 0.0, -0.005), up = Eigen::Vector3d::UnitZ();
  std::fill(st.direction.begin(), st.direction.end(), 0.0);
  f.assemble();
  auto vertical = [&](std::int64_t s) {  // e_z^T H_ss e_z
    std::vector<double> v(st.position.size(), 0.0);
    kernels::vec3(v, s) = up;
    return kernels::vec3(f.product(v), s).z();
  };
  std::vector<std::int64_t> free;
  std::vector<double> before;
  for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
    if (!f.ctx.is_free(s)) continue;
    for (const kernels::Obstacle& o : f.sim.obstacles()) {
      Eigen::Vector3d n;
      ASSERT_GE(o.signed_distance(kernels::vec3(st.position, s), n), d) << "no contact yet";
    }
    free.push_back(s);
    before.push_back(vertical(s));
  }
  // Only a particle in contact has a block stored; every other one's is m / dt^2 I.
  const kernels::ModelHessian& model = *f.objective.model_hessian();
  EXPECT_EQ(model.contact_blocks(), 0);
  for (std::int64_t s : free) kernels::vec3(st.direction, s) = lower;
  f.assemble();
  int touching = 0, in_contact = 0;
  const double dt = f.ctx.dt();
  for (std::size_t k = 0; k < free.size(); ++k) {
    const std::int64_t s = free[k];
    double gained = 0.0;
    bool contact = false;
    for (const kernels::Obstacle& o : f.sim.obstacles()) {
      Eigen::Vector3d n;
      if (o.signed_distance(kernels::vec3(st.position, s) + lower, n) < d) {
        gained += f.ctx.contact_stiffness(s) * n.z() * n.z();
        ++touching;
        contact = true;
      }
    }
    in_contact += contact ? 1 : 0;
    EXPECT_NEAR(vertical(s) - before[k], gained, 1e-9 * (before[k] + gained)) << "particle " << s;
    const Eigen::Matrix3d own = model.particle_block(f.ctx, s);
    const double inertia = mesh.mass[s] / (dt * dt);
    EXPECT_NEAR(own(2, 2), inertia + gained, 1e-9 * (inertia + gained)) << "particle " << s;
    if (!contact) {
      EXPECT_EQ(own, Eigen::Matrix3d(Eigen::Matrix3d::Identity() * inertia));
    }
  }
  EXPECT_GE(touching, 5);
  EXPECT_LT(touching, static_cast<int>(free.size()));
  EXPECT_EQ(model.contact_blocks(), in_contact);
}

}  // namespace
}  // namespace clothbench
