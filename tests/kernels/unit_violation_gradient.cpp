// The `violation` formulation's gradient (MODEL.md 4A, 5): the analytic gradient with respect
// to every free unknown (positions, edge tensions, triple moments) against central finite
// differences of E, one weight at a time and all together, with obstacle supports active
// (two obstacles on some particles, curved normals); the numeric (local-cost) gradient mode
// against the analytic one; the Simulation wiring; bit-identical evaluation across thread
// counts; and a short CG run that lowers E.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "kernels/simulation.hpp"
#include "kernels/violation_elements.hpp"
#include "kernels/violation_objective.hpp"
#include "schedulers/static_driver.hpp"

namespace clothbench::kernels {
namespace {

constexpr double kDistance = 0.01;  // contact distance d, m

struct Weights {
  double newton, stretch, bend, contact;
};

/// 9 x 7 particles, 0.2 x 0.15 m (spacing 0.025 m), blocks of 4, two pinned corners far from
/// the obstacles; a sphere and a box top just below the middle of the sheet.
SimulationConfig make_config(const Weights& w, bool obstacles) {
  SimulationConfig c;
  c.cloth.particles_i = 9;
  c.cloth.particles_j = 7;
  c.cloth.size_i = 0.2;
  c.cloth.size_j = 0.15;
  c.cloth.origin = Eigen::Vector3d(-0.1, -0.075, 0.0);
  c.cloth.block_size = 4;
  c.cloth.pinned = {{0, 6}, {8, 6}};
  // A soft test fabric (Fm = 5 gf/cm, EMT 10-12 %): band forces at the random strains stay
  // within a few hundred times the particle weight, so E is small enough for finite
  // differences at 1e-6 of each unknown's scale to resolve.
  c.fabric.fm_gf_per_cm = 5.0;
  c.fabric.warp.emt_percent = 10.0;
  c.fabric.weft.emt_percent = 12.0;
  c.time.step = 0.01;
  c.contact.distance = kDistance;
  if (obstacles) {
    ObstacleConfig sphere;
    sphere.kind = ObstacleKind::sphere;
    sphere.radius = 0.1;
    sphere.center = Eigen::Vector3d(0.0, 0.0, -0.1 - 0.004);
    ObstacleConfig box;
    box.kind = ObstacleKind::box;
    box.half_extents = Eigen::Vector3d(0.045, 0.045, 0.05);
    box.center = Eigen::Vector3d(0.0, 0.0, -0.05 - 0.0055);
    c.obstacles = {sphere, box};
  }
  c.solver.formulation = Formulation::violation;
  c.solver.weight_newton = w.newton;
  c.solver.weight_stretch = w.stretch;
  c.solver.weight_bend = w.bend;
  c.solver.weight_contact = w.contact;
  c.solver.numeric_step = 1e-6;
  return c;
}

/// A force in one of the band's regimes (below, inside, above), at least `gap` from both
/// boundary curves so that finite differences never cross a kink of the violation.
double pick_force(const BandCurves& c, double gap, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<int> regimes{2};
  if (c.lower > 3.0 * gap) regimes.push_back(0);
  if (c.upper - c.lower > 3.0 * gap) regimes.push_back(1);
  switch (regimes[rng() % regimes.size()]) {
    case 0:
      return 0.5 * gap + unit(rng) * (c.lower - 2.5 * gap);
    case 1:
      return c.lower + gap + unit(rng) * (c.upper - c.lower - 2.0 * gap);
    default:
      return c.upper + gap + unit(rng) * 5.0 * gap;
  }
}

/// A Simulation holding the geometry plus a ViolationObjective the test drives itself.
struct Harness {
  SimulationConfig config;
  Simulation sim;
  StepContext ctx;
  ViolationObjective objective;
  schedulers::OmpStaticDriver driver;

  explicit Harness(const SimulationConfig& c, unsigned seed = 7)
      : config(c),
        sim(config),
        ctx{sim.mesh(), sim.material(), sim.obstacles(), config, sim.state()},
        objective(ctx) {
    randomise(seed);
  }

  /// Perturbed (0.5 mm in plane, 3 mm out of plane), 2 % stretched positions; a random
  /// inertial target; forces in every band regime.
  void randomise(unsigned seed) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    const ClothMesh& mesh = sim.mesh();
    ClothState& st = sim.state();
    for (int i = 0; i < mesh.size_i(); ++i) {
      for (int j = 0; j < mesh.size_j(); ++j) {
        const std::int64_t s = mesh.slot(i, j);
        const Eigen::Vector3d noise(unit(rng), unit(rng), unit(rng));
        const Eigen::Vector3d offset(unit(rng), unit(rng), unit(rng));
        auto x = vec3(st.position, s);
        x = config.cloth.origin +
            1.02 * Eigen::Vector3d(mesh.rest_coordinate(0, i), mesh.rest_coordinate(1, j), 0.0) +
            Eigen::Vector3d(0.0005, 0.0005, 0.003).cwiseProduct(noise);
        vec3(st.target, s) = x + 0.0005 * offset;
        vec3(st.step_start, s) = x;
      }
    }
    const ViolationScales& scales = objective.scales();
    auto xs = [&](std::int64_t k) { return vec3(st.position, k); };
    for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
      const int d = element_direction(id);
      if (mesh.edge_active[id]) {
        const double l = (xs(mesh.next[id]) - xs(element_slot(id))).norm();
        const BandCurves c = sim.material().tensile[d].curves(l / mesh.edge_rest[id] - 1.0);
        st.edge_force[id] = pick_force(c, 0.2 * scales.tension[d], rng);
      }
      if (mesh.triple_active[id]) {
        const Eigen::Vector3d xc = xs(element_slot(id));
        const double theta =
            turning_angle<double>(xc - xs(mesh.prev[id]), xs(mesh.next[id]) - xc).theta;
        const BandCurves c = sim.material().bending[d].curves(theta / mesh.triple_rest(id));
        st.triple_moment[id] = pick_force(c, 0.2 * scales.moment[d], rng);
      }
    }
  }

  Evaluation evaluate(int threads = 0) {
    Evaluation result;
    const int team = threads > 0 ? threads : omp_get_max_threads();
#pragma omp parallel num_threads(team)
    {
      LoopRunner run(driver, sim.mesh(), nullptr, Instrumentation::off, nullptr);
      const Evaluation e = objective.evaluate(run);
      if (omp_get_thread_num() == 0) result = e;
    }
    return result;
  }

  /// Describes every free particle / element within a kink-safe margin of a switch of E:
  /// contact distance, support on/off, strain 0 / EMT, bending unloading onset.
  std::string near_switches(int* supports_on = nullptr, int* double_supports = nullptr) {
    std::ostringstream out;
    const ClothMesh& mesh = sim.mesh();
    const ClothState& st = sim.state();
    auto x = [&](std::int64_t k) { return vec3(st.position, k); };
    auto t = [&](std::int64_t id) { return st.edge_force[id]; };
    auto m = [&](std::int64_t id) { return st.triple_moment[id]; };
    int on = 0, twice = 0;
    for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
      if (!ctx.is_free(s)) continue;
      Eigen::Vector3d r = newton_residual(ctx, s, x, t, m);
      int here = 0;
      for (const Obstacle& o : sim.obstacles()) {
        Eigen::Vector3d n;
        const double phi = o.signed_distance(x(s), n);
        if (std::abs(phi - kDistance) < 1e-5) out << "slot " << s << " at the contact distance\n";
        if (phi < kDistance) {
          const double lambda = n.dot(r);
          if (std::abs(lambda) < 1e-3 * mesh.mass[s] * 9.8) out << "slot " << s << " lambda ~ 0\n";
          if (lambda > 0.0) {
            r -= lambda * n;
            ++here;
          }
        }
      }
      on += here > 0;
      twice += here > 1;
    }
    for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
      const int d = element_direction(id);
      if (mesh.edge_active[id]) {
        const double eps = (x(mesh.next[id]) - x(element_slot(id))).norm() / mesh.edge_rest[id] - 1;
        const double emt = sim.material().tensile[d].emt;
        if (std::abs(eps) < 1e-4 || std::abs(eps - emt) < 1e-4) out << "edge " << id << " kink\n";
      }
      if (mesh.triple_active[id]) {
        const Eigen::Vector3d xc = x(element_slot(id));
        const double kappa =
            turning_angle<double>(xc - x(mesh.prev[id]), x(mesh.next[id]) - xc).theta /
            mesh.triple_rest(id);
        if (std::abs(kappa - sim.material().bending[d].unloading_onset) < 1e-2 || kappa < 1e-2) {
          out << "triple " << id << " kink\n";
        }
      }
    }
    if (supports_on != nullptr) *supports_on = on;
    if (double_supports != nullptr) *double_supports = twice;
    return out.str();
  }
};

/// Relative errors |g - g_fd| / |g| of the analytic gradient per group of unknowns.
struct GradientErrors {
  double positions = 0.0, tensions = 0.0, moments = 0.0;
  double position_norm = 0.0, tension_norm = 0.0, moment_norm = 0.0;
};

double relative(const std::vector<double>& a, const std::vector<double>& b, double* norm) {
  double diff = 0.0, size = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    diff += (a[k] - b[k]) * (a[k] - b[k]);
    size += a[k] * a[k];
  }
  *norm = std::sqrt(size);
  return size > 0.0 ? std::sqrt(diff / size) : std::sqrt(diff);
}

/// Central differences of E over all free unknowns: positions step 1e-6 of the spacing; forces
/// 1e-5 of their reference (E is piecewise quadratic in the forces, so the larger step has no
/// truncation error and stays far inside the 0.2-reference margins to the band curves).
GradientErrors finite_difference_check(Harness& h) {
  h.evaluate();
  ClothState& st = h.sim.state();
  const ClothMesh& mesh = h.sim.mesh();
  const ViolationState& vs = h.objective.violation_state();
  const ViolationScales& scales = h.objective.scales();
  std::vector<double> analytic_x, fd_x, analytic_t, fd_t, analytic_m, fd_m;
  std::vector<std::pair<double*, double>> unknowns_x;  // (value, step)
  for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
    if (!h.ctx.is_free(s)) continue;
    for (int k = 0; k < 3; ++k) {
      analytic_x.push_back(st.gradient[3 * s + k]);
      unknowns_x.push_back({&st.position[3 * s + k], 1e-6 * scales.length});
    }
  }
  std::vector<std::pair<double*, double>> unknowns_t, unknowns_m;
  for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
    if (mesh.edge_active[id]) {
      analytic_t.push_back(vs.edge_gradient[id]);
      unknowns_t.push_back({&st.edge_force[id], 1e-5 * scales.tension[element_direction(id)]});
    }
    if (mesh.triple_active[id]) {
      analytic_m.push_back(vs.triple_gradient[id]);
      unknowns_m.push_back({&st.triple_moment[id], 1e-5 * scales.moment[element_direction(id)]});
    }
  }
  auto differentiate = [&](const std::vector<std::pair<double*, double>>& unknowns,
                           std::vector<double>& out) {
    for (const auto& [value, step] : unknowns) {
      const double saved = *value, plus = saved + step, minus = saved - step;
      *value = plus;
      const double e_plus = h.evaluate().value;
      *value = minus;
      const double e_minus = h.evaluate().value;
      *value = saved;
      out.push_back((e_plus - e_minus) / (plus - minus));
    }
  };
  differentiate(unknowns_x, fd_x);
  differentiate(unknowns_t, fd_t);
  differentiate(unknowns_m, fd_m);
  GradientErrors e;
  e.positions = relative(analytic_x, fd_x, &e.position_norm);
  e.tensions = relative(analytic_t, fd_t, &e.tension_norm);
  e.moments = relative(analytic_m, fd_m, &e.moment_norm);
  return e;
}

void expect_gradient_matches(const Weights& w, bool obstacles, bool forces_matter) {
  Harness h(make_config(w, obstacles));
  ASSERT_EQ(h.near_switches(), "");
  const GradientErrors e = finite_difference_check(h);
  EXPECT_GT(e.position_norm, 0.0);
  EXPECT_LT(e.positions, 1e-6) << "|g_x| = " << e.position_norm;
  EXPECT_LT(e.tensions, 1e-6) << "|g_t| = " << e.tension_norm;
  EXPECT_LT(e.moments, 1e-6) << "|g_M| = " << e.moment_norm;
  if (forces_matter) {
    EXPECT_GT(e.tension_norm, 0.0);
    EXPECT_GT(e.moment_norm, 0.0);
  }
}

TEST(ViolationGradient, NewtonTermOnly) { expect_gradient_matches({1, 0, 0, 0}, false, true); }
TEST(ViolationGradient, StretchTermOnly) { expect_gradient_matches({0, 1, 0, 0}, false, false); }
TEST(ViolationGradient, BendTermOnly) { expect_gradient_matches({0, 0, 1, 0}, false, false); }
TEST(ViolationGradient, ContactTermOnly) { expect_gradient_matches({0, 0, 0, 1}, true, false); }
TEST(ViolationGradient, AllTermsNoObstacle) {
  expect_gradient_matches({1, 0.7, 1.3, 0.5}, false, true);
}

TEST(ViolationGradient, AllTermsWithActiveSupports) {
  Harness h(make_config({1, 0.7, 1.3, 0.5}, true));
  int supports = 0, doubles = 0;
  ASSERT_EQ(h.near_switches(&supports, &doubles), "");
  EXPECT_GE(supports, 3);  // the supports cancel outward residuals of several particles
  EXPECT_GE(doubles, 1);   // and both obstacles act on at least one particle, in order
  const GradientErrors e = finite_difference_check(h);
  EXPECT_LT(e.positions, 1e-6) << "|g_x| = " << e.position_norm;
  EXPECT_LT(e.tensions, 1e-6) << "|g_t| = " << e.tension_norm;
  EXPECT_LT(e.moments, 1e-6) << "|g_M| = " << e.moment_norm;
}

TEST(ViolationGradient, AllTermsWithExternalForcesAndAMovedObstacle) {
  Harness h(make_config({1, 0.7, 1.3, 0.5}, true));
  h.sim.move_obstacle(0, {0.0005, -0.0003, 0.0});  // sideways: the supports stay as they were
  h.sim.set_external_force(4, 3, {0.002, -0.001, 0.004});
  h.sim.set_external_force(6, 2, {0.0, 0.0, -0.003});
  h.sim.set_external_force(0, 6, {0.0, 0.0, 1.0});  // pinned: no effect
  int supports = 0;
  ASSERT_EQ(h.near_switches(&supports), "");
  EXPECT_GE(supports, 3);
  const GradientErrors e = finite_difference_check(h);
  EXPECT_LT(e.positions, 1e-6) << "|g_x| = " << e.position_norm;
  EXPECT_LT(e.tensions, 1e-6) << "|g_t| = " << e.tension_norm;
  EXPECT_LT(e.moments, 1e-6) << "|g_M| = " << e.moment_norm;
  // The force enters the residual of its particle only, as a load like gravity.
  auto x = [&](std::int64_t k) { return vec3(h.sim.state().position, k); };
  auto t = [&](std::int64_t id) { return h.sim.state().edge_force[id]; };
  auto m = [&](std::int64_t id) { return h.sim.state().triple_moment[id]; };
  const std::int64_t s = h.sim.mesh().slot(4, 3);
  const Eigen::Vector3d with = newton_residual(h.ctx, s, x, t, m);
  h.sim.clear_external_force(4, 3);
  const Eigen::Vector3d without = newton_residual(h.ctx, s, x, t, m);
  EXPECT_LT((without - with - Eigen::Vector3d(0.002, -0.001, 0.004)).norm(), 1e-15);
}

TEST(ViolationGradient, NumericModeMatchesAnalytic) {
  for (const bool obstacles : {false, true}) {
    Harness h(make_config({1, 0.7, 1.3, 0.5}, obstacles), 11);
    h.sim.set_external_force(4, 3, {0.002, -0.001, 0.004});
    ASSERT_EQ(h.near_switches(), "");
    const ViolationState& vs = h.objective.violation_state();
    h.config.solver.gradient = GradientMode::analytic;
    const Evaluation analytic_eval = h.evaluate();
    const std::vector<double> gx = h.sim.state().gradient, gt = vs.edge_gradient,
                              gm = vs.triple_gradient;
    h.config.solver.gradient = GradientMode::numeric;
    const Evaluation numeric_eval = h.evaluate();
    EXPECT_EQ(analytic_eval.value, numeric_eval.value);
    double norm = 0.0;
    EXPECT_LT(relative(gx, h.sim.state().gradient, &norm), 1e-6) << "obstacles " << obstacles;
    EXPECT_LT(relative(gt, vs.edge_gradient, &norm), 1e-6) << "obstacles " << obstacles;
    EXPECT_LT(relative(gm, vs.triple_gradient, &norm), 1e-6) << "obstacles " << obstacles;
  }
}

TEST(ViolationObjective, SimulationUsesItForTheViolationFormulation) {
  Harness h(make_config({1, 1, 1, 1}, true));
  const Evaluation own = h.evaluate();
  const Evaluation via_simulation = h.sim.evaluate(h.driver);
  EXPECT_EQ(own.value, via_simulation.value);
  EXPECT_EQ(own.residual_sq, via_simulation.residual_sq);
  EXPECT_EQ(own.cost, own.value);
  EXPECT_EQ(own.free_particles, 9 * 7 - 2);
  const auto& c = h.objective.components();
  EXPECT_DOUBLE_EQ(own.value, c.newton + c.stretch + c.bend + c.contact);
  EXPECT_EQ(own.residual_sq, c.newton);
}

TEST(ViolationObjective, EvaluationIsBitIdenticalAcrossThreadCounts) {
  Harness h(make_config({1, 1, 1, 1}, true));
  const Evaluation one = h.evaluate(1);
  const std::vector<double> g1 = h.sim.state().gradient;
  const std::vector<double> t1 = h.objective.violation_state().edge_gradient;
  const Evaluation three = h.evaluate(3);
  EXPECT_EQ(one.value, three.value);
  EXPECT_EQ(one.residual_max, three.residual_max);
  EXPECT_EQ(g1, h.sim.state().gradient);
  EXPECT_EQ(t1, h.objective.violation_state().edge_gradient);
}

TEST(ViolationObjective, StepsLowerTheCostAndKeepForcesAsState) {
  for (const bool preconditioned : {false, true}) {
    SimulationConfig c = make_config({1, 1, 1, 1}, true);
    c.solver.preconditioner =
        preconditioned ? kernels::Preconditioner::block_jacobi : kernels::Preconditioner::none;
    c.solver.max_iterations = 30;
    c.solver.tolerance = 1e-9;
    c.solver.reject_residual = 1e300;  // one attempt per step: this test is about CG alone
    Simulation sim(c);
    schedulers::OmpStaticDriver driver;
    for (int k = 0; k < 3; ++k) {
      const StepReport r = sim.step(driver);
      EXPECT_LT(r.minimiser.final.value, r.minimiser.initial.value) << "step " << k;
      EXPECT_TRUE(sim.diagnostics().finite);
    }
    // Forces are unknowns: after falling three steps the cloth carries tension somewhere.
    double largest = 0.0;
    for (double t : sim.state().edge_force) largest = std::max(largest, std::abs(t));
    EXPECT_GT(largest, 0.0) << "preconditioned " << preconditioned;
  }
}

}  // namespace
}  // namespace clothbench::kernels
