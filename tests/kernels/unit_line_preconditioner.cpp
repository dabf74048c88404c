// The line-solve preconditioner (kernels/line_preconditioner.hpp): its edge blocks are the
// stretch term's Hessian (checked against central differences of the analytic edge gradient on
// the loading, plateau and unloading branches), each direction's solve is the exact inverse of
// the modelled stiffness on each grid line, the mean of the two is
// symmetric and positive and zero off the unknowns, and - why it exists - linear CG on the
// modelled stiffness of a sheet in tension needs several times fewer iterations than with
// block Jacobi, a gap that widens with the mesh.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "kernel_fixtures.hpp"
#include "kernels/potential_elements.hpp"
#include "kernels/potential_objective.hpp"

namespace clothbench {
namespace {

using kernels::LinePreconditioner;

/// A flat n x n sheet with two pinned corners and the line solves on.
kernels::SimulationConfig stretched_sheet(int n) {
  kernels::SimulationConfig c;
  c.cloth.particles_i = c.cloth.particles_j = n;
  c.cloth.block_size = 8;
  c.cloth.size_i = c.cloth.size_j = 0.5;
  c.cloth.origin = {-0.25, -0.25, 0.0};
  c.cloth.pinned = {{0, 0}, {n - 1, n - 1}};
  c.time.step = 0.004;
  c.solver.preconditioner = kernels::Preconditioner::line_solves;
  return c;
}

/// A Simulation with its own PotentialObjective (line solves) whose begin_step has built the
/// blocks, with the sheet stretched by 2 % in both directions (every edge in tension).
struct Fixture {
  explicit Fixture(const kernels::SimulationConfig& config)
      : sim(config),
        ctx{sim.mesh(), sim.material(), sim.obstacles(), sim.config(), sim.state()},
        objective(ctx) {
    kernels::ClothState& st = sim.state();
    for (std::size_t i = 0; i < st.position.size(); ++i) {
      if (i % 3 != 2) st.position[i] *= 1.02;
    }
    st.target = st.position;
    st.step_start = st.position;
    run([&](kernels::LoopRunner& r) { objective.begin_step(r); });
  }
  template <class F>
  void run(F&& f) {
    schedulers::OmpStaticDriver driver;
    kernels::LoopRunner r(driver, sim.mesh(), nullptr, kernels::Instrumentation::off, nullptr);
    f(r);
  }
  /// z = P^-1 g through the preconditioner (every free slot).
  std::vector<double> apply(const std::vector<double>& g) {
    std::vector<double> z(g.size(), 0.0);
    run([&](kernels::LoopRunner& r) { lines().apply(r, ctx, g, z); });
    return z;
  }
  LinePreconditioner& lines() { return *objective.line_preconditioner(); }
  kernels::Simulation sim;
  kernels::StepContext ctx;
  kernels::PotentialObjective objective;
};

std::vector<double> random_free_vector(const kernels::StepContext& ctx, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<double> v(3 * static_cast<std::size_t>(ctx.mesh.slot_count()), 0.0);
  for (std::int64_t s = 0; s < ctx.mesh.slot_count(); ++s) {
    if (!ctx.is_free(s)) continue;
    for (int k = 0; k < 3; ++k) v[3 * s + k] = unit(rng);
  }
  return v;
}

double dot(const std::vector<double>& a, const std::vector<double>& b) {
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) sum += a[i] * b[i];
  return sum;
}

Eigen::Matrix3d load(const std::vector<double>& in, std::int64_t k) {
  const double* p = in.data() + 6 * k;
  Eigen::Matrix3d m;
  m << p[0], p[1], p[2], p[1], p[3], p[4], p[2], p[4], p[5];
  return m;
}

/// The stiffness the preconditioner models, over the free particles: the block-Jacobi blocks
/// on the diagonal and -K_e between the two ends of every edge; with `only_direction` >= 0
/// only the edges along that direction couple (each line's own matrix L_d).
std::vector<double> model_product(Fixture& f, const std::vector<double>& v,
                                  int only_direction = -1) {
  const kernels::ClothMesh& mesh = f.sim.mesh();
  const LinePreconditioner& lines = f.lines();
  std::vector<double> out(v.size(), 0.0);
  for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
    if (!f.ctx.is_free(s)) continue;
    kernels::vec3(out, s) += load(lines.diagonal_block, s) * kernels::vec3(v, s);
  }
  for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
    if (!mesh.edge_active[id]) continue;
    if (only_direction >= 0 && kernels::element_direction(id) != only_direction) continue;
    const std::int64_t a = kernels::element_slot(id), b = mesh.next[id];
    const Eigen::Matrix3d k = load(lines.edge_block, id);
    if (f.ctx.is_free(a) && f.ctx.is_free(b)) {
      kernels::vec3(out, a) -= k * kernels::vec3(v, b);
      kernels::vec3(out, b) -= k * kernels::vec3(v, a);
    }
  }
  return out;
}

/// Iterations of linear preconditioned CG on model_product x = b to a relative residual of
/// 1e-6, with `precondition` (z = P^-1 r).
template <class Precondition>
int linear_cg_iterations(Fixture& f, const std::vector<double>& b, Precondition&& precondition) {
  std::vector<double> x(b.size(), 0.0), r = b;
  std::vector<double> z = precondition(r), p = z;
  double rz = dot(r, z);
  const double stop = 1e-6 * std::sqrt(dot(b, b));
  for (int it = 1; it <= 20000; ++it) {
    const std::vector<double> q = model_product(f, p);
    const double alpha = rz / dot(p, q);
    for (std::size_t i = 0; i < x.size(); ++i) {
      x[i] += alpha * p[i];
      r[i] -= alpha * q[i];
    }
    if (std::sqrt(dot(r, r)) <= stop) return it;
    z = precondition(r);
    const double rz_new = dot(r, z);
    for (std::size_t i = 0; i < p.size(); ++i) p[i] = z[i] + rz_new / rz * p[i];
    rz = rz_new;
  }
  return 20001;
}

/// Gradient of edge `id`'s stretch energy w L Psi(eps) on its end b (the analytic one the
/// solver's gather uses: w t / l (x_b - x_a)), with end `moved` (0 = a, 1 = b) shifted by
/// `shift` and the previous force of the state held fixed.
Eigen::Vector3d edge_gradient_on_b(const kernels::StepContext& ctx, std::int64_t id, int moved,
                                   const Eigen::Vector3d& shift) {
  const std::int64_t a = kernels::element_slot(id), b = ctx.mesh.next[id];
  const std::int64_t target = moved == 0 ? a : b;
  auto x = [&](std::int64_t k) -> Eigen::Vector3d {
    const Eigen::Vector3d xk = kernels::vec3(ctx.state.position, k);
    return k == target ? Eigen::Vector3d(xk + shift) : xk;
  };
  const kernels::EdgeTerm term = kernels::edge_term(ctx, id, x);
  return term.force_density * (x(b) - x(a));
}

/// Checks every edge block of the line solves of `config` (a stretched_sheet(9)) against the
/// finite-difference Hessian of the stretch term.
void expect_edge_blocks_are_the_stretch_hessian(const kernels::SimulationConfig& config) {
  // The stiffness the line solves invert couples the ends of edge e by -K_e: K_e must be the
  // stretch energy's Hessian block d2E/dx_b2 = -d2E/dx_a dx_b. Measured here by central
  // differences (step 1e-6 of the edge length) of the analytic gradient, on a 9 x 9 sheet
  // stretched by 2 %, jiggled out of plane so that edges point every way, with each edge's
  // previous force chosen to put it on the loading branch, the plateau (force held: only
  // the tension across the edge stiffens it) or the unloading branch.
  Fixture f(config);
  const kernels::ClothMesh& mesh = f.sim.mesh();
  kernels::ClothState& st = f.sim.state();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const double h = mesh.spacing(0);
  for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
    if (!f.ctx.is_free(s)) continue;
    for (int k = 0; k < 3; ++k) st.position[3 * s + k] += 0.005 * h * unit(rng);
  }
  int regime_count[3] = {0, 0, 0};
  for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
    if (!mesh.edge_active[id]) continue;
    const double length = (kernels::vec3(st.position, mesh.next[id]) -
                           kernels::vec3(st.position, kernels::element_slot(id)))
                              .norm();
    const double strain = length / mesh.edge_rest[id] - 1.0;
    ASSERT_GT(strain, 0.0) << "edge " << id << " is not in tension";
    const kernels::BandCurves c =
        f.sim.material().tensile[kernels::element_direction(id)].curves(strain);
    ASSERT_LT(1.01 * c.lower, 0.99 * c.upper) << "edge " << id << ": band too thin";
    const int regime = static_cast<int>(id % 3);  // 0 loading, 1 plateau, 2 unloading
    st.edge_force[id] = regime == 0   ? 2.0 * c.upper
                        : regime == 1 ? 0.5 * (c.lower + c.upper)
                                      : 0.5 * c.lower;
    ++regime_count[regime];
  }
  // No last Newton direction and nothing remembered from the fixture's first assembly: the
  // model is the tangent (within a step it also reaches along the last direction and keeps a
  // share of earlier stiffness; unit_newton tests that).
  std::fill(st.direction.begin(), st.direction.end(), 0.0);
  if (kernels::ModelHessian* model = f.objective.model_hessian()) model->forget();
  f.run([&](kernels::LoopRunner& r) { f.objective.refresh_preconditioner(r); });

  // Relative tolerance of each block against its own norm. The across-edge part (tension / l)
  // is tens of times smaller than the along-edge part (slope / L) on the loading and unloading
  // branches, so it is compared on its own, relative to its own size: dropping or mis-scaling
  // it cannot hide below the along-edge part.
  constexpr double kTolerance = 1e-6;
  int checked = 0;
  for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
    if (!mesh.edge_active[id]) continue;
    const std::int64_t a = kernels::element_slot(id), b = mesh.next[id];
    const Eigen::Vector3d e = kernels::vec3(st.position, b) - kernels::vec3(st.position, a);
    const double step = 1e-6 * e.norm();
    Eigen::Matrix3d hessian_bb, hessian_ab;  // d2E/dx_b2 and d2E/dx_b dx_a by columns
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d shift = step * Eigen::Vector3d::Unit(k);
      hessian_bb.col(k) =
          (edge_gradient_on_b(f.ctx, id, 1, shift) - edge_gradient_on_b(f.ctx, id, 1, -shift)) /
          (2.0 * step);
      hessian_ab.col(k) =
          (edge_gradient_on_b(f.ctx, id, 0, shift) - edge_gradient_on_b(f.ctx, id, 0, -shift)) /
          (2.0 * step);
    }
    const Eigen::Matrix3d block = load(f.lines().edge_block, id);
    const Eigen::Vector3d u = e.normalized();
    const Eigen::Matrix3d across = Eigen::Matrix3d::Identity() - u * u.transpose();
    const double along_fd = u.dot(hessian_bb * u);
    EXPECT_NEAR(u.dot(block * u), along_fd, kTolerance * hessian_bb.norm())
        << "edge " << id << " (regime " << id % 3 << "): along-edge stiffness";
    const Eigen::Matrix3d across_fd = across * hessian_bb * across;
    EXPECT_LE((across * block * across - across_fd).norm(), kTolerance * across_fd.norm())
        << "edge " << id << " (regime " << id % 3 << "): across-edge stiffness\n"
        << across * block * across << "\nfinite differences\n"
        << across_fd;
    EXPECT_LE((block - hessian_bb).norm(), kTolerance * hessian_bb.norm())
        << "edge " << id << ": K_e against d2E/dx_b2";
    EXPECT_LE((block + hessian_ab).norm(), kTolerance * hessian_bb.norm())
        << "edge " << id << ": -K_e against d2E/dx_a dx_b";
    ++checked;
  }
  EXPECT_EQ(checked, 2 * 9 * 8);
  for (int regime = 0; regime < 3; ++regime) EXPECT_GT(regime_count[regime], 40);
}

TEST(LinePreconditioner, EdgeBlocksAreTheStretchHessianByFiniteDifferences) {
  expect_edge_blocks_are_the_stretch_hessian(stretched_sheet(9));
}

TEST(LinePreconditioner, NewtonsEdgeBlocksAreTheStretchHessianByFiniteDifferences) {
  // Under Newton the blocks come from the model Hessian's assembly instead (potential_newton.cpp).
  kernels::SimulationConfig newton = stretched_sheet(9);
  newton.solver.method = kernels::StepMethod::newton;
  expect_edge_blocks_are_the_stretch_hessian(newton);
}

TEST(LinePreconditioner, EachDirectionSolvesItsLinesExactly) {
  // z must equal (L_0^-1 g + L_1^-1 g) / 2 with each L_d (the modelled stiffness with only the
  // edges along d coupling) assembled densely and solved by Eigen.
  Fixture f(stretched_sheet(9));
  const kernels::ClothMesh& mesh = f.sim.mesh();
  const std::vector<double> g = random_free_vector(f.ctx, 3);
  std::vector<double> expected(g.size(), 0.0);
  for (int d = 0; d < 2; ++d) {
    // Dense L_d over all free particles (block diagonal over lines), solved with Eigen.
    std::vector<std::int64_t> unknowns;
    std::vector<int> index(static_cast<std::size_t>(mesh.slot_count()), -1);
    for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
      if (!f.ctx.is_free(s)) continue;
      index[s] = static_cast<int>(unknowns.size());
      unknowns.push_back(s);
    }
    const auto n = static_cast<Eigen::Index>(3 * unknowns.size());
    Eigen::MatrixXd l = Eigen::MatrixXd::Zero(n, n);
    for (std::size_t c = 0; c < 3 * unknowns.size(); ++c) {
      std::vector<double> e(g.size(), 0.0);
      e[3 * unknowns[c / 3] + c % 3] = 1.0;
      const std::vector<double> column = model_product(f, e, d);
      for (std::size_t r = 0; r < unknowns.size(); ++r) {
        for (int k = 0; k < 3; ++k) l(3 * r + k, c) = column[3 * unknowns[r] + k];
      }
    }
    Eigen::VectorXd rhs(n);
    for (std::size_t r = 0; r < unknowns.size(); ++r) {
      for (int k = 0; k < 3; ++k) rhs(3 * r + k) = g[3 * unknowns[r] + k];
    }
    const Eigen::VectorXd x = l.ldlt().solve(rhs);
    for (std::size_t r = 0; r < unknowns.size(); ++r) {
      for (int k = 0; k < 3; ++k) expected[3 * unknowns[r] + k] += 0.5 * x(3 * r + k);
    }
  }
  const std::vector<double> z = f.apply(g);
  double diff = 0.0, norm = 0.0;
  for (std::size_t i = 0; i < z.size(); ++i) {
    diff += (z[i] - expected[i]) * (z[i] - expected[i]);
    norm += expected[i] * expected[i];
  }
  EXPECT_LT(std::sqrt(diff / norm), 1e-10);
}

TEST(LinePreconditioner, TheKernelRefusesItWhereItHasNone) {
  kernels::SimulationConfig violation = stretched_sheet(9);
  violation.solver.formulation = kernels::Formulation::violation;
  EXPECT_THROW(kernels::Simulation{violation}, std::invalid_argument);
  EXPECT_NO_THROW(kernels::Simulation{stretched_sheet(9)});
}

TEST(LinePreconditioner, MemoryEstimateCoversItsArrays) {
  kernels::SimulationConfig block_jacobi = stretched_sheet(65);
  block_jacobi.solver.preconditioner = kernels::Preconditioner::block_jacobi;
  const kernels::SimulationConfig lines = stretched_sheet(65);
  EXPECT_EQ(kernels::estimate_memory_bytes(lines) - kernels::estimate_memory_bytes(block_jacobi),
            65u * 65u * LinePreconditioner::kBytesPerSlot);
  const kernels::Simulation with(lines), without(block_jacobi);
  EXPECT_GE(with.memory_bytes() - without.memory_bytes(),
            65u * 65u * LinePreconditioner::kBytesPerSlot);
  EXPECT_GE(kernels::estimate_memory_bytes(lines), with.memory_bytes());
}

TEST(LinePreconditioner, IsSymmetricPositiveAndZeroOffTheUnknowns) {
  Fixture f(stretched_sheet(33));
  const std::vector<double> u = random_free_vector(f.ctx, 1), v = random_free_vector(f.ctx, 2);
  const std::vector<double> pu = f.apply(u), pv = f.apply(v);
  EXPECT_NEAR(dot(u, pv), dot(v, pu), 1e-10 * std::abs(dot(u, pv)));
  EXPECT_GT(dot(u, pu), 0.0);
  EXPECT_GT(dot(v, pv), 0.0);
  for (std::int64_t s = 0; s < f.sim.mesh().slot_count(); ++s) {
    if (f.ctx.is_free(s)) continue;
    EXPECT_EQ(kernels::vec3(pu, s).norm(), 0.0) << "slot " << s << " is not an unknown";
  }
}

TEST(LinePreconditioner, LinearCgNeedsFarFewerIterationsThanBlockJacobi) {
  std::vector<int> jacobi, lines;
  const int sizes[] = {17, 33, 65};
  for (int n : sizes) {
    Fixture f(stretched_sheet(n));
    const std::vector<double> b = random_free_vector(f.ctx, 7);
    jacobi.push_back(linear_cg_iterations(f, b, [&](const std::vector<double>& r) {
      std::vector<double> z(r.size(), 0.0);
      for (std::int64_t s = 0; s < f.sim.mesh().slot_count(); ++s) {
        if (f.ctx.is_free(s)) {
          kernels::vec3(z, s) =
              kernels::apply_symmetric(f.sim.state().preconditioner, s, kernels::vec3(r, s));
        }
      }
      return z;
    }));
    lines.push_back(
        linear_cg_iterations(f, b, [&](const std::vector<double>& r) { return f.apply(r); }));
  }
  for (std::size_t k = 0; k < jacobi.size(); ++k) {
    std::printf("linear CG iterations, mesh %d: block Jacobi %d, line solves %d\n", sizes[k],
                jacobi[k], lines[k]);
  }
  // At every size the line solves need at most a quarter of block Jacobi's iterations, and the
  // gap widens with the mesh.
  for (std::size_t k = 0; k < jacobi.size(); ++k) EXPECT_LT(4 * lines[k], jacobi[k]);
  EXPECT_LT(double(lines[2]) / lines[0], double(jacobi[2]) / jacobi[0]);
}

}  // namespace
}  // namespace clothbench
