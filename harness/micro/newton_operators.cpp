// The Newton solver's linear operators on the draped box at 101^2, 301^2 and 1001^2
// particles (the same state as the gradient benchmarks, harness/micro/box_scene.hpp): the
// model Hessian's product y = H v (ModelHessian::apply, three loops: ghosts, triples, the
// particle gather), one V(1,1) cycle z = B r (VcyclePreconditioner::apply: the line
// Gauss-Seidel sweeps, residuals, restriction and prolongation on every level, the coarsest
// level's direct solve), and the V-cycle's factorisation for a new model of the same
// structure (Galerkin values and line factors; the structure is made once, in the set-up).
// `vcycle_apply_one_line` is the same cycle with one line per smoothing task instead of two
// (VcyclePreconditioner::set_lines_per_task; the same bits), so that the two compare as a
// ratio within one run (add --benchmark_enable_random_interleaving=true on a noisy host).
// These are what one inner PCG iteration and one Newton iteration cost besides the gradient;
// compare them with `gradient/` as ns_per_element within one run.
//
// Counters: elements/s and ns per element (active particles + edges + triples, as in
// `gradient/`), the V-cycle's levels, level-0 nodes and the bytes its hierarchy holds (its
// operators, prolongations, line factors and vectors: a cycle reads each level's operator
// and line factors several times, so they set its memory traffic).
#include <benchmark/benchmark.h>
#include <omp.h>

#include <memory>
#include <random>
#include <string>
#include <vector>

#include "harness/micro/box_scene.hpp"
#include "harness/micro/smoke.hpp"
#include "kernels/potential_objective.hpp"
#include "kernels/simulation.hpp"
#include "schedulers/static_driver.hpp"

namespace {

using clothbench::kernels::LoopRunner;
using clothbench::kernels::Simulation;

/// Newton's objective over the draped box's state: its model assembled there and the V-cycle
/// factorised for it. Kept while the draped box is (the 1001^2 hierarchy holds 2.1 GiB).
struct NewtonOperators {
  explicit NewtonOperators(Simulation& s)
      : sim(s),
        config(newton_config(s.config())),
        ctx{s.mesh(), s.material(), s.obstacles(), config, s.state()},
        objective(ctx) {
    const auto n = s.state().position.size();
    v.assign(n, 0.0);
    y.assign(n, 0.0);
    std::mt19937 rng(20261128);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    for (std::int64_t slot = 0; slot < s.mesh().slot_count(); ++slot) {
      if (!ctx.is_free(slot)) continue;
      for (int k = 0; k < 3; ++k) v[3 * static_cast<std::size_t>(slot) + k] = unit(rng);
    }
    region([&](LoopRunner& run) {
      clothbench::kernels::refresh_ghosts(run, s.mesh(), s.state().position);
      objective.prepare_history(run);
      (void)objective.evaluate(run);
      objective.assemble_newton(run, /*new_step=*/true);
    });
  }
  static clothbench::kernels::SimulationConfig newton_config(
      clothbench::kernels::SimulationConfig c) {
    c.solver.method = clothbench::kernels::StepMethod::newton;
    c.solver.preconditioner = clothbench::kernels::Preconditioner::vcycle;
    c.solver.vcycle_after = 0;  // the V-cycle from the first assembly
    return c;
  }
  /// Runs f(run) on every thread of one parallel region.
  template <class F>
  void region(F&& f) {
#pragma omp parallel
    {
      LoopRunner run(driver, sim.mesh(), nullptr, clothbench::kernels::Instrumentation::off,
                     nullptr);
      f(run);
    }
  }
  Simulation& sim;
  clothbench::kernels::SimulationConfig config;
  clothbench::kernels::StepContext ctx;
  clothbench::kernels::PotentialObjective objective;
  clothbench::schedulers::OmpStaticDriver driver;
  std::vector<double> v, y;
};

/// The operators over the current draped box (made again when the box is: the last one's
/// references would be left dangling).
NewtonOperators& operators(int n) {
  static std::unique_ptr<NewtonOperators> cached;
  static int generation = 0;
  Simulation& sim = clothbench::micro::draped_box(n, clothbench::kernels::Formulation::potential,
                                                  clothbench::kernels::ElementKernel::reference);
  const int now = clothbench::micro::draped_box_cache().generation;
  if (!cached || generation != now) {
    cached.reset();
    cached = std::make_unique<NewtonOperators>(sim);
    generation = now;
  }
  return *cached;
}

enum class Operator { hessian_apply, vcycle_apply, vcycle_apply_one_line, vcycle_factor };

void newton_operator(benchmark::State& state, Operator op) {
  const int n = static_cast<int>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  omp_set_num_threads(threads);
  NewtonOperators& o = operators(n);
  clothbench::kernels::VcyclePreconditioner& vcycle = *o.objective.vcycle();
  clothbench::kernels::ModelHessian& hessian = *o.objective.model_hessian();
  auto once = [&] {
    o.region([&](LoopRunner& run) {
      switch (op) {
        case Operator::hessian_apply:
          (void)hessian.apply(run, o.ctx, o.v, o.y);
          break;
        case Operator::vcycle_apply:
        case Operator::vcycle_apply_one_line:
          vcycle.apply(run, o.ctx, o.v, o.y);
          break;
        case Operator::vcycle_factor:
          vcycle.factor(run, o.ctx, hessian);
          break;
      }
    });
  };
  const int lines_per_task = vcycle.lines_per_task();
  vcycle.set_lines_per_task(op == Operator::vcycle_apply_one_line ? 1 : lines_per_task);
  once();  // warm
  for (auto _ : state) {
    once();
    benchmark::DoNotOptimize(o.y.data());
  }
  vcycle.set_lines_per_task(lines_per_task);
  std::string label = "scalar";
  if (clothbench::micro::smoke()) label += " smoke";
  state.SetLabel(label);
  const double calls = static_cast<double>(state.iterations());
  clothbench::micro::set_element_counters(state,
                                          calls * static_cast<double>(o.sim.active_elements()));
  state.counters["levels"] = vcycle.levels();
  state.counters["level0_nodes"] = static_cast<double>(vcycle.level_nodes(0));
  state.counters["hierarchy_bytes"] = benchmark::Counter(
      static_cast<double>(vcycle.memory_bytes()), benchmark::Counter::kDefaults,
      benchmark::Counter::kIs1024);
  state.counters["threads"] = threads;
}

BENCHMARK_CAPTURE(newton_operator, hessian_apply, Operator::hessian_apply)
    ->Apply(clothbench::micro::box_sizes);
BENCHMARK_CAPTURE(newton_operator, vcycle_apply, Operator::vcycle_apply)
    ->Apply(clothbench::micro::box_sizes);
BENCHMARK_CAPTURE(newton_operator, vcycle_apply_one_line, Operator::vcycle_apply_one_line)
    ->Apply(clothbench::micro::box_sizes);
BENCHMARK_CAPTURE(newton_operator, vcycle_factor, Operator::vcycle_factor)
    ->Apply(clothbench::micro::box_sizes);

}  // namespace
