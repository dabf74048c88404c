// AMRC (MODEL.md 6): the quadtree, the mesh it implies, ghosts, mass, Active-Lists and warm
// starts after thousands of random refine/coarsen events; refine-then-coarsen restores the
// same mesh; the analytic gradient on adaptive meshes with ghost chains against finite
// differences (both formulations).
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "kernel_fixtures.hpp"
#include "kernels/amrc.hpp"
#include "kernels/simulation.hpp"
#include "schedulers/registry.hpp"
#include "schedulers/static_driver.hpp"

namespace clothbench {
namespace {

using kernels::AdaptiveMesh;
using kernels::ClothMesh;
using kernels::TreeCell;

/// A crumpled sheet of (2^L a + 1) x (2^L b + 1) particles with AMRC on.
kernels::SimulationConfig adaptive_cloth(int levels, int a, int b, bool pins = false) {
  kernels::SimulationConfig c = testing::small_cloth(false, false);
  c.cloth.particles_i = (1 << levels) * a + 1;
  c.cloth.particles_j = (1 << levels) * b + 1;
  c.cloth.size_i = 0.025 * (c.cloth.particles_i - 1);
  c.cloth.size_j = 0.025 * (c.cloth.particles_j - 1);
  c.cloth.block_size = 6;
  c.cloth.initial_crumple = 0.004;
  if (pins) c.cloth.pinned = {{0, 0}, {c.cloth.particles_i - 1, c.cloth.particles_j - 1}};
  c.amrc.enabled = true;
  c.amrc.levels = levels;
  return c;
}

std::string where(const ClothMesh& mesh, std::int64_t s) {
  return "(" + std::to_string(mesh.grid_i(s)) + ", " + std::to_string(mesh.grid_j(s)) + ")";
}

/// Every invariant of an adaptive mesh; returns the number of failures (and reports them).
/// With `lists_expected` (a driver over the Active-Lists has run) the lists must exist.
int check_invariants(const kernels::Simulation& sim, const std::string& context,
                     bool lists_expected = false) {
  const ClothMesh& mesh = sim.mesh();
  const AdaptiveMesh& tree = *sim.adaptive_mesh();
  const kernels::ClothState& st = sim.state();
  int failures = 0;
  auto fail = [&](const std::string& what) {
    if (++failures <= 5) ADD_FAILURE() << context << ": " << what;
  };
  if (!tree.balanced()) fail("tree not 2:1 balanced");

  // Mass: exactly the sheet's mass, carried by active particles only.
  const double expected = mesh.areal_density() * sim.config().cloth.size_i * sim.config().cloth.size_j;
  if (std::abs(mesh.total_mass() - expected) > 1e-12 * expected) {
    fail("mass " + std::to_string(mesh.total_mass()) + " != " + std::to_string(expected));
  }
  std::int64_t ghosts = 0;
  for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
    const std::uint8_t f = mesh.flags[s];
    const bool active = f & kernels::kParticleActive, ghost = f & kernels::kParticleGhost;
    if (active && ghost) fail("slot both active and ghost at " + where(mesh, s));
    if (!active && mesh.mass[s] != 0.0) fail("mass on a non-active slot " + where(mesh, s));
    if (active && !(mesh.mass[s] > 0.0)) fail("active particle without mass " + where(mesh, s));
    if (ghost) {
      ++ghosts;
      // A ghost: on the midpoint of its parents, which are nodes at equal grid distance.
      const int d = kernels::ghost_direction(f);
      if (d < 0) {
        fail("ghost without direction " + where(mesh, s));
        continue;
      }
      const std::int64_t id = kernels::element_id(s, d);
      const std::int32_t p = mesh.prev[id], n = mesh.next[id];
      if (p < 0 || n < 0) {
        fail("ghost without two parents " + where(mesh, s));
        continue;
      }
      const int before = d == 0 ? mesh.grid_i(s) - mesh.grid_i(p) : mesh.grid_j(s) - mesh.grid_j(p);
      const int after = d == 0 ? mesh.grid_i(n) - mesh.grid_i(s) : mesh.grid_j(n) - mesh.grid_j(s);
      if (before != after) fail("ghost not in the middle of its coarse edge " + where(mesh, s));
      const Eigen::Vector3d mid =
          0.5 * (kernels::node_value(mesh, st.position, p) + kernels::node_value(mesh, st.position, n));
      if (kernels::vec3(st.position, s) != mid) fail("crack: ghost off its parents' midpoint " + where(mesh, s));
      const std::int64_t across = kernels::element_id(s, 1 - d);
      if ((mesh.next[across] >= 0) == (mesh.prev[across] >= 0)) {
        fail("ghost must have exactly one neighbour across its edge " + where(mesh, s));
      }
    }
    for (int d = 0; d < 2; ++d) {
      const std::int64_t id = kernels::element_id(s, d);
      const std::int32_t n = mesh.next[id], p = mesh.prev[id];
      if (n >= 0 && mesh.prev[kernels::element_id(n, d)] != s) fail("next/prev not symmetric");
      if (mesh.edge_active[id]) {
        if (!kernels::is_node(f) || n < 0 || !kernels::is_node(mesh.flags[n])) {
          fail("edge joins a non-node at " + where(mesh, s));
          continue;
        }
        const int span = d == 0 ? mesh.grid_i(n) - mesh.grid_i(s) : mesh.grid_j(n) - mesh.grid_j(s);
        if (span <= 0 || (span & (span - 1)) != 0) fail("edge span not a power of two");
        if (std::abs(mesh.edge_rest[id] - static_cast<float>(span * mesh.spacing(d))) > 0.0f) {
          fail("edge rest length inconsistent with its span at " + where(mesh, s));
        }
        for (int t = 1; t < span; ++t) {
          const std::int32_t k = d == 0 ? mesh.slot(mesh.grid_i(s) + t, mesh.grid_j(s))
                                        : mesh.slot(mesh.grid_i(s), mesh.grid_j(s) + t);
          if (kernels::is_node(mesh.flags[k])) fail("edge skips a node at " + where(mesh, k));
        }
        if (!(mesh.edge_width[id] > 0.0f)) fail("edge without width");
      }
      if (mesh.triple_active[id]) {
        if (!active || n < 0 || p < 0) fail("triple not centred on an active particle with two neighbours");
        // Half the grid distance from its previous to its next node: the extent along the
        // line its centre stands for.
        const int reach = d == 0 ? mesh.grid_i(n) - mesh.grid_i(p) : mesh.grid_j(n) - mesh.grid_j(p);
        const double rest = 0.5 * reach * mesh.spacing(d);
        if (std::abs(mesh.triple_rest(id) - rest) > 1e-6 * rest) fail("triple rest spacing");
        if (!(mesh.triple_width(id) > 0.0f)) fail("triple without width");
      }
    }
  }
  if (ghosts != mesh.ghost_count()) fail("ghost count");

  // No crack: every side of every leaf is a chain of edges from corner to corner.
  for (const TreeCell& c : tree.leaves()) {
    const int size = 1 << c.level, i0 = c.ci * size, j0 = c.cj * size;
    const int sides[4][3] = {{i0, j0, 1}, {i0 + size, j0, 1}, {i0, j0, 0}, {i0, j0 + size, 0}};
    for (const auto& side : sides) {
      const int d = side[2];
      std::int64_t s = mesh.slot(side[0], side[1]);
      const std::int64_t end = d == 0 ? mesh.slot(side[0] + size, side[1]) : mesh.slot(side[0], side[1] + size);
      int hops = 0;
      while (s != end && hops <= size) {
        const std::int64_t id = kernels::element_id(s, d);
        if (!mesh.edge_active[id]) break;
        s = mesh.next[id];
        ++hops;
      }
      if (s != end) fail("crack: leaf side not covered by edges at level " + std::to_string(c.level));
    }
  }

  // Active-Lists: exactly the live elements, each once, in storage order.
  if (lists_expected && sim.active_lists() == nullptr) fail("no Active-Lists for an @active driver");
  if (const kernels::ActiveLists* lists = sim.active_lists()) {
    for (auto kind : {kernels::ElementKind::particles, kernels::ElementKind::edges,
                      kernels::ElementKind::triples, kernels::ElementKind::ghosts}) {
      std::vector<std::int32_t> expected_ids;
      const int per = kernels::ids_per_slot(kind);
      for (std::int64_t id = 0; id < per * mesh.slot_count(); ++id) {
        if (kernels::element_is_live(mesh, kind, id)) expected_ids.push_back(static_cast<std::int32_t>(id));
      }
      if (lists->of(kind).entries != expected_ids) fail("active list differs from the live elements");
    }
  }
  return failures;
}

/// The mesh state an event sequence must restore.
struct MeshSnapshot {
  std::vector<std::uint8_t> flags, edge_active, triple_active;
  std::vector<std::int32_t> next, prev, particles, edges, triples, ghosts;
  std::vector<float> edge_rest, edge_width;  // the triples' follow (ClothMesh::triple_rest)
  std::vector<double> mass;
  bool operator==(const MeshSnapshot&) const = default;
};
MeshSnapshot snapshot(const kernels::Simulation& sim) {
  const ClothMesh& m = sim.mesh();
  MeshSnapshot s{m.flags, m.edge_active, m.triple_active, m.next, m.prev, {}, {}, {}, {},
                 m.edge_rest, m.edge_width, m.mass};
  if (const auto* lists = sim.active_lists()) {
    s.particles = lists->particles.entries;
    s.edges = lists->edges.entries;
    s.triples = lists->triples.entries;
    s.ghosts = lists->ghosts.entries;
  }
  return s;
}

TEST(Amrc, TreeOfTheFinestMeshGivesTheUniformMesh) {
  kernels::SimulationConfig c = adaptive_cloth(2, 3, 2);
  kernels::Simulation sim(c);
  kernels::ClothMesh rewritten = sim.mesh();
  sim.adaptive_mesh()->write_mesh(rewritten);
  const ClothMesh& original = sim.mesh();
  EXPECT_EQ(rewritten.flags, original.flags);
  EXPECT_EQ(rewritten.next, original.next);
  EXPECT_EQ(rewritten.prev, original.prev);
  EXPECT_EQ(rewritten.edge_active, original.edge_active);
  EXPECT_EQ(rewritten.triple_active, original.triple_active);
  EXPECT_EQ(rewritten.edge_rest, original.edge_rest);
  EXPECT_EQ(rewritten.edge_width, original.edge_width);
  // The triples' rest spacing and width, means of their edges', are the uniform mesh's node
  // spacing and strip width: what the mesh stored for them before they were computed.
  for (std::int64_t id = 0; id < 2 * original.slot_count(); ++id) {
    if (!original.triple_active[id]) continue;
    const int d = kernels::element_direction(id);
    EXPECT_EQ(original.triple_rest(id), static_cast<float>(original.spacing(d))) << id;
    EXPECT_EQ(original.triple_width(id), original.edge_width[id]) << id;
  }
  for (std::int64_t s = 0; s < original.slot_count(); ++s) {
    EXPECT_NEAR(rewritten.mass[s], original.mass[s], 1e-15 * original.mass[s]);
  }
  EXPECT_EQ(rewritten.ghost_count(), 0);
}

TEST(Amrc, RejectsSizesThatAreNotTwoToTheLTimesNPlusOne) {
  kernels::SimulationConfig c = adaptive_cloth(2, 3, 2);
  c.cloth.particles_i = 14;
  EXPECT_THROW(kernels::Simulation{c}, std::invalid_argument);
}

TEST(Amrc, RefineKeepsTwoToOneBalance) {
  kernels::Simulation sim(adaptive_cloth(3, 2, 2));
  AdaptiveMesh& tree = sim.begin_tree_edit();
  // Coarsen everything to level 3, then split one corner cell down to level 0: the balance
  // refinement must cascade so that no two neighbours differ by more than one level.
  for (int k = 1; k <= 3; ++k) {
    for (int ci = 0; ci < (16 >> k); ++ci) {
      for (int cj = 0; cj < (16 >> k); ++cj) tree.coarsen(TreeCell{k, ci, cj}, sim.mesh());
    }
  }
  EXPECT_EQ(tree.leaves().size(), 4u);
  EXPECT_EQ(tree.refine(TreeCell{3, 0, 0}), 1);
  EXPECT_EQ(tree.refine(TreeCell{2, 0, 0}), 1);
  EXPECT_EQ(tree.refine(TreeCell{2, 0, 0}), 0) << "not a leaf any more";
  EXPECT_GT(tree.refine(TreeCell{1, 1, 1}), 1) << "splitting next to a level-2 leaf must cascade";
  EXPECT_TRUE(tree.balanced());
  sim.end_tree_edit();
  EXPECT_EQ(check_invariants(sim, "after cascade"), 0);
  EXPECT_GT(sim.mesh().ghost_count(), 0);
}

/// Length of the ghost chain above slot s (0 for a particle, 1 for a ghost of particles).
int chain_depth(const ClothMesh& mesh, std::int64_t s) {
  const int d = kernels::ghost_direction(mesh.flags[s]);
  if (d < 0) return 0;
  const std::int64_t id = kernels::element_id(s, d);
  return 1 + std::max(chain_depth(mesh, mesh.prev[id]), chain_depth(mesh, mesh.next[id]));
}

/// Random refine/coarsen events on small grids, every invariant checked after each event.
void random_events(int levels, int a, int b, int events, unsigned seed, const std::string& scheduler) {
  kernels::Simulation sim(adaptive_cloth(levels, a, b, true));
  auto driver = schedulers::make_driver(scheduler);
  sim.evaluate(*driver);  // builds the lists when the driver runs over them
  const bool over_lists = driver->space() == schedulers::IterationSpace::active;
  ASSERT_EQ(sim.active_lists() != nullptr, over_lists) << scheduler;
  std::mt19937 rng(seed);
  const AdaptiveMesh& tree = *sim.adaptive_mesh();
  std::int64_t refined = 0, coarsened = 0, ghosts_seen = 0;
  int deepest_chain = 0;
  for (int e = 0; e < events; ++e) {
    AdaptiveMesh& edit = sim.begin_tree_edit();
    const int ops = 1 + static_cast<int>(rng() % 4);
    for (int o = 0; o < ops; ++o) {
      const int k = 1 + static_cast<int>(rng() % levels);
      const TreeCell c{k, static_cast<int>(rng() % (tree.cells_i() >> k)),
                       static_cast<int>(rng() % (tree.cells_j() >> k))};
      // Coarsening is tried more often so that the mesh visits every level.
      if (rng() % 5 < 3) {
        coarsened += edit.coarsen(c, sim.mesh()) ? 1 : 0;
      } else {
        // Refine the leaf that holds a random point of c.
        const int fi = c.ci << k, fj = c.cj << k;
        const int level = tree.leaf_level(fi, fj);
        refined += edit.refine(TreeCell{level, fi >> level, fj >> level});
      }
    }
    sim.end_tree_edit();
    ghosts_seen += sim.mesh().ghost_count();
    for (std::int64_t s = 0; s < sim.mesh().slot_count(); ++s) {
      deepest_chain = std::max(deepest_chain, chain_depth(sim.mesh(), s));
    }
    if (check_invariants(sim, "event " + std::to_string(e) + " seed " + std::to_string(seed),
                         over_lists) > 0) {
      return;
    }
  }
  EXPECT_GT(refined, events / 5);
  EXPECT_GT(coarsened, events / 5);
  EXPECT_GT(ghosts_seen, 0);
  // 2:1 balance across sides means a ghost's parents are always particles (a ghost parent
  // would need a leaf two levels finer next to a coarse one); the recursion is a safeguard.
  EXPECT_EQ(deepest_chain, 1);
}

TEST(Amrc, InvariantsHoldAfterThousandsOfRandomEventsWithBlocks) {
  random_events(2, 4, 3, 1500, 11, "static");
}

TEST(Amrc, InvariantsHoldAfterThousandsOfRandomEventsWithActiveLists) {
  random_events(3, 3, 2, 1500, 12, "active-lists");
}

TEST(Amrc, RefineThenCoarsenRestoresTheSameMeshAndLists) {
  kernels::Simulation sim(adaptive_cloth(3, 2, 2));
  auto driver = schedulers::make_driver("active-lists");
  sim.evaluate(*driver);
  ASSERT_NE(sim.active_lists(), nullptr) << "the lists this test compares";
  std::mt19937 rng(5);
  int rounds_done = 0;
  for (int round = 0; round < 40; ++round) {
    // A random balanced starting mesh...
    AdaptiveMesh& tree = sim.begin_tree_edit();
    for (int o = 0; o < 30; ++o) {
      const int k = 1 + static_cast<int>(rng() % 3);
      tree.coarsen(TreeCell{k, static_cast<int>(rng() % (16 >> k)), static_cast<int>(rng() % (16 >> k))},
                   sim.mesh());
    }
    sim.end_tree_edit();
    const MeshSnapshot before = snapshot(sim);
    const std::vector<TreeCell> leaves = tree.leaves();
    // ...refine one coarse leaf (cascading) and coarsen exactly what was split, finest first.
    TreeCell target{0, 0, 0};
    for (const TreeCell& c : leaves) {
      if (c.level >= 2) target = c;
    }
    if (target.level < 1) continue;
    AdaptiveMesh& edit = sim.begin_tree_edit();
    edit.refine(target);
    sim.end_tree_edit();
    EXPECT_NE(snapshot(sim), before);
    std::set<std::tuple<int, int, int>> original;
    for (const TreeCell& c : leaves) original.insert({c.level, c.ci, c.cj});
    for (int pass = 0; pass < 4; ++pass) {
      AdaptiveMesh& undo = sim.begin_tree_edit();
      for (int k = 1; k <= 3; ++k) {
        for (int ci = 0; ci < (16 >> k); ++ci) {
          for (int cj = 0; cj < (16 >> k); ++cj) {
            if (original.count({k, ci, cj})) undo.coarsen(TreeCell{k, ci, cj}, sim.mesh());
          }
        }
      }
      sim.end_tree_edit();
    }
    const MeshSnapshot after = snapshot(sim);
    EXPECT_TRUE(after == before) << "round " << round << " flags " << (after.flags == before.flags)
                                 << " next " << (after.next == before.next) << " mass "
                                 << (after.mass == before.mass) << " widths "
                                 << (after.edge_width == before.edge_width) << " lists "
                                 << (after.edges == before.edges);
    if (!(after == before)) {
      std::string now, then;
      for (const TreeCell& c : tree.leaves()) now += std::to_string(c.level) + ":" + std::to_string(c.ci) + "," + std::to_string(c.cj) + " ";
      for (const TreeCell& c : leaves) then += std::to_string(c.level) + ":" + std::to_string(c.ci) + "," + std::to_string(c.cj) + " ";
      ADD_FAILURE() << "target " << target.level << ":" << target.ci << "," << target.cj << "\nnow  " << now << "\nthen " << then;
    }
    EXPECT_EQ(check_invariants(sim, "restored", true), 0);
    ++rounds_done;
  }
  // A round without a leaf of level 2 or more is skipped; most rounds must have run.
  EXPECT_GE(rounds_done, 30) << "rounds that refined and coarsened back";
}

TEST(Amrc, PinnedParticlesStayActive) {
  kernels::SimulationConfig c = adaptive_cloth(2, 2, 2);
  c.cloth.pinned = {{2, 2}, {8, 5}};
  kernels::Simulation sim(c);
  AdaptiveMesh& tree = sim.begin_tree_edit();
  for (int k = 1; k <= 2; ++k) {
    for (int ci = 0; ci < (8 >> k); ++ci) {
      for (int cj = 0; cj < (8 >> k); ++cj) tree.coarsen(TreeCell{k, ci, cj}, sim.mesh());
    }
  }
  sim.end_tree_edit();
  for (const auto& [i, j] : c.cloth.pinned) {
    EXPECT_TRUE(sim.mesh().flags[sim.mesh().slot(i, j)] & kernels::kParticleActive) << i << "," << j;
  }
  EXPECT_EQ(check_invariants(sim, "pins"), 0);
}

/// A mesh with every level: level-2 blocks, level-1 cells, level-0 cells, ghosts between.
void build_graded_mesh(kernels::Simulation& sim) {
  AdaptiveMesh& tree = sim.begin_tree_edit();
  const int ci = tree.cells_i(), cj = tree.cells_j();
  for (int k = 1; k <= 2; ++k) {
    for (int a = 0; a < (ci >> k); ++a) {
      for (int b = 0; b < (cj >> k); ++b) tree.coarsen(TreeCell{k, a, b}, sim.mesh());
    }
  }
  tree.refine(TreeCell{2, 0, 0});
  tree.refine(TreeCell{1, 1, 1});
  tree.refine(TreeCell{1, 0, 1});
  sim.end_tree_edit();
  ASSERT_GT(sim.mesh().ghost_count(), 2);
}

/// Central differences of the objective over every free active coordinate (ghosts follow).
double gradient_error(kernels::Simulation& sim) {
  schedulers::OmpStaticDriver driver;
  sim.evaluate(driver);
  const std::vector<double> gradient = sim.state().gradient;
  std::vector<double>& x = sim.state().position;
  const double h = 1e-7;
  double diff = 0.0, norm = 0.0;
  for (std::int64_t s = 0; s < sim.mesh().slot_count(); ++s) {
    const std::uint8_t f = sim.mesh().flags[s];
    if ((f & (kernels::kParticleActive | kernels::kParticlePinned)) != kernels::kParticleActive) continue;
    for (int k = 0; k < 3; ++k) {
      const std::size_t i = static_cast<std::size_t>(3 * s + k);
      const double keep = x[i];
      x[i] = keep + h;
      const double plus = sim.evaluate(driver, true).value;
      x[i] = keep - h;
      const double minus = sim.evaluate(driver, true).value;
      x[i] = keep;
      const double fd = (plus - minus) / (2.0 * h);
      diff += (fd - gradient[i]) * (fd - gradient[i]);
      norm += gradient[i] * gradient[i];
    }
  }
  sim.evaluate(driver);
  return std::sqrt(diff / norm);
}

TEST(Amrc, PotentialGradientMatchesFiniteDifferencesWithGhosts) {
  for (bool obstacles : {false, true}) {
    kernels::SimulationConfig c = adaptive_cloth(2, 4, 3, true);
    if (obstacles) {
      kernels::ObstacleConfig sphere;
      sphere.kind = kernels::ObstacleKind::sphere;
      sphere.center = {0.2, 0.15, -0.05};
      sphere.radius = 0.0535;
      c.obstacles.push_back(sphere);
    }
    kernels::Simulation sim(c);
    build_graded_mesh(sim);
    testing::randomise_state(sim, 3);
    EXPECT_LT(gradient_error(sim), 1e-6) << (obstacles ? "with a sphere" : "free");
  }
}

TEST(Amrc, NumericGradientModeMatchesAnalyticWithGhosts) {
  kernels::SimulationConfig c = adaptive_cloth(2, 4, 3, true);
  kernels::Simulation analytic(c);
  c.solver.gradient = kernels::GradientMode::numeric;
  c.solver.numeric_step = 1e-5;
  kernels::Simulation numeric(c);
  for (kernels::Simulation* sim : {&analytic, &numeric}) {
    build_graded_mesh(*sim);
    testing::randomise_state(*sim, 9);
  }
  schedulers::OmpStaticDriver driver;
  analytic.evaluate(driver);
  numeric.evaluate(driver);
  double diff = 0.0, norm = 0.0;
  for (std::size_t i = 0; i < analytic.state().gradient.size(); ++i) {
    const double d = analytic.state().gradient[i] - numeric.state().gradient[i];
    diff += d * d;
    norm += analytic.state().gradient[i] * analytic.state().gradient[i];
  }
  EXPECT_LT(std::sqrt(diff / norm), 1e-6);
}

TEST(Amrc, ViolationGradientMatchesFiniteDifferencesWithGhosts) {
  // All terms, and the Newton residual alone (where the ghosts' forces handed to their parents
  // and the parents' adjoints handed back decide the gradient).
  for (bool newton_only : {false, true}) {
    kernels::SimulationConfig c = adaptive_cloth(2, 4, 3, true);
    c.solver.formulation = kernels::Formulation::violation;
    c.fabric.fm_gf_per_cm = 5.0;  // soft: E stays small enough for finite differences
    if (newton_only) c.solver.weight_stretch = c.solver.weight_bend = 0.0;
    kernels::Simulation sim(c);
    build_graded_mesh(sim);
    testing::randomise_state(sim, 4);
    EXPECT_LT(gradient_error(sim), 1e-5) << (newton_only ? "Newton term only" : "all terms");
  }
}

TEST(Amrc, OffMeansNoTreeAndNoEvents) {
  kernels::SimulationConfig c = adaptive_cloth(2, 2, 2);
  c.amrc.enabled = false;
  kernels::Simulation sim(c);
  EXPECT_EQ(sim.adaptive_mesh(), nullptr);
  schedulers::OmpStaticDriver driver;
  for (int step = 0; step < 4; ++step) EXPECT_FALSE(sim.step(driver).amrc.has_value());
  EXPECT_THROW(sim.adapt(), std::logic_error);
}

TEST(Amrc, NewParticlesStartOnTheInterpolatedSurface) {
  // 9 x 9 coarsened to four 4 x 4 cells, then one cell split down to the finest level: every
  // new particle (and new ghost) lies on the bilinear surface of the old cell that held it,
  // computed here from that cell's four corners, not by the code that refines.
  kernels::Simulation sim(adaptive_cloth(2, 2, 2));
  AdaptiveMesh& tree = sim.begin_tree_edit();
  for (int k = 1; k <= 2; ++k) {
    for (int a = 0; a < (4 >> (k - 1)); ++a) {
      for (int b = 0; b < (4 >> (k - 1)); ++b) tree.coarsen(TreeCell{k, a, b}, sim.mesh());
    }
  }
  sim.end_tree_edit();
  ASSERT_EQ(tree.leaves().size(), 4u);
  const std::vector<std::uint8_t> old_flags = sim.mesh().flags;
  const std::vector<double> old_position = sim.state().position;
  AdaptiveMesh& refine = sim.begin_tree_edit();
  refine.refine(TreeCell{2, 1, 0});
  for (int a = 2; a < 4; ++a) {
    for (int b = 0; b < 2; ++b) refine.refine(TreeCell{1, a, b});
  }
  sim.end_tree_edit();
  const ClothMesh& mesh = sim.mesh();
  auto old_x = [&](int i, int j) { return kernels::vec3(old_position, mesh.slot(i, j)); };
  int checked = 0, off_quarter = 0;
  for (int i = 0; i < mesh.size_i(); ++i) {
    for (int j = 0; j < mesh.size_j(); ++j) {
      const std::int64_t s = mesh.slot(i, j);
      const std::uint8_t f = mesh.flags[s];
      if (!kernels::is_node(f) || kernels::is_node(old_flags[s])) continue;
      const int i0 = std::min(i / 4, 1) * 4, j0 = std::min(j / 4, 1) * 4;
      const double u = (i - i0) / 4.0, v = (j - j0) / 4.0;
      const Eigen::Vector3d expected =
          (1 - u) * (1 - v) * old_x(i0, j0) + u * (1 - v) * old_x(i0 + 4, j0) +
          u * v * old_x(i0 + 4, j0 + 4) + (1 - u) * v * old_x(i0, j0 + 4);
      const Eigen::Vector3d x = kernels::vec3(sim.state().position, s);
      EXPECT_LT((x - expected).norm(), 1e-14) << "new node " << where(mesh, s);
      ++checked;
      if (u != 0.5 && v != 0.5) ++off_quarter;
    }
  }
  EXPECT_GT(checked, 20) << "the split must create new particles";
  EXPECT_GT(off_quarter, 0) << "new particles off the cell's mid-lines (u or v = 1/4, 3/4)";
  EXPECT_EQ(check_invariants(sim, "after the split"), 0);
}

TEST(Amrc, NewParticlesInsideAnObstacleMoveOutToTheContactLayer) {
  // A coarse sheet lying on a sphere (its particles at the contact distance d): refining it
  // puts new particles on the coarse bilinear surface, whose chords cut into the sphere.
  kernels::SimulationConfig c = adaptive_cloth(2, 2, 2);  // 9 x 9, spacing 2.5 cm
  c.cloth.initial_crumple = 0.0;
  kernels::ObstacleConfig sphere;
  sphere.kind = kernels::ObstacleKind::sphere;
  sphere.center = {0.1, 0.1, -0.2};
  sphere.radius = 0.16;
  c.obstacles.push_back(sphere);
  c.cloth.origin = {0.0, 0.0, 0.0};
  kernels::Simulation sim(c);
  const double d = c.contact.distance;
  AdaptiveMesh& tree = sim.begin_tree_edit();
  for (int k = 1; k <= 2; ++k) {
    for (int a = 0; a < (4 >> (k - 1)); ++a) {
      for (int b = 0; b < (4 >> (k - 1)); ++b) tree.coarsen(TreeCell{k, a, b}, sim.mesh());
    }
  }
  sim.end_tree_edit();
  const kernels::Obstacle ball(sphere);
  kernels::ClothState& st = sim.state();
  for (std::int64_t s = 0; s < sim.mesh().slot_count(); ++s) {
    if (!(sim.mesh().flags[s] & kernels::kParticleActive)) continue;
    Eigen::Vector3d x = kernels::vec3(st.position, s);
    const Eigen::Vector2d r(x.x() - 0.1, x.y() - 0.1);
    x.z() = sphere.center.z() + std::sqrt(sphere.radius * sphere.radius - r.squaredNorm()) + d;
    const Eigen::Vector3d velocity_step(0.001, 0.0, -0.002);
    kernels::vec3(st.position, s) = x;
    kernels::vec3(st.step_start, s) = x;
    kernels::vec3(st.target, s) = x + velocity_step;
  }
  const std::vector<double> coarse_surface = sim.surface_positions();
  AdaptiveMesh& refine = sim.begin_tree_edit();
  for (int a = 0; a < 2; ++a) {
    for (int b = 0; b < 2; ++b) refine.refine(TreeCell{2, a, b});
  }
  for (int a = 0; a < 4; ++a) {
    for (int b = 0; b < 4; ++b) refine.refine(TreeCell{1, a, b});
  }
  sim.end_tree_edit();
  EXPECT_EQ(check_invariants(sim, "after refining over the sphere"), 0);
  int lifted = 0;
  for (std::int64_t s = 0; s < sim.mesh().slot_count(); ++s) {
    ASSERT_TRUE(sim.mesh().flags[s] & kernels::kParticleActive) << "the finest mesh again";
    const Eigen::Vector3d x = kernels::vec3(st.position, s);
    const Eigen::Vector3d old = kernels::vec3(coarse_surface, s);
    if (ball.signed_distance(old) >= 0.0) {
      EXPECT_EQ(x, old) << "a particle outside the sphere stays on the old surface";
      continue;
    }
    ++lifted;
    EXPECT_NEAR(ball.signed_distance(x), d, 1e-12) << where(sim.mesh(), s);
    const Eigen::Vector3d carried = kernels::vec3(st.target, s) - kernels::vec3(st.step_start, s);
    EXPECT_LT((carried - Eigen::Vector3d(0.001, 0.0, -0.002)).norm(), 1e-15) << "velocity kept";
    EXPECT_EQ(kernels::vec3(st.step_start, s), x) << "x^n moves with x";
  }
  EXPECT_GT(lifted, 0) << "the coarse surface must cut into the sphere for this test to mean anything";
}

}  // namespace
}  // namespace clothbench
