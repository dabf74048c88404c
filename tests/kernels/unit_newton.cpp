// The Newton step solver (kernels/model_hessian.hpp, newton_minimiser.hpp): the model Hessian
// is the exact second derivative of Phi where the model is exact, symmetric and positive
// definite everywhere (ghosts included); the nonlinear smoothing's colours keep every element
// to one moving particle per colour and its moves only lower Phi; Newton (with and without the
// smoothing) reaches the state nonlinear CG reaches; and
// damping is a rate, so halving the step does not add damping.
#include <gtest/gtest.h>

#include <cmath>
#include <Eigen/SparseCore>
#include <algorithm>
#include <limits>
#include <random>
#include <tuple>
#include <utility>

#include "kernel_fixtures.hpp"
#include "kernels/potential_elements.hpp"
#include "kernels/potential_objective.hpp"

namespace clothbench {
namespace {

using kernels::Preconditioner;
using kernels::StepMethod;

/// The model Hessian of a Simulation's state, through a PotentialObjective of its own.
struct ModelFixture {
  explicit ModelFixture(const kernels::SimulationConfig& config)
      : sim(config),
        ctx{sim.mesh(), sim.material(), sim.obstacles(), sim.config(), sim.state()},
        objective(ctx) {}
  template <class F>
  void run(F&& f) {
    schedulers::OmpStaticDriver driver;
    kernels::LoopRunner r(driver, sim.mesh(), nullptr, kernels::Instrumentation::off, nullptr);
    f(r);
  }
  /// Ghosts on their midpoints, the per-step constants, then H at the current positions.
  void assemble() {
    schedulers::OmpStaticDriver driver;
    (void)sim.evaluate(driver, true);
    run([&](kernels::LoopRunner& r) {
      objective.prepare_history(r);
      objective.refresh_preconditioner(r);
    });
  }
  std::vector<double> product(std::vector<double> v) {
    std::vector<double> y(v.size(), 0.0);
    run([&](kernels::LoopRunner& r) { (void)objective.model_hessian()->apply(r, ctx, v, y); });
    return y;
  }
  /// The analytic gradient at the current positions.
  std::vector<double> gradient() {
    schedulers::OmpStaticDriver driver;
    (void)sim.evaluate(driver, true);
    return sim.state().gradient;
  }
  kernels::Simulation sim;
  kernels::StepContext ctx;
  kernels::PotentialObjective objective;
};

kernels::SimulationConfig newton_config(kernels::SimulationConfig c) {
  c.solver.method = StepMethod::newton;
  return c;
}

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

double dot(const std::vector<double>& a, const std::vector<double>& b) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) sum += a[i] * b[i];
  return sum;
}

std::vector<double> random_free_vector(const kernels::Simulation& sim, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<double> v(sim.state().position.size(), 0.0);
  const kernels::StepContext ctx{sim.mesh(), sim.material(), sim.obstacles(), sim.config(),
                                 const_cast<kernels::ClothState&>(sim.state())};
  for (std::int64_t s = 0; s < sim.mesh().slot_count(); ++s) {
    if (!ctx.is_free(s)) continue;
    for (int k = 0; k < 3; ++k) v[3 * s + k] = unit(rng);
  }
  return v;
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
    EXPECT_NEAR(axial(id), secant[id], 1e-9 * secant[id]) << "edge " << id;
    if (secant[id] > 0.0) ++past_plateau;
  }
  EXPECT_GT(past_plateau, static_cast<int>(edges.size()) / 2);
  std::fill(st.direction.begin(), st.direction.end(), 0.0);
  f.assemble();
  for (std::int64_t id : edges) {
    EXPECT_NEAR(axial(id), keep * secant[id], 1e-9 * secant[id]) << "edge " << id;
  }
  // A step's first assembly does not reach along the previous step's direction.
  for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
    if (f.ctx.is_free(s)) kernels::vec3(st.direction, s) = 0.03 * x(s);
  }
  f.run([&](kernels::LoopRunner& r) { f.objective.assemble_newton(r, /*new_step=*/true); });
  for (std::int64_t id : edges) {
    EXPECT_NEAR(axial(id), keep * keep * secant[id], 1e-9 * secant[id]) << "edge " << id;
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
    const double scale = mesh.triple_width[id] / mesh.triple_rest[id];
    const double model = f.objective.model_hessian()->bending_stiffness(id);
    if (t.curvature > 3.0 * band.kappa0) {
      ASSERT_NEAR(t.moment, band.loading(t.curvature), 1e-12 * t.moment) << "loading branch";
      ASSERT_LT(t.slope, 0.99 * t.moment / t.curvature) << "triple " << id;
      EXPECT_NEAR(model, scale * std::min(t.moment / t.curvature, at_zero), 1e-12 * model)
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

/// A 9 x 9 cloth for AMRC with L = 2, with pins and obstacles (testing::small_cloth).
kernels::SimulationConfig graded_config() {
  kernels::SimulationConfig c = newton_config(testing::small_cloth(true, true));
  c.cloth.particles_i = 9;
  c.cloth.particles_j = 9;
  c.amrc.enabled = true;
  c.amrc.levels = 2;
  return c;
}

/// Coarse cells beside fine ones (ghosts on the shared sides), then a random state of `seed`.
void grade_and_randomise(ModelFixture& f, unsigned seed) {
  kernels::AdaptiveMesh& tree = f.sim.begin_tree_edit();
  ASSERT_TRUE(tree.coarsen(kernels::TreeCell{1, 0, 0}, f.sim.mesh()));
  ASSERT_TRUE(tree.coarsen(kernels::TreeCell{1, 3, 2}, f.sim.mesh()));
  f.sim.end_tree_edit();
  ASSERT_GT(f.sim.mesh().ghost_count(), 0);
  testing::randomise_state(f.sim, seed);
}

TEST(ModelHessian, IsSymmetricAndPositiveDefiniteOnRandomStatesWithGhosts) {
  const kernels::SimulationConfig c = graded_config();
  for (unsigned seed : {1u, 2u, 3u}) {
    ModelFixture f(c);
    grade_and_randomise(f, seed);
    if (HasFatalFailure()) return;
    f.assemble();
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
    f.assemble();
    std::int64_t unknowns = 0;
    const std::vector<std::int64_t> index = kernels::free_unknowns(f.ctx, &unknowns);
    ASSERT_GT(unknowns, 0);
    const Eigen::SparseMatrix<double> m = f.objective.model_hessian()->matrix(f.ctx, index, unknowns);
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

/// A 13 x 13 cloth falling onto a sphere and a box from 3 mm above them.
kernels::SimulationConfig small_drape() {
  kernels::SimulationConfig c = testing::small_cloth(true, false);
  c.cloth.particles_i = c.cloth.particles_j = 13;
  c.cloth.initial_crumple = 0.0;
  c.cloth.origin = {-0.1, -0.1, 0.0065};  // 3 mm above the sphere: contact from step 5
  c.time.step = 0.004;
  c.solver.tolerance = 1e-5;
  c.solver.max_iterations = 3000;
  c.solver.max_newton_iterations = 60;
  c.solver.max_linear_iterations = 500;
  c.solver.reject_residual = 1e300;
  return c;
}

/// The free particles that move a node: itself, or a ghost's parents (recursively).
void owners_of(const kernels::ClothMesh& mesh, std::int64_t k, std::vector<std::int64_t>& out) {
  const int d = kernels::ghost_direction(mesh.flags[k]);
  if (d < 0) {
    out.push_back(k);
    return;
  }
  const std::int64_t id = kernels::element_id(k, d);
  owners_of(mesh, mesh.prev[id], out);
  owners_of(mesh, mesh.next[id], out);
}

/// Every element's nodes, ghosts resolved into the particles that move them: no two of one
/// colour (else two threads would change one element's energy at once); every free particle
/// and only those coloured.
void expect_valid_colouring(ModelFixture& f) {
  const kernels::ClothMesh& mesh = f.sim.mesh();
  const std::vector<int>& colour = f.objective.smoothing_colours();
  ASSERT_EQ(colour.size(), static_cast<std::size_t>(mesh.slot_count()));
  int elements = 0;
  for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
    std::vector<std::int64_t> nodes;
    const std::int64_t slot = kernels::element_slot(id);
    if (mesh.edge_active[id]) nodes = {slot, mesh.next[id]};
    if (mesh.triple_active[id]) nodes = {mesh.prev[id], slot, mesh.next[id]};
    if (nodes.empty()) continue;
    std::vector<std::int64_t> owners;
    for (std::int64_t k : nodes) owners_of(mesh, k, owners);
    std::sort(owners.begin(), owners.end());
    owners.erase(std::unique(owners.begin(), owners.end()), owners.end());
    for (std::size_t a = 0; a < owners.size(); ++a) {
      for (std::size_t b = a + 1; b < owners.size(); ++b) {
        if (colour[owners[a]] < 0 || colour[owners[b]] < 0) continue;
        EXPECT_NE(colour[owners[a]], colour[owners[b]])
            << "element " << id << " moves with slots " << owners[a] << " and " << owners[b];
      }
    }
    ++elements;
  }
  EXPECT_GT(elements, 0);
  EXPECT_GE(f.objective.smoothing_colour_count(), 3u);
  for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
    EXPECT_EQ(colour[s] >= 0, f.ctx.is_free(s)) << "slot " << s;
  }
}

TEST(NonlinearSmoothing, NoElementMovesWithTwoParticlesOfOneColourAndPhiOnlyFalls) {
  kernels::SimulationConfig c = graded_config();
  c.solver.smoothing_sweeps = 3;
  for (unsigned seed : {1u, 2u, 3u}) {
    ModelFixture f(c);
    grade_and_randomise(f, seed);
    if (HasFatalFailure()) return;
    f.assemble();
    kernels::Evaluation before, after;
    std::int64_t moved = 0;
    f.run([&](kernels::LoopRunner& r) {
      before = f.objective.evaluate(r);
      f.objective.colour_for_smoothing(r);
      moved = f.objective.smooth(r, 3, 1e-6);
      after = f.objective.evaluate(r);
    });
    expect_valid_colouring(f);
    EXPECT_GT(moved, 0) << "seed " << seed;
    EXPECT_LT(after.value, before.value) << "seed " << seed;
    EXPECT_LT(after.cost, before.cost) << "seed " << seed << ": the residual falls too";
  }
}

TEST(NonlinearSmoothing, TheColouringIsKeptWhileTheMeshIsUnchangedAndMadeAgainAfterAnEdit) {
  kernels::SimulationConfig c = graded_config();
  c.solver.smoothing_sweeps = 3;
  ModelFixture f(c);
  f.run([&](kernels::LoopRunner& r) { f.objective.colour_for_smoothing(r); });
  expect_valid_colouring(f);  // the uniform mesh
  const std::vector<int> uniform = f.objective.smoothing_colours();
  testing::randomise_state(f.sim, 4);  // positions do not change the topology
  f.run([&](kernels::LoopRunner& r) { f.objective.colour_for_smoothing(r); });
  EXPECT_EQ(f.objective.smoothing_colours(), uniform);
  grade_and_randomise(f, 5);  // an AMRC edit: inactive slots, ghosts
  if (HasFatalFailure()) return;
  f.run([&](kernels::LoopRunner& r) { f.objective.colour_for_smoothing(r); });
  expect_valid_colouring(f);
  EXPECT_NE(f.objective.smoothing_colours(), uniform);
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
  for (std::int64_t s : free) kernels::vec3(st.direction, s) = lower;
  f.assemble();
  int touching = 0;
  for (std::size_t k = 0; k < free.size(); ++k) {
    const std::int64_t s = free[k];
    double gained = 0.0;
    for (const kernels::Obstacle& o : f.sim.obstacles()) {
      Eigen::Vector3d n;
      if (o.signed_distance(kernels::vec3(st.position, s) + lower, n) < d) {
        gained += f.ctx.contact_stiffness(s) * n.z() * n.z();
        ++touching;
      }
    }
    EXPECT_NEAR(vertical(s) - before[k], gained, 1e-9 * (before[k] + gained)) << "particle " << s;
  }
  EXPECT_GE(touching, 5);
  EXPECT_LT(touching, static_cast<int>(free.size()));
}

TEST(NewtonMinimiser, ReachesTheStateNonlinearCgReaches) {
  kernels::SimulationConfig cg = small_drape();
  kernels::SimulationConfig newton = newton_config(cg);
  // Nonlinear CG has no multigrid: Newton-multigrid is compared with CG and line solves.
  // The last pairs: Newton with nonlinear smoothing after each line search, and without the
  // model's refinement along each direction (-1: the default, one).
  const std::tuple<Preconditioner, Preconditioner, int, int> pairs[] = {
      {Preconditioner::block_jacobi, Preconditioner::block_jacobi, 0, -1},
      {Preconditioner::line_solves, Preconditioner::line_solves, 0, -1},
      {Preconditioner::line_solves, Preconditioner::multigrid, 0, -1},
      {Preconditioner::line_solves, Preconditioner::line_solves, 3, -1},
      {Preconditioner::line_solves, Preconditioner::line_solves, 3, 0}};
  for (const auto& [pc, p, sweeps, refinements] : pairs) {
    cg.solver.preconditioner = pc;
    newton.solver.preconditioner = p;
    newton.solver.smoothing_sweeps = sweeps;
    newton.solver.model_refinements = refinements;
    kernels::Simulation a(cg), b(newton);
    schedulers::OmpStaticDriver driver;
    int newton_iterations = 0, linear_iterations = 0;
    for (int step = 0; step < 10; ++step) {
      const kernels::StepReport ra = a.step(driver), rb = b.step(driver);
      // Nonlinear CG's line search can stall a little above the tolerance at contact onset.
      EXPECT_LE(kernels::MinimiserReport::rms(ra.minimiser.final), 1e-3) << "CG step " << ra.step;
      EXPECT_EQ(rb.minimiser.reason, kernels::StopReason::converged) << "Newton step " << rb.step;
      EXPECT_LE(kernels::MinimiserReport::rms(rb.minimiser.final), cg.solver.tolerance);
      newton_iterations += rb.minimiser.iterations;
      linear_iterations += rb.minimiser.linear_iterations;
    }
    EXPECT_GT(newton_iterations, 0);
    EXPECT_GE(linear_iterations, newton_iterations);
    double worst = 0.0;
    for (std::size_t i = 0; i < a.state().position.size(); ++i) {
      worst = std::max(worst, std::abs(a.state().position[i] - b.state().position[i]));
    }
    // Residuals of 1e-5 (Newton) to 1e-3 (CG) weights put a particle off the minimiser by
    // about r m g / (m / dt^2) <= 2e-7 m: far below the millimetres the cloth moved.
    EXPECT_LT(worst, 1e-6) << "m, preconditioner " << kernels::to_string(p);
    EXPECT_GT(std::abs(a.state().position[2] - cg.cloth.origin.z()), 1e-3) << "the cloth moved";
    EXPECT_GT(a.diagnostics().contact_support, 0.0) << "and touches the obstacles";
  }
}

TEST(NewtonMinimiser, AssemblesTheModelAgainAlongEachDirectionItsRefinementsAsk) {
  // Under the V-cycle every assembly is one factorisation: a step of N >= 1 Newton iterations
  // assembles at its start and before each later iteration (N), and again `refinements` times
  // after each direction; a step that converges at once assembles once.
  for (int refinements : {0, 1, 2}) {
    kernels::SimulationConfig c = newton_config(small_drape());
    c.solver.preconditioner = Preconditioner::vcycle;
    c.solver.model_refinements = refinements;
    kernels::Simulation sim(c);
    schedulers::OmpStaticDriver driver;
    std::int64_t expected = 0;
    int newton_iterations = 0;
    for (int step = 0; step < 8; ++step) {
      const kernels::StepReport r = sim.step(driver);
      ASSERT_EQ(r.sub_steps, 1);
      EXPECT_EQ(r.minimiser.reason, kernels::StopReason::converged) << "step " << r.step;
      const int n = r.minimiser.iterations;
      expected += n == 0 ? 1 : static_cast<std::int64_t>(n) * (1 + refinements);
      newton_iterations += n;
    }
    EXPECT_GT(newton_iterations, 8) << "the drape needs Newton iterations";
    EXPECT_EQ(sim.vcycle_work().factorisations, expected) << refinements << " refinements";
  }
}

/// A free-falling 5 x 5 cloth (no obstacle, no strain) with steps of dt and the damping of
/// 0.1 per 4 ms written for that step (the scene's damping is per step of its own length).
kernels::SimulationConfig damped_fall(double dt, StepMethod method) {
  kernels::SimulationConfig c;
  c.cloth.particles_i = c.cloth.particles_j = 5;
  c.cloth.block_size = 5;
  c.cloth.size_i = c.cloth.size_j = 0.1;
  c.time.step = dt;
  c.time.damping = 1.0 - std::pow(0.9, dt / 0.004);
  c.solver.method = method;
  c.solver.tolerance = 1e-9;
  c.solver.max_iterations = 200;
  return c;
}

/// Where particle (2, 2) is after `seconds` of steps of `dt`, and its vertical velocity (the
/// last step's displacement over dt).
struct Fall {
  double velocity = 0.0;
  double height = 0.0;
};
Fall fall(kernels::SimulationConfig c, double seconds, int halvings = 0) {
  if (halvings > 0) {  // every step rejected and redone as halves, `halvings` times
    c.solver.reject_residual = -1.0;
    c.solver.max_step_halvings = halvings;
  }
  kernels::Simulation sim(c);
  schedulers::OmpStaticDriver driver;
  const int steps = static_cast<int>(std::lround(seconds / c.time.step));
  const std::int64_t s = sim.mesh().slot(2, 2);
  double before = 0.0;
  for (int k = 0; k < steps; ++k) {
    before = sim.state().position[3 * s + 2];
    const kernels::StepReport r = sim.step(driver);
    EXPECT_EQ(r.sub_steps, 1 << halvings);
  }
  return {(sim.state().position[3 * s + 2] - before) / c.time.step, sim.state().position[3 * s + 2]};
}

TEST(Damping, IsARateSoHalvingTheStepDoesNotAddDamping) {
  for (StepMethod method : {StepMethod::nonlinear_cg, StepMethod::newton}) {
    const Fall coarse_fall = fall(damped_fall(0.004, method), 0.1);
    const Fall fine_fall = fall(damped_fall(0.002, method), 0.1);
    const double coarse = coarse_fall.velocity, fine = fine_fall.velocity;
    // v' = g - lambda v with lambda = -ln(0.9) / 4 ms: after 0.1 s close to g / lambda.
    const double lambda = -std::log(0.9) / 0.004, g = 9.80665;
    const double exact = -g / lambda * (1.0 - std::exp(-lambda * 0.1));
    // Backward Euler's error is O(lambda dt): a few per cent here, and halving dt halves it.
    EXPECT_NEAR(coarse, exact, 0.08 * std::abs(exact));
    EXPECT_NEAR(fine, exact, 0.04 * std::abs(exact));
    EXPECT_LT(std::abs(fine - exact), std::abs(coarse - exact));
    // Had a halved step been damped as a whole one (0.9 per 2 ms), the fine velocity would be
    // about half the coarse one.
    EXPECT_LT(std::abs(fine - coarse), 0.05 * std::abs(coarse));
    // Steps rejected and redone as two halves move exactly like steps of half the length.
    const Fall halved = fall(damped_fall(0.004, method), 0.1, 1);
    EXPECT_NEAR(halved.height, fine_fall.height, 1e-9) << "m";
    EXPECT_GT(std::abs(coarse_fall.height - fine_fall.height), 1e-5) << "m: dt matters";
  }
}

}  // namespace
}  // namespace clothbench
