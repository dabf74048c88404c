// AMRC bookkeeping at the paper's size (1001^2, L = 3): the Active-Lists rebuild, sequential
// (as the paper built its lists) against the parallel prefix-sum compaction, and one mesh
// rewrite from the tree, at 1 and 2 (or more) threads. The mesh is the shape AMRC gives a
// cloth on a box: coarsest far away and on the flat top, finest along the box outline.
#include <benchmark/benchmark.h>
#include <omp.h>

#include <cmath>
#include <memory>

#include "harness/micro/smoke.hpp"
#include "kernels/simulation.hpp"

namespace {

using clothbench::kernels::AdaptiveMesh;
using clothbench::kernels::ListBuild;
using clothbench::kernels::Simulation;
using clothbench::kernels::TreeCell;

std::unique_ptr<Simulation> graded_box_mesh() {
  // 1001 = 2^3 x 125 + 1; a smoke run takes 33 = 2^3 x 4 + 1 (smoke.hpp).
  const int n = clothbench::micro::scaled(1001, 33);
  const int intervals = n - 1;
  clothbench::kernels::SimulationConfig c;
  c.cloth.particles_i = c.cloth.particles_j = n;
  c.cloth.size_i = c.cloth.size_j = 1.0;
  c.amrc.enabled = true;
  c.amrc.levels = 3;
  auto sim = std::make_unique<Simulation>(c);
  AdaptiveMesh& tree = sim->begin_tree_edit();
  // Merge every level-3 cell that does not touch the lines 1/4 and 3/4 of the sheet.
  for (int k = 1; k <= 3; ++k) {
    const int cells = intervals >> k;
    for (int ci = 0; ci < cells; ++ci) {
      for (int cj = 0; cj < cells; ++cj) {
        auto near_outline = [&](int c) {
          const double lo = double(c << k) / intervals, hi = double((c + 1) << k) / intervals;
          return (lo <= 0.25 && 0.25 <= hi) || (lo <= 0.75 && 0.75 <= hi);
        };
        if (near_outline(ci) || near_outline(cj)) continue;
        tree.coarsen(TreeCell{k, ci, cj}, sim->mesh());
      }
    }
  }
  sim->end_tree_edit();
  return sim;
}

void list_rebuild(benchmark::State& state, ListBuild build) {
  const int threads = static_cast<int>(state.range(0));
  omp_set_num_threads(threads);
  static std::unique_ptr<Simulation> sim = graded_box_mesh();
  sim->set_list_build(build);
  sim->rebuild_lists();
  for (auto _ : state) benchmark::DoNotOptimize(sim->rebuild_lists());
  state.counters["threads"] = threads;
  state.counters["active_particles"] = static_cast<double>(sim->active_lists()->particles.size());
  state.counters["slots_per_second"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * static_cast<double>(sim->mesh().slot_count()),
      benchmark::Counter::kIsRate);
}

void mesh_rewrite(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  omp_set_num_threads(threads);
  static std::unique_ptr<Simulation> sim = graded_box_mesh();
  for (auto _ : state) {
    sim->begin_tree_edit();
    sim->end_tree_edit();
  }
  state.counters["threads"] = threads;
}

void thread_counts(benchmark::internal::Benchmark* b) {
  const int cores = omp_get_num_procs();
  for (int t = 1; t <= cores; t *= 2) b->Arg(t);
  b->UseRealTime()->Unit(benchmark::kMillisecond);
}

BENCHMARK_CAPTURE(list_rebuild, sequential, ListBuild::sequential)->Apply(thread_counts);
BENCHMARK_CAPTURE(list_rebuild, parallel_prefix_sum, ListBuild::parallel_prefix_sum)
    ->Apply(thread_counts);
BENCHMARK(mesh_rewrite)->Apply(thread_counts);

}  // namespace
