// Timing, accounting and verification of one sweep run (see measured_run.hpp).
#include "harness/sweep/measured_run.hpp"

#include <fmt/core.h>
#include <omp.h>

#include <cmath>
#include <numeric>

#include "harness/run/disturbance.hpp"
#include "harness/run/verify.hpp"

namespace clothbench::harness {

OverheadAccounting account(const kernels::LoopTimes& times, double wall_seconds,
                           double step_seconds) {
  OverheadAccounting a;
  a.wall_seconds = wall_seconds;
  a.step_seconds = step_seconds;
  a.sequential_overhead = step_seconds - times.loop_wall;
  a.parallel_overhead = times.loop_wall - times.busiest_sum;
  a.load_imbalance = times.busiest_sum - times.mean_sum;
  a.parallel_work = times.mean_sum;
  a.unaccounted = wall_seconds - step_seconds;
  a.imbalance_percent =
      times.mean_sum > 0.0 ? 100.0 * (times.busiest_sum / times.mean_sum - 1.0) : 0.0;
  a.loops = times.loops;
  double sum = 0.0;
  for (const auto& t : times.threads) {
    a.thread_work.push_back(t.work);
    a.chunks += t.chunks;
    sum += t.work;
  }
  const auto n = static_cast<double>(a.thread_work.size());
  if (n > 1 && sum > 0.0) {
    const double mean = sum / n;
    double squares = 0.0;
    for (double w : a.thread_work) squares += (w - mean) * (w - mean);
    a.thread_work_cv = std::sqrt(squares / n) / mean;
  }
  return a;
}

MeasuredRun measure_run(kernels::Simulation& simulation, schedulers::LoopDriver& driver,
                        int steps, kernels::Instrumentation instrumentation,
                        const StateReference* reference) {
  MeasuredRun run;
  run.instrumentation = instrumentation;
  kernels::LoopTimes times;
  times.resize(omp_get_max_threads());
  kernels::LoopTimes* timer = instrumentation == kernels::Instrumentation::off ? nullptr : &times;
  double step_seconds = 0.0;
  bool finite_cost = true;
  simulation.set_planned_steps(simulation.steps_done() + steps);  // shares a time budget
  const ResourceSample before = sample_resources();
  const double start = kernels::monotonic_seconds();
  for (int k = 0; k < steps && finite_cost; ++k) {
    const kernels::StepReport report = simulation.step(driver, instrumentation, timer);
    step_seconds += report.seconds;
    run.cg_iterations += report.minimiser.iterations;
    finite_cost = std::isfinite(report.minimiser.final.cost) &&
                  std::isfinite(report.minimiser.final.value);
    ++run.steps_done;
  }
  const double wall = kernels::monotonic_seconds() - start;
  run.disturbance = assess_disturbance(before, sample_resources(), omp_get_max_threads(),
                                       omp_get_num_procs(), omp_wait_policy());
  run.accounting = account(times, wall, step_seconds);
  if (timer == nullptr) {
    run.accounting = OverheadAccounting{};
    run.accounting.wall_seconds = wall;
    run.accounting.step_seconds = step_seconds;
    run.accounting.unaccounted = wall - step_seconds;
  }

  // Verification (HPCG style: a run reports a time only when its result is right), by the
  // one verifier every command uses (verify.hpp).
  if (!finite_cost) {
    run.verification.fail(fmt::format("step {}: non-finite cost", run.steps_done));
  }
  const StateFigures figures =
      verify_state(simulation, simulation.steps_done(), run.verification, reference);
  run.mass_error = figures.mass_error;
  run.finite = figures.finite && finite_cost;
  run.state_digest = figures.state_digest;
  run.bit_identical = !figures.reference || figures.reference->identical;
  return run;
}

}  // namespace clothbench::harness
