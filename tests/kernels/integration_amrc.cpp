// AMRC in whole runs (MODEL.md 6): a flat cloth resting on a table coarsens to the coarsest
// level everywhere; a cloth lying on a box coarsens its flat top and far parts and keeps fine
// cells along the box edges; mass stays exact and no ghost leaves its edge's midpoint.
#include <gtest/gtest.h>

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "kernel_fixtures.hpp"
#include "kernels/amrc.hpp"
#include "kernels/model_hessian.hpp"
#include "schedulers/registry.hpp"

namespace clothbench {
namespace {

/// Level of the leaf over the sheet point (x, y) in metres from the sheet's corner.
int level_at(const kernels::Simulation& sim, double x, double y) {
  const kernels::AdaptiveMesh& tree = *sim.adaptive_mesh();
  const int fi = std::min(tree.cells_i() - 1, static_cast<int>(x / sim.mesh().spacing(0)));
  const int fj = std::min(tree.cells_j() - 1, static_cast<int>(y / sim.mesh().spacing(1)));
  return tree.leaf_level(fi, fj);
}

void expect_sound(const kernels::Simulation& sim) {
  const kernels::StateDiagnostics d = sim.diagnostics();
  const double expected = sim.mesh().areal_density() * sim.config().cloth.size_i * sim.config().cloth.size_j;
  EXPECT_NEAR(d.total_mass, expected, 1e-12 * expected);
  EXPECT_EQ(d.max_ghost_offset, 0.0);
  EXPECT_TRUE(d.finite);
  EXPECT_TRUE(sim.adaptive_mesh()->balanced());
}

TEST(AmrcDrape, FlatClothOnATableCoarsensToTheCoarsestLevel) {
  kernels::SimulationConfig c;
  c.cloth.particles_i = c.cloth.particles_j = 33;  // 2^3 * 4 + 1
  c.cloth.block_size = 8;
  c.cloth.size_i = c.cloth.size_j = 0.64;
  const double table_top = 0.75, d = c.contact.distance;
  c.cloth.origin = {-0.32, -0.32, table_top + d - d / c.contact.stiffness};
  kernels::ObstacleConfig table;
  table.kind = kernels::ObstacleKind::box;
  table.center = {0.0, 0.0, table_top / 2};
  table.half_extents = {0.5, 0.5, table_top / 2};
  c.obstacles.push_back(table);
  c.solver.tolerance = 1e-6;
  c.amrc.enabled = true;
  c.amrc.levels = 3;
  c.amrc.check_every = 3;
  kernels::Simulation sim(c);
  schedulers::OmpStaticDriver driver;
  std::vector<std::int64_t> particles;
  for (int step = 1; step <= 12; ++step) {
    const kernels::StepReport r = sim.step(driver);
    EXPECT_EQ(r.amrc.has_value(), step % 3 == 0) << "step " << step;
    if (r.amrc) particles.push_back(r.amrc->particles);
    expect_sound(sim);
  }
  // One level per check: 33^2 -> 17^2 -> 9^2 -> 5^2, then nothing left to merge.
  EXPECT_EQ(particles, (std::vector<std::int64_t>{17 * 17, 9 * 9, 5 * 5, 5 * 5}));
  for (const kernels::TreeCell& leaf : sim.adaptive_mesh()->leaves()) EXPECT_EQ(leaf.level, 3);
  const kernels::StateDiagnostics diag = sim.diagnostics();
  EXPECT_NEAR(diag.contact_support / diag.weight, 1.0, 1e-6);
}

kernels::SimulationConfig box_scene() {
  kernels::SimulationConfig c;
  c.cloth.particles_i = c.cloth.particles_j = 33;  // 2^2 * 8 + 1
  c.cloth.block_size = 16;
  c.cloth.size_i = c.cloth.size_j = 1.0;
  c.cloth.origin = {-0.5, -0.5, 0.2515};  // lying on the box top (z = 0.25) from the start
  c.obstacles.push_back(testing::box_obstacle({0.0, 0.0, 0.125}, {0.25, 0.25, 0.125}));
  c.time.step = 0.004;
  c.time.damping = 0.1;
  c.solver.tolerance = 1e-2;
  c.solver.max_iterations = 300;
  c.amrc.enabled = true;
  c.amrc.levels = 2;
  return c;
}

TEST(AmrcDrape, ClothOnABoxKeepsFineCellsAlongTheBoxEdges) {
  kernels::Simulation sim(box_scene());
  schedulers::OmpStaticDriver driver;
  for (int step = 0; step < 12; ++step) {
    sim.step(driver);
    expect_sound(sim);
  }
  EXPECT_EQ(level_at(sim, 0.5, 0.5), 2) << "the middle of the flat top";
  EXPECT_EQ(level_at(sim, 0.02, 0.02), 2) << "a far corner";
  EXPECT_EQ(level_at(sim, 0.98, 0.5), 2) << "the middle of a far side";
  for (double along : {0.3, 0.5, 0.7}) {
    // The box edges run along x = 0.25 and x = 0.75 (and the same in y) in sheet coordinates.
    EXPECT_EQ(level_at(sim, 0.24, along), 0) << "box edge x = 0.25, y = " << along;
    EXPECT_EQ(level_at(sim, 0.76, along), 0) << "box edge x = 0.75, y = " << along;
    EXPECT_EQ(level_at(sim, along, 0.24), 0) << "box edge y = 0.25, x = " << along;
    EXPECT_EQ(level_at(sim, along, 0.76), 0) << "box edge y = 0.75, x = " << along;
  }
  EXPECT_GT(sim.mesh().ghost_count(), 0);
  const kernels::StateDiagnostics d = sim.diagnostics();
  EXPECT_LT(d.active_particles, 33 * 33 / 2) << "at least half the particles merged away";
  EXPECT_GT(d.min_particle_distance, 0.0);
}

TEST(AmrcDrape, ThrashingThresholdsStayFiniteExactAndCrackFree) {
  // Thresholds closer than a factor two: what is merged turns more than the refine threshold
  // at the next check and is split again. Checked after every step.
  kernels::SimulationConfig c = box_scene();
  c.amrc.check_every = 1;
  c.amrc.refine_threshold = 0.012;
  c.amrc.coarsen_threshold = 0.01;
  kernels::Simulation sim(c);
  auto driver = schedulers::make_driver("active-lists");
  std::int64_t splits = 0, merges = 0;
  for (int step = 0; step < 24; ++step) {
    const kernels::StepReport r = sim.step(*driver);
    ASSERT_TRUE(r.amrc.has_value());
    splits += r.amrc->refined;
    merges += r.amrc->coarsened;
    expect_sound(sim);
    ASSERT_TRUE(std::isfinite(r.minimiser.final.cost)) << "step " << r.step;
    EXPECT_GT(sim.diagnostics().min_particle_distance, 0.0) << "step " << r.step;
  }
  EXPECT_GT(splits, 0);
  EXPECT_GT(merges, 0);
}

TEST(AmrcDrape, ListsAndBlocksGiveTheSameBytesWhileTheMeshCoarsens) {
  // Whole tiles of the lists fall empty when the mesh coarsens; their reductions must not
  // see what those tiles held before (a stale partial once stalled every line search).
  auto run = [](const std::string& scheduler, int threads) {
    omp_set_num_threads(threads);
    kernels::SimulationConfig c = box_scene();
    c.cloth.block_size = 4;  // many tiles, most of them empty on the coarse mesh
    kernels::Simulation sim(c);
    auto driver = schedulers::make_driver(scheduler);
    std::vector<double> out;
    for (int step = 0; step < 9; ++step) {
      const kernels::StepReport r = sim.step(*driver);
      out.push_back(r.minimiser.final.cost);
      out.push_back(r.minimiser.final.value);
      out.push_back(static_cast<double>(r.minimiser.iterations));
    }
    out.insert(out.end(), sim.state().position.begin(), sim.state().position.end());
    return out;
  };
  const std::vector<double> reference = run("static", 1);
  for (const std::string scheduler : {"active-lists", "dynamic:1@active", "static"}) {
    for (int threads : {1, 2, 3}) {
      const std::vector<double> other = run(scheduler, threads);
      ASSERT_EQ(other.size(), reference.size());
      EXPECT_EQ(std::memcmp(other.data(), reference.data(), reference.size() * sizeof(double)), 0)
          << scheduler << " with " << threads << " threads";
    }
  }
}

TEST(AmrcDrape, HandingBackUnusedSlotsPagesKeepsEveryBit) {
  // After each AMRC event the pages of slots that are neither particle nor ghost go back to the
  // system (kernels/slot_pages.hpp) and read as zero from then on. Nothing may read them while
  // unused: a run that hands them back must give the bits of one that keeps them, also where
  // the mesh refines again into slots whose pages went back. Newton (V-cycle) and nonlinear CG
  // (block Jacobi, whose gradient history and blocks are handed back too).
  struct Run {
    std::vector<double> out;
    std::size_t released = 0;
    std::int64_t reactivated = 0;  ///< slots read as zero after an event, nodes at a later one
    std::int64_t remembered = 0;   ///< inactive triples with bending memory after an event
    std::int64_t marked = 0;       ///< NaN marks an event left in the scratch arrays
    std::int64_t misfiled = 0;     ///< Active-Lists that differ from the live elements
    std::int64_t stale = 0;        ///< forces kept by elements an event took away
    std::int64_t loaded = 0;       ///< forces that are not zero after an event
  };
  auto run = [](kernels::StepMethod method, bool release) {
    kernels::SimulationConfig c = box_scene();
    c.cloth.particles_i = c.cloth.particles_j = 129;  // 2^3 * 16 + 1
    c.cloth.block_size = 64;  // rows of 64 slots: a coarse region's empty rows fill whole pages
    c.amrc.levels = 3;
    c.amrc.check_every = 2;
    c.solver.method = method;
    kernels::Simulation sim(c);
    sim.set_release_unused_pages(release);
    auto driver = schedulers::make_driver("active-lists");
    Run r;
    std::vector<std::uint8_t> zeroed(static_cast<std::size_t>(sim.mesh().slot_count()), 0);
    for (int step = 0; step < 12; ++step) {
      const kernels::StepReport report = sim.step(*driver);
      r.out.push_back(report.minimiser.final.cost);
      r.out.push_back(report.minimiser.final.value);
      r.out.push_back(static_cast<double>(report.minimiser.iterations));
      r.out.push_back(static_cast<double>(report.minimiser.linear_iterations));
      if (!report.amrc) continue;
      r.released += report.amrc->released_bytes;
      if (const kernels::ModelHessian* model = sim.model_hessian()) {
        // An element the event took away keeps no stiffness memory (forget_inactive).
        for (std::int64_t id = 0; id < 2 * sim.mesh().slot_count(); ++id) {
          if (!sim.mesh().triple_active[static_cast<std::size_t>(id)] &&
              (model->bending_stiffness(id) != 0.0 || model->bending_along(id) != 0.0)) {
            ++r.remembered;
          }
        }
      }
      const kernels::ClothState& st = sim.state();
      // The event writes its fields of the old forces only at the ids of the old elements
      // (AdaptiveMesh::begin_change), never a mark at every id: an unused slot's scratch pages
      // stay with the system. Evaluations write finite values only.
      for (const std::vector<double>* v : {&st.edge_scratch, &st.triple_scratch}) {
        r.marked += std::count_if(v->begin(), v->end(), [](double x) { return std::isnan(x); });
      }
      // An element the event took away keeps no force: forces are handed back with the unused
      // slots' pages, and the state must not depend on whether they were.
      for (std::int64_t id = 0; id < 2 * sim.mesh().slot_count(); ++id) {
        const auto k = static_cast<std::size_t>(id);
        if (!sim.mesh().edge_active[k] && st.edge_force[k] != 0.0) ++r.stale;
        if (!sim.mesh().triple_active[k] && st.triple_moment[k] != 0.0) ++r.stale;
        if (st.edge_force[k] != 0.0 || st.triple_moment[k] != 0.0) ++r.loaded;
      }
      // The lists' pages beyond their entries go back too; a list that grows again into them
      // holds exactly the live elements.
      const kernels::ActiveLists& lists = *sim.active_lists();
      for (const kernels::ElementKind kind :
           {kernels::ElementKind::particles, kernels::ElementKind::edges,
            kernels::ElementKind::triples, kernels::ElementKind::ghosts}) {
        std::vector<std::int32_t> live;
        for (std::int64_t id = 0; id < kernels::ids_per_slot(kind) * sim.mesh().slot_count(); ++id) {
          if (kernels::element_is_live(sim.mesh(), kind, id)) {
            live.push_back(static_cast<std::int32_t>(id));
          }
        }
        r.misfiled += lists.of(kind).entries == live ? 0 : 1;
      }
      for (std::int64_t s = 0; s < sim.mesh().slot_count(); ++s) {
        const bool node = kernels::is_node(sim.mesh().flags[static_cast<std::size_t>(s)]);
        if (node && zeroed[static_cast<std::size_t>(s)]) ++r.reactivated;
        // x^n is never the origin on this sheet (it lies at z = 0.2515 and falls from there):
        // an unused slot's x^n of exactly zero is a page that went back.
        const bool zero = st.step_start[3 * s] == 0.0 && st.step_start[3 * s + 1] == 0.0 &&
                          st.step_start[3 * s + 2] == 0.0;
        zeroed[static_cast<std::size_t>(s)] = !node && zero ? 1 : 0;
      }
    }
    const kernels::ClothState& st = sim.state();
    for (const std::vector<double>* v : {&st.position, &st.edge_force, &st.triple_moment}) {
      r.out.insert(r.out.end(), v->begin(), v->end());
    }
    return r;
  };
  for (const kernels::StepMethod method :
       {kernels::StepMethod::newton, kernels::StepMethod::nonlinear_cg}) {
    const Run kept = run(method, false), handed = run(method, true);
    EXPECT_EQ(kept.released, 0u);
    EXPECT_EQ(kept.remembered, 0) << kernels::to_string(method);
    EXPECT_EQ(handed.remembered, 0) << kernels::to_string(method);
    EXPECT_EQ(kept.marked, 0) << kernels::to_string(method);
    EXPECT_EQ(handed.marked, 0) << kernels::to_string(method);
    EXPECT_EQ(handed.misfiled, 0) << kernels::to_string(method);
    EXPECT_EQ(kept.stale, 0) << kernels::to_string(method);
    EXPECT_GT(kept.loaded, 0) << kernels::to_string(method) << ": no element carries a force";
    ASSERT_EQ(handed.out.size(), kept.out.size());
    EXPECT_EQ(std::memcmp(handed.out.data(), kept.out.data(), kept.out.size() * sizeof(double)), 0)
        << kernels::to_string(method);
#if defined(__linux__)
    EXPECT_GT(handed.released, 0u) << kernels::to_string(method);
    EXPECT_GT(handed.reactivated, 0)
        << kernels::to_string(method) << ": no slot whose page went back was used again";
    EXPECT_EQ(kept.reactivated, 0) << "the slots keep their values when nothing is handed back";
#endif
  }
}

}  // namespace
}  // namespace clothbench
