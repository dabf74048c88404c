// The multigrid preconditioner of Newton's inner PCG (kernels/multigrid_preconditioner.hpp):
// its prolongation reproduces linear fields across ghosts and pins, its coarse operator is
// P^T H P, the cycle is symmetric positive definite, and PCG iterations with it stay flat as
// the mesh is refined where the line solves alone grow.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <stdexcept>
#include <vector>

#include "newton_fixtures.hpp"
#include "tests/harness/sanitizer_build.hpp"

namespace clothbench {
namespace {

using kernels::Preconditioner;
using testing::dot;

/// A flat n x n sheet stretched by 2 % with two pinned corners and bent triples (the bending
/// band on its loading branch): the linear model of the solver tests.
kernels::SimulationConfig stretched_sheet(int n, Preconditioner preconditioner) {
  kernels::SimulationConfig c;
  c.cloth.particles_i = c.cloth.particles_j = n;
  c.cloth.block_size = 8;
  c.cloth.size_i = c.cloth.size_j = 0.5;
  c.cloth.origin = {-0.25, -0.25, 0.0};
  c.cloth.pinned = {{0, 0}, {n - 1, n - 1}};
  c.time.step = 0.004;
  c.solver.method = kernels::StepMethod::newton;
  c.solver.preconditioner = preconditioner;
  c.solver.vcycle_after = 0;  // the V-cycle factorised with every model
  return c;
}

/// A graded AMRC cloth (coarse cells beside fine ones: ghosts) with pins, obstacles in contact
/// and a random state.
kernels::SimulationConfig graded_cloth(bool pins,
                                       Preconditioner preconditioner = Preconditioner::multigrid) {
  kernels::SimulationConfig c = testing::small_cloth(true, pins);
  c.cloth.particles_i = 17;
  c.cloth.particles_j = 9;
  c.cloth.size_i = 0.4;
  c.amrc.enabled = true;
  c.amrc.levels = 3;
  c.solver.method = kernels::StepMethod::newton;
  c.solver.preconditioner = preconditioner;
  c.solver.vcycle_after = 0;  // the V-cycle factorised with every model
  return c;
}

/// The model Hessian's fixture (newton_fixtures.hpp) with a graded tree and the
/// preconditioner applied.
struct Fixture : testing::ModelFixture {
  using ModelFixture::ModelFixture;
  /// Leaves of 1, 2 and 4 finest cells side by side (ghosts on their shared sides): two cells
  /// of 2 x 2, and a cell of 4 x 4 at the end of the sheet with cells of 2 x 2 around it.
  void grade() {
    kernels::AdaptiveMesh& tree = sim.begin_tree_edit();
    for (const kernels::TreeCell c :
         {kernels::TreeCell{1, 0, 0}, kernels::TreeCell{1, 3, 1}, kernels::TreeCell{1, 5, 0},
          kernels::TreeCell{1, 5, 1}, kernels::TreeCell{1, 6, 2}, kernels::TreeCell{1, 7, 2},
          kernels::TreeCell{1, 6, 0}, kernels::TreeCell{1, 7, 0}, kernels::TreeCell{1, 6, 1},
          kernels::TreeCell{1, 7, 1}, kernels::TreeCell{2, 3, 0}}) {
      EXPECT_TRUE(tree.coarsen(c, sim.mesh())) << c.level << " " << c.ci << " " << c.cj;
    }
    sim.end_tree_edit();
    ASSERT_GT(sim.mesh().ghost_count(), 0);
  }
  std::vector<double> precondition(const std::vector<double>& r) {
    std::vector<double> z(r.size(), 0.0);
    run([&](kernels::LoopRunner& lr) {
      if (objective.vcycle() != nullptr) {
        objective.vcycle()->apply(lr, ctx, r, z);
      } else if (objective.multigrid() != nullptr) {
        objective.multigrid()->apply(lr, ctx, *objective.line_preconditioner(), r, z);
      } else {
        objective.line_preconditioner()->apply(lr, ctx, r, z);
      }
    });
    return z;
  }
  std::vector<double> random_free(unsigned seed) const {
    return testing::random_free_vector(sim, seed);
  }
};

/// x . B y = y . B x and x . B x > 0 for four pairs of random vectors on the free particles.
void expect_symmetric_positive(Fixture& f, unsigned seed) {
  for (unsigned k = 0; k < 4; ++k) {
    const std::vector<double> x = f.random_free(100 * seed + 2 * k);
    const std::vector<double> y = f.random_free(100 * seed + 2 * k + 1);
    const std::vector<double> bx = f.precondition(x), by = f.precondition(y);
    const double xby = dot(x, by), ybx = dot(y, bx);
    EXPECT_NEAR(xby, ybx, 1e-10 * std::sqrt(dot(x, bx) * dot(y, by))) << "seed " << seed;
    EXPECT_GT(dot(x, bx), 0.0);
    EXPECT_GT(dot(y, by), 0.0);
  }
}

/// Linear PCG on the kernel's model Hessian with the objective's own preconditioner, to a
/// relative residual of 1e-6; returns the iterations.
int pcg_iterations(Fixture& f, const std::vector<double>& b) {
  std::vector<double> x(b.size(), 0.0), r = b, z = f.precondition(r), p = z;
  double rz = dot(r, z);
  const double stop = 1e-6 * std::sqrt(dot(b, b));
  for (int it = 1; it <= 3000; ++it) {
    const std::vector<double> q = f.product(p);
    const double alpha = rz / dot(p, q);
    for (std::size_t i = 0; i < x.size(); ++i) {
      x[i] += alpha * p[i];
      r[i] -= alpha * q[i];
    }
    if (std::sqrt(dot(r, r)) <= stop) return it;
    z = f.precondition(r);
    const double rz_new = dot(r, z);
    for (std::size_t i = 0; i < p.size(); ++i) p[i] = z[i] + rz_new / rz * p[i];
    rz = rz_new;
  }
  return 3001;
}

/// Stretched by 2 %, bent before (bending in the model), the step's constants and H.
void load_stretched(Fixture& f) {
  kernels::ClothState& st = f.sim.state();
  for (std::size_t i = 0; i < st.position.size(); ++i) {
    if (i % 3 != 2) st.position[i] *= 1.02;
  }
  for (double& m : st.triple_moment) m = 2.0 * f.sim.material().bending[0].hb;
  st.target = st.position;
  st.step_start = st.position;
  f.run([&](kernels::LoopRunner& r) { f.objective.begin_step(r); });
}

TEST(Multigrid, PcgIterationsStayFlatFrom17To257WhereLineSolvesGrow) {
  // The line solves alone up to 129^2 (542 iterations at 257^2 would double the test's time).
  int lines_first = 0, lines_last = 0;
  for (int n : {17, 33, 65, 129, 257}) {
    if (n == 257 && clothbench_test::kSanitized) continue;
    Fixture mg(stretched_sheet(n, Preconditioner::multigrid));
    load_stretched(mg);
    ASSERT_EQ(mg.objective.multigrid()->coarse_failures(), 0);
    const std::vector<double> b = mg.random_free(7);
    const int with_mg = pcg_iterations(mg, b);
    EXPECT_LE(with_mg, 20) << n << "^2";
    if (n > 129) {
      std::printf("%d^2: PCG iterations with the two-level preconditioner %d\n", n, with_mg);
      continue;
    }
    Fixture lines(stretched_sheet(n, Preconditioner::line_solves));
    load_stretched(lines);
    const int with_lines = pcg_iterations(lines, b);
    std::printf("%d^2: PCG iterations with line solves %d, with the two-level preconditioner %d\n",
                n, with_lines, with_mg);
    if (n == 17) lines_first = with_lines;
    lines_last = with_lines;
  }
  EXPECT_GT(lines_last, 4 * lines_first) << "the line solves alone grow with the mesh";
}

TEST(Multigrid, ProlongationReproducesLinearFieldsAcrossGhostsAndDropsPins) {
  // A linear field sampled at the coarse nodes is interpolated exactly at every free particle
  // (the bilinear rule and the ghosts' midpoint rule both reproduce linear fields); a pinned
  // corner contributes nothing, so rows next to a pin sum to less than one.
  for (bool pins : {false, true}) {
    Fixture f(graded_cloth(pins));
    f.grade();
    f.assemble();
    const kernels::MultigridPreconditioner& mg = *f.objective.multigrid();
    const auto& p = mg.prolongation();
    const kernels::ClothMesh& mesh = f.sim.mesh();
    ASSERT_GT(mg.coarse_nodes(), 0);
    std::int64_t free_count = 0;
    for (std::int64_t s = 0; s < mesh.slot_count(); ++s) free_count += f.ctx.is_free(s) ? 1 : 0;
    EXPECT_LT(mg.coarse_nodes(), free_count / 2) << "the coarse grid is coarser";
    // Coarse values: the linear field (i, 2j, i - j) of each coarse node's grid point.
    Eigen::VectorXd coarse(p.cols());
    std::vector<bool> seen(static_cast<std::size_t>(p.cols()), false);
    for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
      for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(p, 3 * s); it; ++it) {
        if (it.value() == 1.0) {  // an identity row: s is this coarse node
          const Eigen::Vector3d field(mesh.grid_i(s), 2.0 * mesh.grid_j(s),
                                      mesh.grid_i(s) - mesh.grid_j(s));
          coarse.segment<3>(it.col()) = field;
          seen[static_cast<std::size_t>(it.col())] = true;
        }
      }
    }
    for (Eigen::Index c = 0; c < p.cols(); c += 3) ASSERT_TRUE(seen[c]) << "coarse column " << c;
    const Eigen::VectorXd fine = p * coarse;
    int near_pin = 0;
    for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
      if (!f.ctx.is_free(s)) {
        EXPECT_EQ(p.row(3 * s).nonZeros(), 0) << "slot " << s;
        continue;
      }
      double row_sum = 0.0;
      for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(p, 3 * s); it; ++it) {
        row_sum += it.value();
      }
      const Eigen::Vector3d field(mesh.grid_i(s), 2.0 * mesh.grid_j(s),
                                  mesh.grid_i(s) - mesh.grid_j(s));
      if (row_sum < 1.0 - 1e-12) {
        EXPECT_TRUE(pins) << "slot " << s << " lost weight without a pin";
        ++near_pin;
        continue;
      }
      EXPECT_NEAR(row_sum, 1.0, 1e-12) << "slot " << s;
      EXPECT_LT((fine.segment<3>(3 * s) - field).norm(), 1e-12) << "slot " << s;
    }
    EXPECT_EQ(near_pin > 0, pins);
  }
}

TEST(Multigrid, CoarseOperatorIsTheGalerkinProductComputedDensely) {
  for (unsigned seed : {1u, 2u}) {
    Fixture f(graded_cloth(true));
    f.grade();
    testing::randomise_state(f.sim, seed);
    f.assemble();
    const kernels::MultigridPreconditioner& mg = *f.objective.multigrid();
    const std::int64_t slots = f.sim.mesh().slot_count();
    std::vector<std::int64_t> unknown(static_cast<std::size_t>(slots), -1);
    for (std::int64_t s = 0; s < slots; ++s) unknown[s] = f.ctx.is_free(s) ? s : -1;
    const Eigen::MatrixXd a =
        Eigen::MatrixXd(f.objective.model_hessian()->matrix(f.ctx, unknown, slots));
    const Eigen::MatrixXd p = Eigen::MatrixXd(mg.prolongation());
    const Eigen::MatrixXd expected = p.transpose() * a * p;
    const Eigen::MatrixXd coarse = Eigen::MatrixXd(mg.coarse_operator());
    ASSERT_EQ(coarse.rows(), expected.rows());
    EXPECT_LE((coarse - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff());
    // And the fine matrix is the matrix-free H the PCG multiplies with.
    const std::vector<double> v = f.random_free(seed);
    const std::vector<double> hv = f.product(v);
    const Eigen::VectorXd av = a * Eigen::Map<const Eigen::VectorXd>(v.data(), v.size());
    double worst = 0.0, scale = 0.0;
    for (std::int64_t s = 0; s < slots; ++s) {
      if (!f.ctx.is_free(s)) continue;
      worst = std::max(worst, (av.segment<3>(3 * s) - Eigen::Vector3d(&hv[3 * s])).norm());
      scale = std::max(scale, Eigen::Vector3d(&hv[3 * s]).norm());
    }
    EXPECT_LT(worst, 1e-12 * scale);
  }
}

TEST(Multigrid, TheCycleIsSymmetricPositiveDefinite) {
  for (unsigned seed : {3u, 4u, 5u}) {
    Fixture f(graded_cloth(true));
    f.grade();
    testing::randomise_state(f.sim, seed);
    f.assemble();
    ASSERT_EQ(f.objective.multigrid()->coarse_failures(), 0);
    expect_symmetric_positive(f, seed);
  }
}

// --- The V-cycle (kernels/vcycle_preconditioner.hpp) ------------------------------------

TEST(Vcycle, PcgIterationsStayFlatFrom17To257) {
  // With the shipped coarsest size (64 nodes) and with a coarsest level of up to 600 nodes
  // (a level fewer at most sizes): flat either way.
  for (const std::int64_t coarsest :
       {kernels::VcyclePreconditioner::kCoarsestNodes, std::int64_t{600}}) {
    for (int n : {17, 33, 65, 129, 257}) {
      if (n == 257 && clothbench_test::kSanitized) continue;
      Fixture f(stretched_sheet(n, Preconditioner::vcycle));
      f.objective.vcycle()->set_coarsest_nodes(coarsest);
      load_stretched(f);
      const kernels::VcyclePreconditioner& v = *f.objective.vcycle();
      ASSERT_EQ(v.failures(), 0);
      const int iterations = pcg_iterations(f, f.random_free(7));
      EXPECT_LE(iterations, 15) << n << "^2";
      std::printf("%d^2: PCG iterations with the V-cycle %d (%d levels, coarsest %lld nodes)\n", n,
                  iterations, v.levels(), static_cast<long long>(v.level_nodes(v.levels() - 1)));
      if (n >= 65) {
        EXPECT_GE(v.levels(), 3) << n << "^2";
      }
    }
  }
}

/// The graded cloth with a random state and a V-cycle of at least three levels on it (a
/// coarsest level of 4 nodes), assembled.
const kernels::VcyclePreconditioner& graded_vcycle(Fixture& f, unsigned seed) {
  f.grade();
  testing::randomise_state(f.sim, seed);
  f.objective.vcycle()->set_coarsest_nodes(4);
  f.assemble();
  return *f.objective.vcycle();
}

TEST(Vcycle, ProlongationsReproduceLinearFieldsOnAGradedMeshWithGhosts) {
  Fixture f(graded_cloth(false, Preconditioner::vcycle));
  const kernels::VcyclePreconditioner& v = graded_vcycle(f, 6);
  ASSERT_GE(v.levels(), 3);
  for (int k = 0; k + 1 < v.levels(); ++k) {
    const auto& p = v.prolongation(k);
    ASSERT_EQ(p.rows(), 3 * v.level_nodes(k));
    ASSERT_EQ(p.cols(), 3 * v.level_nodes(k + 1));
    for (int axis = 0; axis < 2; ++axis) {
      const std::vector<int>& fine = axis == 0 ? v.node_i(k) : v.node_j(k);
      const std::vector<int>& coarse = axis == 0 ? v.node_i(k + 1) : v.node_j(k + 1);
      Eigen::VectorXd c = Eigen::VectorXd::Zero(p.cols());
      for (std::size_t a = 0; a < coarse.size(); ++a) {
        for (int d = 0; d < 3; ++d) c[static_cast<Eigen::Index>(3 * a + d)] = coarse[a] + 0.5 * d;
      }
      const Eigen::VectorXd x = p * c;
      for (std::size_t a = 0; a < fine.size(); ++a) {
        for (int d = 0; d < 3; ++d) {
          EXPECT_NEAR(x[static_cast<Eigen::Index>(3 * a + d)], fine[a] + 0.5 * d, 1e-12)
              << "level " << k << " node " << a;
        }
      }
    }
  }
}

/// The largest excess of |stored - exact| over one rounding to float of each entry (2^-24
/// relative) and a sum's double rounding (1e-12 of the largest entry): the V-cycle stores its
/// operators' entries, summed in double, rounded to float once. <= 0 when every entry is.
double beyond_one_float_rounding(const Eigen::MatrixXd& stored, const Eigen::MatrixXd& exact) {
  const double sums = 1e-12 * exact.cwiseAbs().maxCoeff();
  const Eigen::MatrixXd allowed = std::ldexp(1.0, -24) * exact.cwiseAbs().array() + sums;
  return ((stored - exact).cwiseAbs() - allowed).maxCoeff();
}

TEST(Vcycle, CoarseOperatorsAreGalerkinProductsOfTheModel) {
  Fixture f(graded_cloth(true, Preconditioner::vcycle));
  const kernels::VcyclePreconditioner& v = graded_vcycle(f, 8);
  ASSERT_GE(v.levels(), 3);
  EXPECT_GT(f.sim.mesh().ghost_count(), 0);
  // The isotropic model, then the same state with bending's floor released along the turning
  // vector (rank-one terms per triple in level 0's rows).
  for (const bool floor_along : {true, false}) {
    if (!floor_along) f.assemble(/*floor_along=*/false);
    // Level 0, summed by rows, is the model's matrix (summed element by element).
    std::int64_t unknowns = 0;
    const std::vector<std::int64_t> unknown = kernels::free_unknowns(f.ctx, &unknowns);
    const Eigen::MatrixXd model =
        Eigen::MatrixXd(f.objective.model_hessian()->matrix(f.ctx, unknown, unknowns));
    const Eigen::MatrixXd level0 = Eigen::MatrixXd(v.level_operator(0));
    ASSERT_EQ(level0.rows(), model.rows());
    EXPECT_LE(beyond_one_float_rounding(level0, model), 0.0) << "floor along " << floor_along;
    for (int k = 0; k + 1 < v.levels(); ++k) {
      const Eigen::MatrixXd p = Eigen::MatrixXd(v.prolongation(k));
      const Eigen::MatrixXd expected = p.transpose() * Eigen::MatrixXd(v.level_operator(k)) * p;
      const Eigen::MatrixXd coarse = Eigen::MatrixXd(v.level_operator(k + 1));
      EXPECT_LE(beyond_one_float_rounding(coarse, expected), 0.0)
          << "level " << k + 1 << " floor along " << floor_along;
    }
  }
}

TEST(Vcycle, TheCycleIsSymmetricPositiveDefiniteOnCrumpledStatesInContact) {
  for (unsigned seed : {3u, 4u, 5u}) {
    Fixture f(graded_cloth(true, Preconditioner::vcycle));
    const kernels::VcyclePreconditioner& v = graded_vcycle(f, seed);
    ASSERT_EQ(v.failures(), 0);
    ASSERT_GE(v.levels(), 3);
    expect_symmetric_positive(f, seed);
  }
}

TEST(Vcycle, OneOrTwoLinesPerSmoothingTaskGiveTheSameBits) {
  for (unsigned seed : {3u, 7u}) {
    Fixture f(graded_cloth(true, Preconditioner::vcycle));
    ASSERT_GE(graded_vcycle(f, seed).levels(), 3);
    kernels::VcyclePreconditioner& v = *f.objective.vcycle();
    ASSERT_EQ(v.lines_per_task(), 2);
    const std::vector<double> r = f.random_free(seed + 20);
    const std::vector<double> two = f.precondition(r);
    v.set_lines_per_task(1);
    const std::vector<double> one = f.precondition(r);
    ASSERT_EQ(one.size(), two.size());
    EXPECT_EQ(std::memcmp(one.data(), two.data(), one.size() * sizeof(double)), 0) << seed;
    double norm = 0.0;
    for (const double z : one) norm += z * z;
    EXPECT_GT(norm, 0.0);
  }
  Fixture f(graded_cloth(true, Preconditioner::vcycle));
  kernels::VcyclePreconditioner& v = *f.objective.vcycle();
  EXPECT_THROW(v.set_lines_per_task(3), std::invalid_argument);
  EXPECT_THROW(v.set_lines_per_task(0), std::invalid_argument);
  EXPECT_EQ(v.lines_per_task(), 2);
}

/// The model anew at the current state: no stiffness remembered, no last direction (so that
/// fixtures reaching the same state by different paths assemble the same model).
void assemble_afresh(Fixture& f) {
  f.objective.model_hessian()->forget();
  std::fill(f.sim.state().direction.begin(), f.sim.state().direction.end(), 0.0);
  f.assemble();
}

/// Every level's operator and one cycle of `a` and `b` have the same bits.
void expect_same_hierarchy(Fixture& a, Fixture& b, const char* what) {
  const kernels::VcyclePreconditioner& va = *a.objective.vcycle();
  const kernels::VcyclePreconditioner& vb = *b.objective.vcycle();
  ASSERT_EQ(va.levels(), vb.levels()) << what;
  for (int k = 0; k < va.levels(); ++k) {
    const Eigen::MatrixXd oa = Eigen::MatrixXd(va.level_operator(k));
    const Eigen::MatrixXd ob = Eigen::MatrixXd(vb.level_operator(k));
    ASSERT_EQ(oa.rows(), ob.rows()) << what << ", level " << k;
    EXPECT_TRUE(oa == ob) << what << ", level " << k;
  }
  const std::vector<double> r = a.random_free(11);
  EXPECT_TRUE(a.precondition(r) == b.precondition(r)) << what;
}

TEST(Vcycle, TheHierarchyIsMadeOncePerTopologyAndMatchesOneMadeAnew) {
  // `kept` factorises at a first state, then with other values on the same mesh (values
  // only), then where other triples bend and after an AMRC edit (new structures); each time
  // it must equal a preconditioner made at that state from nothing.
  auto start = [](Fixture& f) {
    f.grade();
    f.objective.vcycle()->set_coarsest_nodes(4);
    testing::randomise_state(f.sim, 3);
  };
  auto edit = [](Fixture& f) {
    kernels::AdaptiveMesh& tree = f.sim.begin_tree_edit();
    EXPECT_TRUE(tree.coarsen(kernels::TreeCell{1, 0, 1}, f.sim.mesh()));
    f.sim.end_tree_edit();
  };
  Fixture kept(graded_cloth(true, Preconditioner::vcycle));
  start(kept);
  assemble_afresh(kept);
  const kernels::VcyclePreconditioner& v = *kept.objective.vcycle();
  ASSERT_GE(v.levels(), 3);
  EXPECT_EQ(v.structures(), 1);
  const Eigen::MatrixXd first = Eigen::MatrixXd(v.level_operator(1));
  // A shorter time step: every inertia block changes, the pattern does not.
  auto shorter_step = [](Fixture& f) {
    f.objective.set_step_length(0.5 * f.sim.config().time.step);
  };
  shorter_step(kept);
  assemble_afresh(kept);
  EXPECT_EQ(v.factorisations(), 2);
  EXPECT_EQ(v.structures(), 1);  // same topology and bending pattern: values only
  EXPECT_FALSE(Eigen::MatrixXd(v.level_operator(1)) == first);
  {
    Fixture made(graded_cloth(true, Preconditioner::vcycle));
    start(made);
    shorter_step(made);
    assemble_afresh(made);
    expect_same_hierarchy(kept, made, "same topology, new values");
  }
  // Other triples bend: a new pattern. Every other triple loses its previous moment, so it
  // follows the unloading curve, which is zero below its onset: no bending stiffness.
  auto other_triples = [](Fixture& f) {
    testing::randomise_state(f.sim, 7);
    std::vector<double>& moment = f.sim.state().triple_moment;
    for (std::size_t id = 0; id < moment.size(); id += 2) moment[id] = 0.0;
  };
  other_triples(kept);
  assemble_afresh(kept);
  EXPECT_EQ(v.structures(), 2);
  {
    Fixture made(graded_cloth(true, Preconditioner::vcycle));
    start(made);
    shorter_step(made);
    other_triples(made);
    assemble_afresh(made);
    expect_same_hierarchy(kept, made, "other triples with bending stiffness");
  }
  edit(kept);
  assemble_afresh(kept);
  EXPECT_EQ(v.structures(), 3);  // the mesh changed: a new structure
  Fixture made(graded_cloth(true, Preconditioner::vcycle));
  start(made);
  shorter_step(made);
  other_triples(made);
  edit(made);
  assemble_afresh(made);
  expect_same_hierarchy(kept, made, "after an AMRC edit");
  EXPECT_EQ(v.failures(), 0);
  EXPECT_GT(v.sequential_seconds(), 0.0);
}

TEST(Vcycle, Level0PatternByRowsIsTheModelsStructurePattern) {
  // The V-cycle makes level 0's pattern row by row (ModelHessian::row_pattern, in parallel);
  // it must be the pattern the model's blocks have element by element
  // (for_each_unknown_block's structure), on a graded mesh with ghosts and pins where some
  // triples bend and others do not.
  for (unsigned seed : {8u, 9u}) {
    Fixture f(graded_cloth(true, Preconditioner::vcycle));
    graded_vcycle(f, seed);
    std::vector<double>& moment = f.sim.state().triple_moment;
    for (std::size_t id = 0; id < moment.size(); id += 3) moment[id] = 0.0;
    assemble_afresh(f);
    const kernels::ModelHessian& h = *f.objective.model_hessian();
    const kernels::ClothMesh& mesh = f.sim.mesh();
    int bending = 0, straight = 0;
    for (std::int64_t id = 0; id < h.element_ids(); ++id) {
      if (mesh.triple_active[id] != 0) ++(h.bends(id) ? bending : straight);
    }
    ASSERT_GT(bending, 0) << "seed " << seed;
    ASSERT_GT(straight, 0) << "seed " << seed;
    std::int64_t unknowns = 0;
    const std::vector<std::int64_t> unknown = kernels::free_unknowns(f.ctx, &unknowns);
    std::vector<std::vector<std::int64_t>> expected(static_cast<std::size_t>(unknowns));
    h.for_each_unknown_block(
        f.ctx, unknown,
        [&](std::int64_t row, std::int64_t col, const double*) {
          expected[static_cast<std::size_t>(row)].push_back(col);
        },
        /*structure=*/true);
    std::vector<std::int64_t> cols;
    for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
      if (unknown[s] < 0) continue;
      std::vector<std::int64_t>& want = expected[static_cast<std::size_t>(unknown[s])];
      std::sort(want.begin(), want.end());
      want.erase(std::unique(want.begin(), want.end()), want.end());
      cols.assign(3, -1);  // it appends
      EXPECT_EQ(h.row_pattern(f.ctx, unknown, s, cols), static_cast<std::int64_t>(want.size()));
      want.insert(want.begin(), 3, -1);
      EXPECT_EQ(cols, want) << "seed " << seed << ", slot " << s;
    }
    EXPECT_GT(mesh.ghost_count(), 0);
  }
}

TEST(Vcycle, ATripleThatStopsBendingInTheLastCheckBlockMakesANewStructure) {
  // factor() compares the model and the mesh with the structure's by blocks of slots in
  // parallel: a change in a later block than the first must be seen as well as one in it.
  Fixture f(stretched_sheet(91, Preconditioner::vcycle));  // 8,281 slots: three blocks
  load_stretched(f);
  assemble_afresh(f);
  const kernels::VcyclePreconditioner& v = *f.objective.vcycle();
  const kernels::ModelHessian& h = *f.objective.model_hessian();
  const kernels::ClothMesh& mesh = f.sim.mesh();
  ASSERT_GT(mesh.slot_count(), 2 * kernels::VcyclePreconditioner::kCheckSlots);
  EXPECT_EQ(v.structures(), 1);
  assemble_afresh(f);
  EXPECT_EQ(v.structures(), 1);  // nothing changed: values only
  std::int64_t last = -1;
  for (std::int64_t id = h.element_ids() - 1; id >= 0 && last < 0; --id) {
    if (mesh.triple_active[id] != 0 && h.bends(id)) last = id;
  }
  ASSERT_GE(last / 2, 2 * kernels::VcyclePreconditioner::kCheckSlots);
  // Without its previous moment the triple follows the unloading curve, zero below its
  // onset: no bending stiffness.
  f.sim.state().triple_moment[static_cast<std::size_t>(last)] = 0.0;
  assemble_afresh(f);
  EXPECT_FALSE(h.bends(last));
  EXPECT_EQ(v.structures(), 2);
  EXPECT_EQ(v.failures(), 0);
}

TEST(Vcycle, MemoryEstimateCoversWhatTheCycleHoldsOnAUniformSheet) {
  // After the step's first factorisation on a 129^2 sheet (the finest level, every line).
  Fixture f(stretched_sheet(129, Preconditioner::vcycle));
  load_stretched(f);
  const kernels::VcyclePreconditioner& v = *f.objective.vcycle();
  ASSERT_GE(v.levels(), 3);
  EXPECT_GT(v.memory_bytes(), 0u);
  EXPECT_LE(v.memory_bytes(), 129u * 129u * kernels::VcyclePreconditioner::kBytesPerSlot);
  kernels::SimulationConfig block_jacobi = stretched_sheet(129, Preconditioner::block_jacobi);
  EXPECT_EQ(kernels::estimate_memory_bytes(stretched_sheet(129, Preconditioner::vcycle)) -
                kernels::estimate_memory_bytes(block_jacobi),
            129u * 129u * kernels::VcyclePreconditioner::kBytesPerSlot);
}

}  // namespace
}  // namespace clothbench
