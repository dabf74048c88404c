// The loop runner presents the Active-Lists to an @active driver (paper section 4.3): its
// loops hand the driver one iteration per live element and visit exactly the live elements,
// and a missing list is an error, never a silent fall-back to blocks. Over blocks or over
// lists the results are bit-identical, so the bit-identity tests cannot see which space ran:
// these tests watch the iteration counts the driver receives.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "kernel_fixtures.hpp"
#include "kernels/amrc.hpp"
#include "kernels/loop_runner.hpp"
#include "kernels/simulation.hpp"
#include "schedulers/registry.hpp"

namespace clothbench {
namespace {

using kernels::ElementKind;

/// Forwards to another driver and records the iteration count of every loop (thread 0's).
class RecordingDriver final : public schedulers::LoopDriver {
 public:
  explicit RecordingDriver(std::unique_ptr<schedulers::LoopDriver> inner) : inner_(std::move(inner)) {}
  void for_range(std::int64_t n, schedulers::RangeBody body) override {
    if (omp_get_thread_num() == 0) counts.push_back(n);
    inner_->for_range(n, body);
  }
  [[nodiscard]] schedulers::IterationSpace space() const override { return inner_->space(); }
  [[nodiscard]] std::string name() const override { return inner_->name(); }
  std::vector<std::int64_t> counts;

 private:
  std::unique_ptr<schedulers::LoopDriver> inner_;
};

/// 17 x 13 particles with AMRC, graded to levels 0-2 with ghosts between; blocks of 6 x 6.
kernels::SimulationConfig graded_config() {
  kernels::SimulationConfig c = testing::small_cloth(false, true);
  c.cloth.particles_i = 17;
  c.cloth.particles_j = 13;
  c.cloth.size_i = 0.025 * 16;
  c.cloth.size_j = 0.025 * 12;
  c.cloth.block_size = 6;
  c.cloth.pinned = {{0, 0}, {16, 12}};
  c.amrc.enabled = true;
  c.amrc.levels = 2;
  // A nonlinear CG step: element and particle loops only (the V-cycle's loops also run over
  // its coarse levels' lines: unit_multigrid, conformance_bit_identity).
  c.solver.method = kernels::StepMethod::nonlinear_cg;
  return c;
}

void grade(kernels::Simulation& sim) {
  kernels::AdaptiveMesh& tree = sim.begin_tree_edit();
  for (int k = 1; k <= 2; ++k) {
    for (int a = 0; a < (tree.cells_i() >> k); ++a) {
      for (int b = 0; b < (tree.cells_j() >> k); ++b) {
        tree.coarsen(kernels::TreeCell{k, a, b}, sim.mesh());
      }
    }
  }
  tree.refine(kernels::TreeCell{2, 1, 1});
  tree.refine(kernels::TreeCell{1, 2, 2});
  sim.end_tree_edit();
}

constexpr ElementKind kKinds[] = {ElementKind::particles, ElementKind::edges,
                                  ElementKind::triples, ElementKind::ghosts};

/// How often each element id of `kind` was visited by one for_each through `driver`.
std::vector<int> visits(const kernels::Simulation& sim, schedulers::LoopDriver& driver,
                        const kernels::ActiveLists* lists, ElementKind kind, int threads) {
  std::vector<int> count(static_cast<std::size_t>(kernels::ids_per_slot(kind) * sim.mesh().slot_count()), 0);
#pragma omp parallel num_threads(threads)
  {
    kernels::LoopRunner run(driver, sim.mesh(), lists, kernels::Instrumentation::off, nullptr);
    run.for_each(kind, kernels::LoopBytes{}, [&](std::int64_t id) {
#pragma omp atomic
      ++count[static_cast<std::size_t>(id)];
    });
  }
  return count;
}

TEST(LoopRunner, AnActiveLoopVisitsExactlyTheLiveElementsThroughTheLists) {
  kernels::Simulation sim(graded_config());
  grade(sim);
  sim.rebuild_lists();
  const kernels::ActiveLists* lists = sim.active_lists();
  ASSERT_NE(lists, nullptr);
  ASSERT_GT(sim.mesh().ghost_count(), 0);
  const std::int64_t blocks = sim.mesh().block_count();
  for (const int threads : {1, 2}) {
    for (const ElementKind kind : kKinds) {
      const std::string context =
          "kind " + std::to_string(static_cast<int>(kind)) + ", " + std::to_string(threads) + " threads";
      RecordingDriver active(schedulers::make_driver("active-lists"));
      RecordingDriver blockwise(schedulers::make_driver("static"));
      const std::vector<int> over_lists = visits(sim, active, lists, kind, threads);
      const std::vector<int> over_blocks = visits(sim, blockwise, nullptr, kind, threads);
      std::int64_t live = 0;
      for (std::size_t id = 0; id < over_lists.size(); ++id) {
        const bool is_live = kernels::element_is_live(sim.mesh(), kind, static_cast<std::int64_t>(id));
        live += is_live ? 1 : 0;
        ASSERT_EQ(over_lists[id], is_live ? 1 : 0) << context << ", id " << id;
        ASSERT_EQ(over_blocks[id], is_live ? 1 : 0) << context << ", id " << id;
      }
      ASSERT_NE(live, blocks) << "the two spaces must differ in size for this test to mean anything";
      // The driver sees one iteration per live element over the lists, one per block otherwise.
      EXPECT_EQ(active.counts, std::vector<std::int64_t>{live}) << context;
      EXPECT_EQ(lists->of(kind).size(), live) << context;
      EXPECT_EQ(blockwise.counts, std::vector<std::int64_t>{blocks}) << context;
    }
  }
}

TEST(LoopRunner, AnActiveDriverWithoutListsIsAnError) {
  kernels::Simulation sim(graded_config());
  const auto active = schedulers::make_driver("active-lists");
  EXPECT_THROW(kernels::LoopRunner(*active, sim.mesh(), nullptr, kernels::Instrumentation::off, nullptr),
               std::logic_error);
  const auto blocks = schedulers::make_driver("dynamic:2");
  EXPECT_NO_THROW(kernels::LoopRunner(*blocks, sim.mesh(), nullptr, kernels::Instrumentation::off, nullptr));
  // Any scheduler may run over the lists when asked to (@active).
  const auto dynamic_active = schedulers::make_driver("dynamic:2@active");
  EXPECT_THROW(kernels::LoopRunner(*dynamic_active, sim.mesh(), nullptr, kernels::Instrumentation::off, nullptr),
               std::logic_error);
}

/// The iteration counts a driver saw during one step of the graded cloth with `threads`.
std::vector<std::int64_t> step_counts(const std::string& scheduler, int threads,
                                      std::vector<std::int64_t>* list_sizes,
                                      std::int64_t* blocks, std::set<std::int64_t>* lines) {
  kernels::Simulation sim(graded_config());
  grade(sim);
  RecordingDriver driver(schedulers::make_driver(scheduler));
  omp_set_num_threads(threads);
  sim.step(driver);
  omp_set_num_threads(1);
  if (const kernels::ActiveLists* lists = sim.active_lists()) {
    for (const ElementKind kind : kKinds) list_sizes->push_back(lists->of(kind).size());
  }
  *blocks = sim.mesh().block_count();
  *lines = {sim.mesh().size_i(), sim.mesh().size_j()};  // the line solves' for_index loops
  return driver.counts;
}

TEST(LoopRunner, AStepWithTheActiveListsDriverRunsEveryElementLoopOverTheLists) {
  for (const int threads : {1, 2}) {
    std::vector<std::int64_t> list_sizes;
    std::set<std::int64_t> lines;
    std::int64_t blocks = 0;
    const std::vector<std::int64_t> counts =
        step_counts("active-lists", threads, &list_sizes, &blocks, &lines);
    ASSERT_EQ(list_sizes.size(), 4u) << "a step with active-lists builds the lists";
    ASSERT_EQ(std::count(list_sizes.begin(), list_sizes.end(), blocks), 0);
    ASSERT_GT(counts.size(), 10u);
    const std::set<std::int64_t> sizes(list_sizes.begin(), list_sizes.end());
    for (const std::int64_t n : counts) {
      EXPECT_TRUE(sizes.count(n) == 1 || lines.count(n) == 1)
          << "a loop of " << n << " iterations (blocks: " << blocks << ")";
    }
    // Every kind's loop ran over its list.
    for (std::size_t k = 0; k < list_sizes.size(); ++k) {
      EXPECT_NE(std::find(counts.begin(), counts.end(), list_sizes[k]), counts.end())
          << "no loop over list " << k << " (" << list_sizes[k] << " entries)";
    }
  }
  // The same step over blocks: every element loop is one iteration per block.
  std::vector<std::int64_t> list_sizes;
  std::set<std::int64_t> lines;
  std::int64_t blocks = 0;
  const std::vector<std::int64_t> counts = step_counts("static", 2, &list_sizes, &blocks, &lines);
  EXPECT_TRUE(list_sizes.empty()) << "no lists are built for a driver over blocks";
  for (const std::int64_t n : counts) {
    EXPECT_TRUE(n == blocks || lines.count(n) == 1) << "a loop of " << n << " iterations";
  }
}

}  // namespace
}  // namespace clothbench
