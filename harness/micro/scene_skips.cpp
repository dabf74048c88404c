// What the kernel saves by skipping the work a scene does not need, one thread, CPU time of
// the calling thread (steadier than wall time on a shared machine):
//  - skip_contact: one objective evaluation of a 101 x 101 cloth draped on a box, with the
//    box touching the cloth (broad phase on / off), the box moved 10 m away (broad phase on /
//    off: every particle still asks for a distance when it is off) and no obstacle at all
//    (the contact terms loop over no obstacle: nothing is computed). Counter
//    `vs_no_obstacle` is the variant's time over the no-obstacle case, measured in the same
//    process.
//  - skip_amrc: the first steps of scenarios/box-101.toml with AMRC off and with AMRC on but idle
//    (L = 2, thresholds that never split or merge: the mesh stays the finest grid and only
//    the checks every 3 steps run), its 30 steps interleaved step by step; both must end in the same
//    bytes. `ratio_cpu` = AMRC idle / AMRC off.
//  - skip_inactive: one evaluation of a 257 x 257 cloth whose AMRC mesh has been coarsened
//    away from two lines (about a quarter of the elements active), by the `static@blocks`
//    scheduler (walks every slot and tests its flags) and `active-lists` (walks compact lists
//    of the active elements), against the same cloth uncoarsened. `time_share` is the
//    evaluation time over that of the full mesh, `active_share` the share of elements active.
// Select with --benchmark_filter=skip_ (about 7 minutes on 2 cores, most of it skip_amrc).
#include <benchmark/benchmark.h>
#include <omp.h>

#include <time.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "harness/micro/box_scene.hpp"
#include "harness/compare/compare_statistics.hpp"
#include "harness/micro/smoke.hpp"
#include "harness/scene/scene.hpp"
#include "kernels/simulation.hpp"
#include "schedulers/registry.hpp"
#include "schedulers/static_driver.hpp"

namespace {

using clothbench::kernels::AdaptiveMesh;
using clothbench::kernels::Simulation;
using clothbench::kernels::SimulationConfig;
using clothbench::kernels::TreeCell;

/// CPU time of the calling thread, s (with one OpenMP thread the work runs on it).
double thread_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

using clothbench::harness::median;  // of a non-empty sample (harness/compare)

using clothbench::micro::box_scene;

/// Mean CPU seconds of one evaluation of `sim` (after one refreshing evaluation), timed over
/// `evaluations` calls.
double evaluation_seconds(Simulation& sim, clothbench::schedulers::LoopDriver& driver,
                          int evaluations) {
  sim.evaluate(driver, true);
  const double start = thread_cpu_seconds();
  for (int k = 0; k < evaluations; ++k) benchmark::DoNotOptimize(sim.evaluate(driver, false).value);
  return (thread_cpu_seconds() - start) / evaluations;
}

enum ContactCase { touching_broad, touching_narrow, far_broad, far_narrow, no_obstacle };

void skip_contact(benchmark::State& state) {
  omp_set_num_threads(1);
  const auto which = static_cast<ContactCase>(state.range(0));
  clothbench::schedulers::OmpStaticDriver driver;
  static std::unique_ptr<Simulation> draped = [] {
    auto sim = std::make_unique<Simulation>(box_scene(101));
    clothbench::schedulers::OmpStaticDriver d;
    for (int k = 0; k < 6; ++k) sim->step(d);  // the sheet lands on the box
    return sim;
  }();
  SimulationConfig bare_config = draped->config();
  bare_config.obstacles.clear();
  Simulation bare(bare_config);
  bare.state() = draped->state();
  Simulation& sim = which == no_obstacle ? bare : *draped;
  const bool far = which == far_broad || which == far_narrow;
  if (far) draped->move_obstacle(0, {0, 0, -10});
  draped->set_broad_phase(which == touching_broad || which == far_broad);
  std::vector<double> ratio;
  for (auto _ : state) {
    const double t = evaluation_seconds(sim, driver, 20);
    const double t0 = evaluation_seconds(bare, driver, 20);
    ratio.push_back(t / t0);
    state.SetIterationTime(t);
  }
  if (far) draped->move_obstacle(0, {0, 0, 10});
  draped->set_broad_phase(true);
  state.counters["vs_no_obstacle"] = median(ratio);
  state.counters["active_particles"] = static_cast<double>(sim.diagnostics().active_particles);
}

void skip_amrc(benchmark::State& state) {
  omp_set_num_threads(1);
  const int kSteps = clothbench::micro::scaled(30, 3);  // the whole scene
  SimulationConfig off =
      clothbench::harness::load_scene(std::filesystem::path(CLOTHBENCH_SOURCE_DIR) /
                                          "scenarios/box-101.toml",
                                      clothbench::harness::default_presets_file())
          .simulation;
  clothbench::micro::shrink_for_smoke(off);
  SimulationConfig idle = off;
  idle.amrc.enabled = true;
  idle.amrc.levels = 2;
  idle.amrc.refine_threshold = 1e9;  // nothing to split: the mesh starts at the finest level
  idle.amrc.coarsen_threshold = -1;  // and nothing is ever merged
  clothbench::schedulers::OmpStaticDriver driver;
  std::vector<double> ratio, off_ms, idle_ms;
  for (auto _ : state) {
    Simulation a(off), b(idle);
    double t_off = 0, t_idle = 0;
    for (int k = 0; k < kSteps; ++k) {  // interleaved, the order swapped every step
      for (int half = 0; half < 2; ++half) {
        const bool first_off = (k + half) % 2 == 0;
        Simulation& s = first_off ? a : b;
        const double start = thread_cpu_seconds();
        s.step(driver);
        (first_off ? t_off : t_idle) += thread_cpu_seconds() - start;
      }
    }
    const auto& x = a.state().position;
    const auto& y = b.state().position;
    if (x.size() != y.size() || std::memcmp(x.data(), y.data(), x.size() * sizeof(double)) != 0) {
      state.SkipWithError("AMRC off and AMRC idle ended in different states");
      return;
    }
    off_ms.push_back(1e3 * t_off / kSteps);
    idle_ms.push_back(1e3 * t_idle / kSteps);
    ratio.push_back(t_idle / t_off);
    state.SetIterationTime(t_off + t_idle);
  }
  state.counters["off_cpu_ms_per_step"] = median(off_ms);
  state.counters["idle_cpu_ms_per_step"] = median(idle_ms);
  state.counters["ratio_cpu"] = median(ratio);
}

/// 257 x 257 with AMRC (L = 2), coarsened to level 2 wherever a cell does not touch the lines
/// 1/4 and 3/4 of the sheet (the finest level stays along them), then draped briefly.
std::unique_ptr<Simulation> coarsened_sheet(bool coarsen) {
  SimulationConfig c = box_scene(257);
  const int intervals = c.cloth.particles_i - 1;
  c.amrc.enabled = true;
  c.amrc.levels = 2;
  c.amrc.refine_threshold = 1e9;
  c.amrc.coarsen_threshold = -1;
  auto sim = std::make_unique<Simulation>(c);
  if (coarsen) {
    AdaptiveMesh& tree = sim->begin_tree_edit();
    for (int k = 1; k <= 2; ++k) {
      const int cells = intervals >> k;
      auto near_line = [&](int cell) {
        const double lo = double(cell << k) / intervals, hi = double((cell + 1) << k) / intervals;
        return (lo <= 0.25 && 0.25 <= hi) || (lo <= 0.75 && 0.75 <= hi);
      };
      for (int ci = 0; ci < cells; ++ci) {
        for (int cj = 0; cj < cells; ++cj) {
          if (!near_line(ci) && !near_line(cj)) tree.coarsen(TreeCell{k, ci, cj}, sim->mesh());
        }
      }
    }
    sim->end_tree_edit();
  }
  clothbench::schedulers::OmpStaticDriver driver;
  for (int k = 0; k < 2; ++k) sim->step(driver);
  return sim;
}

void skip_inactive(benchmark::State& state, const char* scheduler) {
  omp_set_num_threads(1);
  static std::unique_ptr<Simulation> full = coarsened_sheet(false);
  static std::unique_ptr<Simulation> graded = coarsened_sheet(true);
  const auto driver = clothbench::schedulers::make_driver(scheduler);
  std::vector<double> share;
  for (auto _ : state) {
    const double t = evaluation_seconds(*graded, *driver, 10);
    const double t_full = evaluation_seconds(*full, *driver, 10);
    share.push_back(t / t_full);
    state.SetIterationTime(t);
  }
  state.counters["time_share"] = median(share);
  state.counters["active_share"] =
      static_cast<double>(graded->active_elements()) / static_cast<double>(full->active_elements());
  state.counters["active_elements"] = static_cast<double>(graded->active_elements());
}

BENCHMARK(skip_contact)
    ->ArgName("case")  // 0 touching+broad, 1 touching, 2 far+broad, 3 far, 4 no obstacle
    ->DenseRange(touching_broad, no_obstacle)
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond)
    ->Repetitions(1)
    ->Iterations(15);
BENCHMARK(skip_amrc)->UseManualTime()->Unit(benchmark::kMillisecond)->Iterations(3);
BENCHMARK_CAPTURE(skip_inactive, static_blocks, "static@blocks")
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond)
    ->Iterations(10);
BENCHMARK_CAPTURE(skip_inactive, active_lists, "active-lists")
    ->UseManualTime()
    ->Unit(benchmark::kMicrosecond)
    ->Iterations(10);

}  // namespace
