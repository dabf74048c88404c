// `clothbench run`: load, check resources, simulate, verify, report, write VTK + JSON.
#include "harness/run/run_scene.hpp"

#include <fmt/core.h>
#include <omp.h>
#include <sys/resource.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <memory>
#include <stdexcept>

#include "harness/machine/machine_context.hpp"
#include "harness/output/atomic_file.hpp"
#include "harness/output/vtk_writer.hpp"
#include "harness/predict/trace_models.hpp"
#include "harness/report/cloth_picture.hpp"
#include "harness/report/sweep_plots.hpp"
#include "harness/run/resident_memory.hpp"
#include "harness/run/run_summary.hpp"
#include "harness/run/verify.hpp"
#include "harness/scene/scene.hpp"
#include "harness/trace/trace_output.hpp"
#include "kernels/simulation.hpp"
#include "kernels/vector/element_lanes.hpp"
#include "schedulers/registry.hpp"

namespace clothbench::harness {

namespace {

constexpr int kExitPassed = 0;
constexpr int kExitFailed = 1;
constexpr int kExitBadInput = 2;

/// Applies the command line's overrides to the scene's configuration.
void apply_overrides(const RunOptions& options, Scene& scene) {
  if (options.steps) scene.steps = *options.steps;
  kernels::SolverConfig& solver = scene.simulation.solver;
  if (options.formulation) {
    solver.formulation = *options.formulation == "violation" ? kernels::Formulation::violation
                                                             : kernels::Formulation::potential;
  }
  if (options.gradient) {
    solver.gradient = *options.gradient == "numeric" ? kernels::GradientMode::numeric
                                                     : kernels::GradientMode::analytic;
  }
  if (options.method) solver.method = *kernels::step_method_from_string(*options.method);
  if (options.kernel) solver.kernel = *kernels::element_kernel_from_string(*options.kernel);
  if (options.preconditioner) {
    solver.preconditioner = *kernels::preconditioner_from_string(*options.preconditioner);
  }
}

/// --trace-step, --trace-overheads and --trace-bandwidth need --trace, --trace-step a step of
/// the run; returns the header entries the last two copy in (trace_model_headers). Throws
/// std::invalid_argument naming the flag.
nlohmann::json check_trace_options(const RunOptions& options, int steps) {
  const nlohmann::json models =
      trace_model_headers(options.trace_overheads, options.trace_bandwidth,
                          options.trace_file.has_value(), "--trace FILE");
  if (!options.trace_step) return models;
  if (!options.trace_file) {
    throw std::invalid_argument("--trace-step: needs --trace FILE");
  }
  if (*options.trace_step < 1 || *options.trace_step > steps) {
    throw std::invalid_argument(fmt::format("--trace-step: {} is not a step of this run (1..{})",
                                            *options.trace_step, steps));
  }
  return models;
}

}  // namespace

std::uint64_t peak_resident_bytes() {
  // The same high-water mark as each step's record (VmHWM), getrusage's where /proc is absent.
  if (const auto now = read_resident_memory()) return now->peak_bytes;
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<std::uint64_t>(usage.ru_maxrss) * 1024u;  // Linux reports KiB
}

int resolve_threads(int requested, bool allow_oversubscribe, const char* flag) {
  const int hardware = hardware_threads();
  const int threads = requested > 0 ? requested : omp_get_max_threads();
  if (threads > hardware && !allow_oversubscribe) {
    throw std::invalid_argument(fmt::format(
        "{}: {} threads requested but this machine has {} hardware threads; pass "
        "--oversubscribe to run oversubscribed (results are then labelled as such)",
        flag, threads, hardware));
  }
  return threads;
}

std::uint64_t check_memory(const Scene& scene) {
  const kernels::SimulationConfig& config = scene.simulation;
  const std::uint64_t needed = kernels::estimate_memory_bytes(config);
  const std::uint64_t available = total_memory_bytes();
  if (needed > available * 9 / 10) {
    throw SceneError(fmt::format(
        "{}:{}:{}: [cloth] particles: {} x {} particles need about {:.1f} GiB, but this machine "
        "has {:.1f} GiB of memory",
        scene.file.string(), scene.particles_position.line, scene.particles_position.column,
        config.cloth.particles_i, config.cloth.particles_j,
        static_cast<double>(needed) / (1u << 30), static_cast<double>(available) / (1u << 30)));
  }
  return needed;
}

int run_scene(const RunOptions& options) {
  Scene scene;
  std::unique_ptr<schedulers::LoopDriver> driver;
  int threads = 0;
  nlohmann::json trace_models;
  try {
    scene = load_scene(options.scene_file, default_presets_file());
    apply_overrides(options, scene);
    check_memory(scene);
    threads = resolve_threads(options.threads, options.allow_oversubscribe, "--threads");
    driver = schedulers::make_driver(options.scheduler);
    trace_models = check_trace_options(options, scene.steps);
    if (options.newton_log) {
      if (kernels::resolved_method(scene.simulation.solver) != kernels::StepMethod::newton) {
        throw std::invalid_argument(fmt::format(
            "--newton-log: {} runs method {}; the log records Newton iterations (set [solver] "
            "method = \"newton\" or pass --method newton)",
            scene.file.string(),
            kernels::to_string(kernels::resolved_method(scene.simulation.solver))));
      }
      scene.simulation.solver.log_iterations = true;
    }
  } catch (const SceneError& error) {
    fmt::print(stderr, "clothbench: {}\n", error.what());
    return kExitBadInput;
  } catch (const std::invalid_argument& error) {
    fmt::print(stderr, "clothbench: {}\n", error.what());
    return kExitBadInput;
  }
  omp_set_num_threads(threads);

  std::unique_ptr<kernels::Simulation> owned;
  try {
    owned = std::make_unique<kernels::Simulation>(scene.simulation);
  } catch (const std::invalid_argument& error) {
    // Combinations the kernel refuses (e.g. the violation formulation's numeric gradient with
    // AMRC, or one a command-line override made): named with the scene file and the setting's
    // "section.key", exit 2, nothing written.
    fmt::print(stderr, "clothbench: {}: {}\n", scene.file.string(), error.what());
    return kExitBadInput;
  }
  kernels::Simulation& simulation = *owned;
  const bool oversubscribed = threads > hardware_threads();
  fmt::print("clothbench run: {} ({})\n", scene.name, scene.file.string());
  fmt::print("  particles {} x {}, fabric {}, formulation {}, gradient {}, method {}, "
             "preconditioner {}\n",
             scene.simulation.cloth.particles_i, scene.simulation.cloth.particles_j,
             scene.simulation.fabric_name,
             kernels::to_string(scene.simulation.solver.formulation),
             kernels::to_string(scene.simulation.solver.gradient),
             kernels::to_string(kernels::resolved_method(scene.simulation.solver)),
             kernels::to_string(kernels::resolved_preconditioner(scene.simulation.solver)));
  if (scene.simulation.solver.kernel == kernels::ElementKernel::vector) {
    const kernels::vector::ElementLanesKernels& lanes = kernels::vector::element_lanes_kernels();
    fmt::print("  kernel vector ({}, {} lanes)\n", lanes.isa, lanes.lanes);
  } else {
    fmt::print("  kernel reference\n");
  }
  fmt::print("  scheduler {}, threads {}{}, steps {}\n", driver->name(), threads,
             oversubscribed ? " (OVERSUBSCRIBED)" : "", scene.steps);
  if (!driver->note().empty()) fmt::print("  note: {}\n", driver->note());

  std::unique_ptr<kernels::ChunkTrace> trace;
  if (options.trace_file) {
    trace = std::make_unique<kernels::ChunkTrace>();
    trace->start(threads, kTraceRecordsPerThread);
  }
  const ResourceSample before = sample_resources();
  RunSummary summary =
      simulate(simulation, *driver, scene.steps, options.quiet, {}, trace.get());
  summary.disturbance = assess_disturbance(before, sample_resources(), threads,
                                           hardware_threads(), omp_wait_policy());
  summary.threads = threads;
  summary.oversubscribed = oversubscribed;
  summary.peak_resident_bytes = peak_resident_bytes();
  print_summary(summary);

  const std::filesystem::path dir = options.output_dir / scene.file.stem();
  nlohmann::json document = summary_json(summary, scene, driver->name());
  document["machine"] = machine_context();
  try {
    if (trace) {
      nlohmann::json context = {{"machine", document["machine"]},
                                {"scene", scene.name},
                                {"scene_file", scene.file.string()},
                                {"scheduler", driver->name()},
                                {"threads", threads},
                                {"steps", summary.steps.size()},
                                {"state_digest", state_digest(simulation)}};
      context.update(trace_models);
      write_trace_outputs(*trace, *options.trace_file, context, summary.wall_seconds,
                          options.trace_step);
    }
    if (options.write_vtk && summary.verification.passed) {
      write_vtk(dir / "final.vtk", surface_mesh(simulation), scene.name);
    }
    write_file_atomically(dir / "summary.json", document.dump(2) + "\n");
    if (options.newton_log) {
      write_file_atomically(*options.newton_log, newton_log_csv(summary.newton_log));
      fmt::print("  wrote {} ({} Newton iterations)\n", options.newton_log->string(),
                 summary.newton_log.size());
    }
    if (!summary.non_finite.empty()) {
      for (const auto& file :
           write_non_finite_snapshot(dir, "non_finite_snapshot", summary, simulation, scene.name)) {
        fmt::print("  wrote {} (the state at the failing step)\n", file.string());
      }
    }
    // The adaptive mesh's levels over the draped cloth (cloth.png, coloured by level), from
    // at most kPictureCellsPerSide^2 quads whatever the mesh size.
    if (scene.simulation.amrc.enabled && summary.verification.passed && gnuplot_available()) {
      const PlotOutcome plot = plot_cloth(mesh_levels_picture(simulation),
                                          scene.name + ": mesh levels (0 = finest)", dir);
      for (const auto& image : plot.images) fmt::print("  wrote {}\n", image.string());
      for (const auto& problem : plot.problems) fmt::print(stderr, "clothbench: {}\n", problem);
    }
  } catch (const std::exception& error) {
    fmt::print(stderr, "clothbench: could not write results: {}\n", error.what());
    return kExitFailed;
  }
  fmt::print("  wrote {}\n", (dir / "summary.json").string());
  return summary.verification.passed ? kExitPassed : kExitFailed;
}

}  // namespace clothbench::harness
