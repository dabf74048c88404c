// The clothbench command line (CLI11).
//   clothbench run SCENE [options]   one verified simulation (harness/run/run_scene.hpp)
//   clothbench check SCENE           validate a scene file and print what it configures
//   clothbench info [--json]         the machine context (harness/machine)
//   clothbench sweep SCENE|--class C  schedulers x threads grid: Table 2, Fig. 12 (harness/sweep)
//   clothbench stress [options]      the stress matrix, PASSED/FAILED per cell (harness/stress)
//   clothbench table RESULTS.json    Table 2 from a stored sweep (harness/report)
//   clothbench compare A.json B.json two sweeps row by row, with a U test (harness/compare)
//   clothbench predict TRACE         Table 2 / Fig. 12 predicted from a trace (harness/predict)
//   clothbench strip [options]       the step solver on a plane-strain strip (harness/strip)
// Exit codes: 0 success, 1 a run that failed verification or an internal error,
// 2 bad input (command line, scene file), 130 / 143 a sweep stopped by Ctrl-C / SIGTERM
// (its finished rows are kept; it prints the command that resumes it). `compare` exits 1
// when a row is significantly slower in B beyond its --threshold.
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <iostream>

#include "harness/compare/compare_command.hpp"
#include "harness/experiment/experiment.hpp"
#include "harness/machine/allocator.hpp"
#include "harness/machine/machine_context.hpp"
#include "harness/predict/predict_command.hpp"
#include "harness/report/sweep_table.hpp"
#include "harness/run/disturbance.hpp"
#include "harness/run/run_scene.hpp"
#include "harness/run/run_summary.hpp"
#include "harness/scene/scene.hpp"
#include "harness/stress/stress_command.hpp"
#include "harness/strip/strip_command.hpp"
#include "harness/sweep/size_class.hpp"
#include "harness/sweep/sweep.hpp"

namespace {

using clothbench::harness::RunOptions;

constexpr int kExitBadInput = 2;

// `clothbench check`: the scene as the loader understood it, and whether it fits in memory
// (a scene that does not is refused as bad input, as `run` would refuse it).
int check_scene(const std::filesystem::path& file) {
  const auto scene =
      clothbench::harness::load_scene(file, clothbench::harness::default_presets_file());
  const std::uint64_t memory = clothbench::harness::check_memory(scene);
  const auto& sim = scene.simulation;
  fmt::print(
      "{}: OK\n  name        {}\n  steps       {}\n  cloth       {} x {} particles, {} x {} m, "
      "block {}\n"
      "  fabric      {}\n  obstacles   {}\n  time step   {} s\n  amrc        {}\n  hash        "
      "{}\n",
      file.string(), scene.name, scene.steps, sim.cloth.particles_i, sim.cloth.particles_j,
      sim.cloth.size_i, sim.cloth.size_j, sim.cloth.block_size, sim.fabric_name,
      sim.obstacles.size(), sim.time.step,
      sim.amrc.enabled ? fmt::format("{} levels", sim.amrc.levels) : "off",
      scene.source_sha256_or_fnv);
  fmt::print("  memory      about {:.1f} MiB (estimate; this machine has {:.1f} GiB)\n",
             static_cast<double>(memory) / (1u << 20),
             static_cast<double>(clothbench::harness::total_memory_bytes()) / (1u << 30));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  clothbench::harness::configure_allocator();  // before anything large is allocated
  CLI::App app{"clothbench: OpenMP loop-scheduling benchmark on a KES cloth simulation with AMRC"};
  app.set_version_flag("--version", clothbench::harness::version_string());
  app.require_subcommand(1);

  RunOptions run;
  std::string formulation;
  std::string gradient;
  std::string preconditioner;
  std::string method;
  std::string kernel;
  int steps = 0;
  auto* run_command = app.add_subcommand("run", "Simulate a scene and verify the result");
  run_command->add_option("SCENE", run.scene_file, "Scene file (TOML, see scenarios/README.md)")
      ->required()
      ->check(CLI::ExistingFile);
  run_command
      ->add_option("--scheduler", run.scheduler,
                   "Loop scheduler, e.g. static, dynamic:2, active-lists")
      ->capture_default_str();
  run_command
      ->add_option("--threads", run.threads, "OpenMP threads (default: OMP_NUM_THREADS or all PUs)")
      ->check(CLI::Range(1, INT_MAX));
  run_command->add_flag("--oversubscribe", run.allow_oversubscribe,
                        "Allow more threads than hardware PUs");
  auto* steps_option = run_command->add_option("--steps", steps, "Override the scene's step count")
                           ->check(CLI::Range(1, INT_MAX));
  auto* formulation_option =
      run_command->add_option("--formulation", formulation, "Override the formulation")
          ->check(CLI::IsMember({"potential", "violation"}));
  auto* gradient_option = run_command->add_option("--gradient", gradient, "Override the gradient")
                              ->check(CLI::IsMember({"analytic", "numeric"}));
  auto* method_option =
      run_command
          ->add_option("--method", method,
                       "Override the step's minimiser: nonlinear-cg or newton (truncated Newton "
                       "with linear PCG on the model Hessian; potential formulation)")
          ->check(CLI::IsMember(clothbench::kernels::step_method_names()));
  auto* kernel_option =
      run_command
          ->add_option("--kernel", kernel,
                       "Element loops of the potential gradient: reference (scalar, the frozen "
                       "twin) or vector (SIMD lanes, widest instruction set of this CPU)")
          ->check(CLI::IsMember(clothbench::kernels::element_kernel_names()));
  auto* preconditioner_option =
      run_command
          ->add_option("--preconditioner", preconditioner,
                       "Override the preconditioner: none, block-jacobi, line-solves "
                       "(block-tridiagonal solves along the grid lines), multigrid (line "
                       "solves and a coarse grid; Newton only) or v-cycle (a V-cycle on the "
                       "AMRC tree with line Gauss-Seidel; Newton only)")
          ->check(CLI::IsMember(clothbench::kernels::preconditioner_names()));
  run_command->add_option("--out", run.output_dir, "Output directory for VTK and JSON")
      ->capture_default_str();
  bool no_vtk = false;
  run_command->add_flag("--no-vtk", no_vtk, "Do not write VTK surfaces");
  run_command->add_flag("--quiet", run.quiet, "No per-step lines");
  std::filesystem::path trace_file;
  auto* trace_option = run_command->add_option(
      "--trace", trace_file,
      "Record every chunk of every parallel loop into FILE (binary, JSON header; see README) "
      "and draw FILE's stem-timeline.png");
  int trace_step = 0;
  auto* trace_step_option = run_command->add_option(
      "--trace-step", trace_step, "Step of the trace's timeline (default: the most chunks)");
  std::filesystem::path trace_overheads;
  auto* trace_overheads_option = run_command->add_option(
      "--trace-overheads", trace_overheads,
      "With --trace: store the per-loop and per-chunk scheduling costs of clothbench-micro "
      "--benchmark_filter=scheduling_overhead --benchmark_format=json --benchmark_out=FILE in "
      "the trace header (clothbench predict uses them)");
  std::filesystem::path trace_bandwidth;
  auto* trace_bandwidth_option = run_command->add_option(
      "--trace-bandwidth", trace_bandwidth,
      "With --trace: store the triad bandwidth at 1..cores threads of clothbench-micro "
      "--benchmark_filter=^triad --benchmark_format=json --benchmark_out=FILE in the trace "
      "header (clothbench predict's bandwidth ceiling)");

  std::filesystem::path newton_log;
  auto* newton_log_option = run_command->add_option(
      "--newton-log", newton_log,
      "Write every Newton iteration of every step to FILE (CSV: residual before, forcing term, "
      "inner PCG iterations and relative residual, accepted step length, line-search "
      "evaluations, residual after the line search and after the smoothing; Newton only)");

  std::filesystem::path check_file;
  auto* check_command =
      app.add_subcommand("check", "Validate a scene file and print what it sets up");
  check_command->add_option("SCENE", check_file, "Scene file (TOML)")
      ->required()
      ->check(CLI::ExistingFile);

  bool json = false;
  auto* info_command = app.add_subcommand("info", "Print the machine context");
  info_command->add_flag("--json", json, "As JSON (the block stored with every result)");

  // `clothbench sweep`: the lists are parsed after CLI11 so errors can name the bad item.
  clothbench::harness::SweepOptions sweep;
  std::string sweep_schedulers{clothbench::harness::kPaperSchedulers};
  std::string sweep_threads;
  std::string sweep_instrument = "loops";
  std::string sweep_bind = "none";
  int sweep_steps = 0;
  bool sweep_no_plots = false;
  auto* sweep_command = app.add_subcommand(
      "sweep", "Run every scheduler x thread count, write Table 2, Fig. 12 and the JSON record");
  auto* sweep_scene_option =
      sweep_command->add_option("SCENE", sweep.scene_file, "Scene file (TOML); or --class");
  std::string sweep_class;
  auto* sweep_class_option = sweep_command->add_option(
      "--class", sweep_class,
      "Size class instead of SCENE, as in the NAS benchmarks: S (the default job's drape), W "
      "(a 101^2 cloth on the box), A (the paper's box at 1001^2), B (the box at 2001^2); sets "
      "the scene, --repeat and --warmup-steps (see README, Size classes)");
  sweep_command
      ->add_option("--schedulers", sweep_schedulers,
                   "Comma-separated scheduler specs (see `run --scheduler`)")
      ->capture_default_str();
  sweep_command->add_option("--threads", sweep_threads,
                            "Thread counts, e.g. 1,2,4 or 1-8 (default: powers of two up to the "
                            "cores, and the cores)");
  sweep_command->add_flag("--oversubscribe", sweep.allow_oversubscribe,
                          "Allow thread counts above the hardware threads (rows are marked)");
  auto* sweep_repeat_option =
      sweep_command->add_option("--repeat", sweep.repeat, "Measured runs per row and timing level")
          ->capture_default_str()
          ->check(CLI::Range(1, 1000));
  sweep_command
      ->add_option("--count-reference-after", sweep.count_reference_after_seconds,
                   "Without a warm-up, a 1-thread reference run of at least this many seconds "
                   "counts as its row's first run")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e9));
  auto* sweep_warmup_option =
      sweep_command
          ->add_option("--warmup-steps", sweep.warmup_steps,
                       "Steps of the uncounted warm-up run of each row (0: none)")
          ->capture_default_str()
          ->check(CLI::Range(0, INT_MAX));
  auto* sweep_steps_option =
      sweep_command->add_option("--steps", sweep_steps, "Override the scene's step count")
          ->check(CLI::Range(1, INT_MAX));
  sweep_command
      ->add_option("--instrument", sweep_instrument,
                   "Loop timing for the overhead decomposition (its cost is measured)")
      ->capture_default_str()
      ->check(CLI::IsMember({"off", "loops", "chunks"}));
  std::string sweep_instrument_only;
  auto* sweep_instrument_only_option = sweep_command->add_option(
      "--instrument-only", sweep_instrument_only,
      "Comma-separated schedulers (of --schedulers) whose rows get the instrumented runs; the "
      "other rows are timed uninstrumented only (default: every row). E.g. active-lists: the "
      "paper's Table 2 decomposes only that scheduler's time");
  sweep_command
      ->add_option("--bind", sweep_bind,
                   "core: pin thread k to core k (hwloc); none: leave it to OMP_PROC_BIND")
      ->capture_default_str()
      ->check(CLI::IsMember({"none", "core"}));
  sweep_command
      ->add_option("--retries", sweep.retries,
                   "Re-runs of a repetition that other work on the machine disturbed (0-100); a "
                   "row whose runs stay disturbed is labelled DISTURBED and gets no speed-up")
      ->capture_default_str()
      ->check(CLI::Range(0, 100));
  std::string sweep_wait_policy;
  sweep_command
      ->add_option("--wait-policy", sweep_wait_policy,
                   "OMP_WAIT_POLICY of every run: passive (waiting threads sleep; use on a shared "
                   "node) or active (they spin); default: the environment's")
      ->check(CLI::IsMember({"passive", "active"}));
  sweep_command->add_option("--out", sweep.output_dir, "Output directory")->capture_default_str();
  sweep_command->add_flag("--resume", sweep.resume, "Skip rows already in OUT/sweep.json");
  sweep_command->add_flag("--quiet", sweep.quiet, "No progress bar and no per-row lines");
  sweep_command->add_flag("--no-plots", sweep_no_plots, "Do not run gnuplot");
  std::filesystem::path sweep_trace_dir;
  auto* sweep_trace_option = sweep_command->add_option(
      "--trace", sweep_trace_dir,
      "Extra, uncounted traced runs per row (--repeat of them, at most 3; the median kept): "
      "DIR/<scheduler>-<threads>t.cbtrace + timeline");
  std::filesystem::path sweep_trace_overheads;
  auto* sweep_trace_overheads_option = sweep_command->add_option(
      "--trace-overheads", sweep_trace_overheads,
      "With --trace: store the scheduling costs of this scheduling_overhead JSON "
      "(clothbench-micro) in every trace's header");
  std::filesystem::path sweep_trace_bandwidth;
  auto* sweep_trace_bandwidth_option = sweep_command->add_option(
      "--trace-bandwidth", sweep_trace_bandwidth,
      "With --trace: store the triad bandwidth of this clothbench-micro JSON "
      "(--benchmark_filter=^triad) in every trace's header");

  // `clothbench experiment NAME`: the paper's experiments, one command each.
  clothbench::harness::ExperimentOptions experiment;
  std::string experiment_size = "small";
  std::filesystem::path experiment_scene;
  int experiment_steps = 0;
  bool experiment_no_plots = false;
  auto* experiment_command = app.add_subcommand(
      "experiment", "Re-run a paper experiment: table1, table2, table3, or time-error");
  experiment_command->add_option("NAME", experiment.name, "table1 | table2 | table3 | time-error")
      ->required()
      ->check(CLI::IsMember({"table1", "table2", "table3", "time-error"}));
  experiment_command->add_option("--size", experiment_size, "paper | small | tiny")
      ->capture_default_str()
      ->check(CLI::IsMember({"paper", "small", "tiny"}));
  experiment_command->add_option("--out", experiment.output_dir, "Output directory")
      ->capture_default_str();
  experiment_command
      ->add_option("--scheduler", experiment.scheduler, "Scheduler of every run (not table2)")
      ->capture_default_str();
  experiment_command
      ->add_option("--threads", experiment.threads, "OpenMP threads (table2: one row count)")
      ->check(CLI::Range(1, INT_MAX));
  experiment_command->add_flag("--oversubscribe", experiment.allow_oversubscribe,
                               "Allow more threads than hardware PUs");
  auto* experiment_scene_option =
      experiment_command
          ->add_option("--scene", experiment_scene, "time-error only: base scene (default: Table 1's finer)")
          ->check(CLI::ExistingFile);
  std::string experiment_only;
  auto* experiment_only_option = experiment_command->add_option(
      "--only", experiment_only,
      "time-error only: comma-separated settings to run (their labels in time_error.md, e.g. "
      "tol-x10,cap-3); the reference and the base always run");
  auto* experiment_steps_option =
      experiment_command->add_option("--steps", experiment_steps, "Override every scene's step count")
          ->check(CLI::Range(1, INT_MAX));
  auto* experiment_retries_option =
      experiment_command
          ->add_option("--retries", experiment.retries,
                       "table2 only: re-runs of a repetition that other work on the machine "
                       "disturbed (0-100), as in `sweep --retries`")
          ->capture_default_str()
          ->check(CLI::Range(0, 100));
  experiment_command->add_flag("--quiet", experiment.quiet, "No per-run lines");
  experiment_command->add_flag("--no-plots", experiment_no_plots, "Do not run gnuplot");

  std::filesystem::path table_file;
  std::string table_format = "md";
  auto* table_command =
      app.add_subcommand("table", "Print Table 2 (per scheduler) from a stored sweep.json");
  table_command->add_option("RESULTS", table_file, "sweep.json written by `clothbench sweep`")
      ->required();
  table_command->add_option("--format", table_format, "md or csv")
      ->capture_default_str()
      ->check(CLI::IsMember({"md", "csv"}));

  clothbench::harness::StressCommand stress_command(app);
  clothbench::harness::CompareCommand compare_command(app);
  clothbench::harness::PredictCommand predict_command(app);
  clothbench::harness::StripCommand strip_command(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    const int code = app.exit(error);  // prints help, version or the error
    return code == 0 ? 0 : kExitBadInput;
  }

  try {
    if (*run_command) {
      if (*steps_option) run.steps = steps;
      if (*formulation_option) run.formulation = formulation;
      if (*gradient_option) run.gradient = gradient;
      if (*method_option) run.method = method;
      if (*kernel_option) run.kernel = kernel;
      if (*preconditioner_option) run.preconditioner = preconditioner;
      run.write_vtk = !no_vtk;
      if (*trace_option) run.trace_file = trace_file;
      if (*newton_log_option) run.newton_log = newton_log;
      if (*trace_step_option) run.trace_step = trace_step;
      if (*trace_overheads_option) run.trace_overheads = trace_overheads;
      if (*trace_bandwidth_option) run.trace_bandwidth = trace_bandwidth;
      return clothbench::harness::run_scene(run);
    }
    if (*check_command) return check_scene(check_file);
    if (stress_command.selected()) return stress_command.run(argc, argv);
    if (compare_command.selected()) return compare_command.run();
    if (predict_command.selected()) return predict_command.run();
    if (strip_command.selected()) return strip_command.run();
    if (*sweep_command) {
      // The OpenMP runtime reads OMP_WAIT_POLICY when it starts (libgomp: when the program
      // is loaded), so a policy that differs from the environment's restarts the command with
      // it set; the restarted process finds it set and goes on.
      if (!sweep_wait_policy.empty() &&
          clothbench::harness::omp_wait_policy() != sweep_wait_policy) {
        setenv("OMP_WAIT_POLICY", sweep_wait_policy.c_str(), 1);  // NOLINT(concurrency-mt-unsafe)
        execv("/proc/self/exe", argv);
        std::fprintf(stderr,
                     "clothbench sweep: --wait-policy: could not restart with "
                     "OMP_WAIT_POLICY=%s: %s\n",
                     sweep_wait_policy.c_str(), std::strerror(errno));
        return 1;
      }
      try {
        if (*sweep_class_option) {
          clothbench::harness::apply_size_class(
              clothbench::harness::find_size_class(sweep_class), sweep_scene_option->count() > 0,
              sweep_repeat_option->count() > 0, sweep_warmup_option->count() > 0, sweep);
        } else if (!*sweep_scene_option) {
          throw std::invalid_argument("SCENE: a scene file or --class S|W|A|B is required");
        }
        sweep.schedulers = clothbench::harness::split_list(sweep_schedulers, "--schedulers");
        if (!sweep_threads.empty()) {
          sweep.threads = clothbench::harness::parse_thread_list(sweep_threads, "--threads");
        }
        if (*sweep_steps_option) sweep.steps = sweep_steps;
        sweep.instrument = clothbench::harness::parse_instrumentation(sweep_instrument);
        if (*sweep_instrument_only_option) {
          sweep.instrument_only =
              clothbench::harness::split_list(sweep_instrument_only, "--instrument-only");
        }
        sweep.bind = sweep_bind == "core" ? clothbench::harness::BindMode::core
                                          : clothbench::harness::BindMode::none;
        sweep.plots = !sweep_no_plots;
        if (*sweep_trace_option) sweep.trace_dir = sweep_trace_dir;
        if (*sweep_trace_overheads_option) sweep.trace_overheads = sweep_trace_overheads;
        if (*sweep_trace_bandwidth_option) sweep.trace_bandwidth = sweep_trace_bandwidth;
        sweep.command_line.assign(argv, argv + argc);
        return clothbench::harness::run_sweep(sweep);
      } catch (const std::invalid_argument& error) {
        std::fprintf(stderr, "clothbench sweep: %s\n", error.what());
        return kExitBadInput;
      }
    }
    if (*experiment_command) {
      experiment.size = clothbench::harness::parse_experiment_size(experiment_size, "--size");
      // Options that one experiment takes: the others refuse them, saying why.
      struct OneExperimentOption {
        const CLI::Option* option;
        const char* experiment;
        const char* refusal;  // {} = the experiment asked for
      };
      const OneExperimentOption one_experiment_options[] = {
          {experiment_scene_option, "time-error",
           "--scene: only time-error takes a base scene ({} runs its own scenes)"},
          {experiment_only_option, "time-error",
           "--only: only time-error has settings to choose from ({} runs all of its scenes)"},
          {experiment_retries_option, "table2",
           "--retries: only table2 re-runs disturbed repetitions ({} does not time "
           "repetitions)"}};
      for (const OneExperimentOption& o : one_experiment_options) {
        if (*o.option && experiment.name != o.experiment) {
          fmt::print(stderr, "clothbench experiment: {}\n",
                     fmt::format(fmt::runtime(o.refusal), experiment.name));
          return kExitBadInput;
        }
      }
      if (*experiment_only_option) {
        try {
          experiment.only = clothbench::harness::split_list(experiment_only, "--only");
        } catch (const std::invalid_argument& error) {
          fmt::print(stderr, "clothbench experiment: {}\n", error.what());
          return kExitBadInput;
        }
      }
      if (*experiment_scene_option) experiment.scene = experiment_scene;
      if (*experiment_steps_option) experiment.steps = experiment_steps;
      experiment.plots = !experiment_no_plots;
      experiment.command_line.assign(argv, argv + argc);
      return clothbench::harness::run_experiment(experiment);
    }
    if (*table_command) {
      nlohmann::json document;
      try {
        document = clothbench::harness::load_sweep_document(table_file);
      } catch (const std::invalid_argument& error) {
        std::fprintf(stderr, "clothbench table: %s\n", error.what());
        return kExitBadInput;
      }
      clothbench::harness::add_derived(document);
      std::cout << (table_format == "csv" ? clothbench::harness::format_csv(document)
                                          : clothbench::harness::format_markdown(document));
      return 0;
    }
    if (*info_command) {
      const auto context = clothbench::harness::machine_context();
      if (json) {
        std::cout << context.dump(2) << '\n';
      } else {
        std::cout << clothbench::harness::machine_summary(context);
      }
      return 0;
    }
  } catch (const clothbench::harness::SceneError& error) {
    std::fprintf(stderr, "clothbench: %s\n", error.what());
    return kExitBadInput;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "clothbench: error: %s\n", error.what());
    return 1;
  }
  return kExitBadInput;
}
