// Timing, accounting and verification of one sweep run (see measured_run.hpp).
#include "harness/sweep/measured_run.hpp"

#include <fmt/core.h>
#include <omp.h>

#include <cmath>
#include <cstring>
#include <numeric>

#include "harness/scene/scene.hpp"

namespace clothbench::harness {

namespace {

template <class T>
void append_bytes(std::string& out, const std::vector<T>& values) {
  const std::size_t bytes = values.size() * sizeof(T);
  const std::size_t at = out.size();
  out.resize(at + bytes);
  if (bytes > 0) std::memcpy(out.data() + at, values.data(), bytes);
}

}  // namespace

std::string state_bytes(const kernels::Simulation& simulation) {
  const kernels::ClothState& state = simulation.state();
  std::string bytes;
  append_bytes(bytes, state.position);
  append_bytes(bytes, state.edge_force);
  append_bytes(bytes, state.triple_moment);
  return bytes;
}

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
                        const std::string* reference_bytes) {
  MeasuredRun run;
  run.instrumentation = instrumentation;
  kernels::LoopTimes times;
  times.resize(omp_get_max_threads());
  kernels::LoopTimes* timer = instrumentation == kernels::Instrumentation::off ? nullptr : &times;
  double step_seconds = 0.0;
  bool finite_cost = true;
  simulation.set_planned_steps(simulation.steps_done() + steps);  // shares a time budget
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
  run.accounting = account(times, wall, step_seconds);
  if (timer == nullptr) {
    run.accounting = OverheadAccounting{};
    run.accounting.wall_seconds = wall;
    run.accounting.step_seconds = step_seconds;
    run.accounting.unaccounted = wall - step_seconds;
  }

  // Verification (HPCG style: a run reports a time only when its result is right).
  const kernels::StateDiagnostics d = simulation.diagnostics();
  const kernels::ClothConfig& cloth = simulation.config().cloth;
  const double expected = simulation.mesh().areal_density() * cloth.size_i * cloth.size_j;
  run.mass_error = std::abs(d.total_mass - expected) / expected;
  run.finite = d.finite && finite_cost;
  if (!finite_cost) {
    run.verification.fail(fmt::format("step {}: non-finite cost", run.steps_done));
  }
  if (!d.finite) run.verification.fail("non-finite final state");
  if (!(run.mass_error <= 1e-12)) {
    run.verification.fail(fmt::format("mass {:.15g} kg differs from {:.15g} kg (relative {:.3g})",
                                      d.total_mass, expected, run.mass_error));
  }
  const std::string bytes = state_bytes(simulation);
  run.state_digest = fnv1a64_hex(bytes);
  if (reference_bytes != nullptr) {
    run.bit_identical = bytes.size() == reference_bytes->size() &&
                        std::memcmp(bytes.data(), reference_bytes->data(), bytes.size()) == 0;
    if (!run.bit_identical) {
      std::size_t first = 0;
      const std::size_t common = std::min(bytes.size(), reference_bytes->size());
      while (first < common && bytes[first] == (*reference_bytes)[first]) ++first;
      run.verification.fail(fmt::format(
          "final state differs from the 1-thread reference (digest {} vs {}, first differing "
          "byte {} of {})",
          run.state_digest, fnv1a64_hex(*reference_bytes), first, bytes.size()));
    }
  }
  return run;
}

}  // namespace clothbench::harness
