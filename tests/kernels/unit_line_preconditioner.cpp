// The line-solve preconditioner (kernels/line_preconditioner.hpp): each direction's solve is
// the exact inverse of the modelled stiffness on each grid line, the mean of the two is
// symmetric and positive and zero off the unknowns, and - why it exists - linear CG on the
// modelled stiffness of a sheet in tension needs several times fewer iterations than with
// block Jacobi, a gap that widens with the mesh.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>

#include "kernel_fixtures.hpp"
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
int linear_cg_iterations(Fixture& f, const std::vector<double>& b,
                         Precondition&& precondition) {
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
    lines.push_back(linear_cg_iterations(f, b, [&](const std::vector<double>& r) {
      return f.apply(r);
    }));
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
