// `clothbench sweep` (see sweep.hpp): the grid loop, resume, and the output files.
#include "harness/sweep/sweep.hpp"

#include <fmt/core.h>
#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "harness/machine/machine_context.hpp"
#include "harness/output/atomic_file.hpp"
#include "harness/predict/trace_models.hpp"
#include "harness/report/cloth_picture.hpp"
#include "harness/report/sweep_plots.hpp"
#include "harness/report/sweep_table.hpp"
#include "harness/run/core_round_trip.hpp"
#include "harness/run/disturbance.hpp"
#include "harness/run/resident_memory.hpp"
#include "harness/run/run_summary.hpp"
#include "harness/scene/scene.hpp"
#include "harness/sweep/measured_run.hpp"
#include "harness/sweep/progress_bar.hpp"
#include "harness/sweep/stop_request.hpp"
#include "harness/sweep/sweep_document.hpp"
#include "harness/sweep/sweep_resume.hpp"
#include "harness/sweep/thread_binding.hpp"
#include "harness/trace/trace_file.hpp"
#include "harness/trace/trace_output.hpp"
#include "schedulers/registry.hpp"

namespace clothbench::harness {

using nlohmann::json;

namespace {

/// One scheduler of the grid, checked up front.
struct GridScheduler {
  std::string given;      ///< as on the command line
  std::string canonical;  ///< driver name()
  std::string note;       ///< driver note() (runtime workaround), may be empty
};

/// Builds and runs one fresh simulation with `threads` threads.
MeasuredRun fresh_run(const Scene& scene, schedulers::LoopDriver& driver, int threads, int steps,
                      kernels::Instrumentation level, const StateReference* reference,
                      std::unique_ptr<kernels::Simulation>* keep = nullptr) {
  omp_set_num_threads(threads);
  const RunMemoryProbe memory;  // the run's peak includes building its simulation
  auto simulation = std::make_unique<kernels::Simulation>(scene.simulation);
  MeasuredRun run = measure_run(*simulation, driver, steps, level, reference);
  run.memory = memory.finish();
  if (keep != nullptr) *keep = std::move(simulation);
  return run;
}

/// sweep --trace: more runs of the row with the per-chunk trace, after its measured runs and
/// not counted (tracing adds two clock reads per chunk: the measured runs stay untraced).
/// `runs` traced runs (the sweep's --repeat, at most 3), of which the one with the median time
/// is kept: one run on a VM can be 10-15 % off its row's median, and the predictor replays
/// the trace's times. A trace of more than kLargestRepeatedTraceBytes is kept from its first
/// run (three of them would have to be held at once). Writes DIR/<scheduler>-<threads>t.cbtrace and
/// its timeline; the header says how many runs were traced, whether the final state equals the
/// sweep's reference bit for bit, and holds `models` (the predictor's costs and bandwidth,
/// trace_model_headers).
constexpr double kLargestRepeatedTraceBytes = 256.0 * 1024 * 1024;

void traced_row_run(const Scene& scene, schedulers::LoopDriver& driver, int threads, int runs,
                    const StateReference& reference, const std::filesystem::path& dir,
                    const json& models, bool quiet) {
  omp_set_num_threads(threads);
  struct Traced {
    double seconds = 0.0;
    std::unique_ptr<kernels::ChunkTrace> trace;
    std::string digest;
    bool identical = false;  // the final state equals the reference (bytes, or digest)
  };
  std::vector<Traced> traced;
  std::vector<double> all_seconds;
  for (int r = 0; r < std::max(1, runs); ++r) {
    kernels::Simulation simulation(scene.simulation);
    Traced t;
    t.trace = std::make_unique<kernels::ChunkTrace>();
    t.trace->start(threads, kTraceRecordsPerThread);
    simulation.set_planned_steps(scene.steps);
    for (int k = 0; k < scene.steps; ++k) {
      t.seconds +=
          simulation.step(driver, kernels::Instrumentation::off, nullptr, t.trace.get()).seconds;
    }
    t.digest = state_digest(simulation);
    t.identical = compare_state(simulation, reference, t.digest).identical;
    all_seconds.push_back(t.seconds);
    const bool large = static_cast<double>(t.trace->chunk_count()) *
                           static_cast<double>(sizeof(kernels::ChunkRecord)) >
                       kLargestRepeatedTraceBytes;
    traced.push_back(std::move(t));
    if (large) break;  // a trace this large is kept from one run (memory)
  }
  std::vector<std::size_t> order(traced.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return traced[a].seconds < traced[b].seconds; });
  const Traced& kept = traced[order[(order.size() - 1) / 2]];
  const bool identical = std::all_of(traced.begin(), traced.end(),
                                     [](const Traced& t) { return t.identical; });
  nlohmann::json context = {{"machine", machine_context()},
                            {"scene", scene.name},
                            {"scene_file", scene.file.string()},
                            {"scheduler", driver.name()},
                            {"threads", threads},
                            {"steps", scene.steps},
                            {"traced_runs", traced.size()},
                            {"traced_runs_seconds", all_seconds},
                            {"state_digest", kept.digest},
                            {"bit_identical_to_reference", identical}};
  context.update(models);
  write_trace_outputs(*kept.trace, dir / row_trace_file_name(driver.name(), threads), context,
                      kept.seconds, std::nullopt, quiet);
}

/// Writes sweep.json, table.md and table.csv into `dir` (atomically, each).
void write_outputs(json& document, const std::filesystem::path& dir) {
  add_derived(document);
  document["updated_utc"] = utc_now();
  check_finite(document, "sweep");
  write_file_atomically(dir / "sweep.json", document.dump(2) + "\n");
  write_file_atomically(dir / "table.md", format_markdown(document));
  write_file_atomically(dir / "table.csv", format_csv(document));
}

/// The final state of the reference run, stored so that a resumed sweep can say where a row's
/// state first differs from it. Only for resuming: `results/` ignores it (.gitignore). Without
/// it a resume compares by the digest in sweep.json; the reference never runs again.
constexpr const char* kReferenceStateFile = "reference-state.bin";

/// The stored reference state of `dir` when it is the one `digest` names; nullopt (and why,
/// in `why`) when it is missing or differs.
std::optional<std::string> stored_reference_state(const std::filesystem::path& dir,
                                                  const std::string& digest, std::string& why) {
  const std::filesystem::path file = dir / kReferenceStateFile;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) {
    why = fmt::format("{} is missing", file.string());
    return std::nullopt;
  }
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    why = fmt::format("{} cannot be opened", file.string());
    return std::nullopt;
  }
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in.good() && !in.eof()) {
    why = fmt::format("{} cannot be read", file.string());
    return std::nullopt;
  }
  if (fnv1a64_hex(bytes) != digest) {
    why = fmt::format("{} does not hold the state digest {} of sweep.json", file.string(), digest);
    return std::nullopt;
  }
  return bytes;
}

/// `word` quoted for a POSIX shell when it needs to be.
std::string shell_quoted(const std::string& word) {
  if (!word.empty() && word.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                              "0123456789@%+=:,./-_") == std::string::npos) {
    return word;
  }
  std::string quoted = "'";
  for (const char c : word) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

/// The command line of this sweep with --resume: what continues an interrupted sweep.
std::string resume_command(const SweepOptions& options) {
  std::vector<std::string> words = options.command_line;
  if (words.empty()) {  // not started from the command line: the equivalent one
    words = {"clothbench", "sweep", options.scene_file.string(), "--out",
             options.output_dir.string()};
  }
  if (std::find(words.begin(), words.end(), "--resume") == words.end()) words.push_back("--resume");
  std::string command;
  for (const std::string& word : words) {
    if (!command.empty()) command += ' ';
    command += shell_quoted(word);
  }
  return command;
}

}  // namespace

int run_sweep(const SweepOptions& given) {
  SweepOptions options = given;  // --instrument-only becomes canonical names below
  // Everything that can be wrong with the input is checked before the first run.
  Scene scene = load_scene(options.scene_file, default_presets_file());
  if (options.steps) scene.steps = *options.steps;
  check_memory(scene);
  if (options.schedulers.empty()) throw std::invalid_argument("--schedulers: no scheduler given");
  if (options.repeat < 1) throw std::invalid_argument("--repeat: must be at least 1");
  if (options.retries < 0) throw std::invalid_argument("--retries: must be at least 0");
  std::vector<GridScheduler> grid;
  for (const std::string& spec : options.schedulers) {
    std::unique_ptr<schedulers::LoopDriver> driver;
    try {
      driver = schedulers::make_driver(spec);
    } catch (const std::invalid_argument& error) {
      throw std::invalid_argument(fmt::format("--schedulers: {}", error.what()));
    }
    grid.push_back({spec, driver->name(), driver->note()});
  }
  {
    std::vector<std::string> canonical;
    for (const GridScheduler& s : grid) canonical.push_back(s.canonical);
    options.instrument_only = canonical_instrument_only(options, canonical);
  }
  const std::vector<std::string>& instrument_only = options.instrument_only;
  // Whether the rows of scheduler `canonical` get instrumented runs.
  auto instruments = [&](const std::string& canonical) {
    return options.instrument != kernels::Instrumentation::off &&
           (instrument_only.empty() ||
            std::find(instrument_only.begin(), instrument_only.end(), canonical) !=
                instrument_only.end());
  };
  const ThreadBinder binder;
  const std::vector<int> threads =
      options.threads.empty() ? default_thread_counts(binder.cores()) : options.threads;
  for (int n : threads) resolve_threads(n, options.allow_oversubscribe, "--threads");
  // The traces' header "overheads" and "bandwidth" (each absent when not given).
  const json trace_models = trace_model_headers(options.trace_overheads, options.trace_bandwidth,
                                                options.trace_dir.has_value(), "--trace DIR");
  const int hardware = hardware_threads();
  const std::filesystem::path json_file = options.output_dir / "sweep.json";

  json document;
  const json machine = machine_context();
  const bool resuming = options.resume && std::filesystem::exists(json_file);
  if (resuming) {
    document = resumed_document(json_file, scene, scene.steps, options, machine,
                                settings_json(options, threads, scene.steps));
  }

  // The reference: the first scheduler on 1 thread, uninstrumented and uncounted.
  if (!options.quiet) {
    fmt::print(
        "clothbench sweep: {}{} ({}), {} steps, {} schedulers x {} thread counts, "
        "repeat {} (retries {}), OMP_WAIT_POLICY {}, instrument {}{}, bind {}\n",
        options.size_class ? "class " + *options.size_class + ": " : std::string(), scene.name,
        scene.file.string(), scene.steps, grid.size(), threads.size(), options.repeat,
        options.retries, omp_wait_policy(), to_string(options.instrument),
        instrument_only.empty() ? std::string()
                                : fmt::format(" (only {})", fmt::join(instrument_only, ", ")),
        to_string(options.bind));
    std::fflush(stdout);
  }
  // From here on Ctrl-C / SIGTERM stop the sweep after the run in progress (stop_request.hpp).
  const StopRequest stop;
  const std::filesystem::path reference_file = options.output_dir / kReferenceStateFile;
  // A resumed sweep never runs the reference again: it compares its rows with the reference
  // state stored by the session that ran it, or, when that file is missing or not the one
  // sweep.json names (a sweep continued from a copy of its sweep.json), with its digest.
  StateReference reference;
  std::string reference_source = "run";
  if (resuming) {
    std::string why;
    reference = StateReference::of_digest(document["reference"]["state_digest"].get<std::string>());
    if (std::optional<std::string> stored =
            stored_reference_state(options.output_dir, reference.digest, why)) {
      reference.bytes = std::move(*stored);
      reference_source = "stored";
      if (!options.quiet) {
        fmt::print("  reference: the stored final state of the 1-thread reference run ({}, "
                   "digest {}), not run again\n",
                   reference_file.string(), reference.digest);
      }
    } else {
      reference_source = "digest";
      if (!options.quiet) {
        fmt::print("  reference: {}; the rows are compared with the reference's digest {} "
                   "(not run again)\n",
                   why, reference.digest);
      }
    }
  }
  // The cloth picture comes from the reference run, right after it: the reference's simulation
  // is not kept while the rows run (at the paper's size it is most of a run's memory).
  PlotOutcome cloth;
  json reference_entry = resuming ? document["reference"] : json::object();
  std::optional<MeasuredRun> reference_run;
  if (reference_source == "run") {
    std::unique_ptr<kernels::Simulation> reference_simulation;
    const MeasuredRun& run = reference_run.emplace(
        fresh_run(scene, *schedulers::make_driver(grid.front().given), 1, scene.steps,
                  kernels::Instrumentation::off, nullptr, &reference_simulation));
    reference = StateReference::of_bytes(state_bytes(*reference_simulation));
    if (!run.verification.passed && !options.quiet) {
      fmt::print("  warning: the reference run itself fails verification: {}\n",
                 run.verification.failures.front());
    }
    write_file_atomically(reference_file, *reference.bytes);
    if (options.plots && gnuplot_available()) {
      cloth = plot_cloth(cloth_picture(*reference_simulation),
                         fmt::format("{} after {} steps", scene.name, scene.steps),
                         options.output_dir);
    }
    reference_entry = {{"scheduler", grid.front().canonical},
                       {"threads", 1},
                       {"state_digest", run.state_digest},
                       {"state_bytes", reference.bytes->size()},
                       {"verification_passed", run.verification.passed},
                       {"wall_seconds", run.accounting.wall_seconds},
                       {"disturbed", run.disturbance.disturbed},
                       {"counted_in_row", false}};
  }
  if (!resuming) {
    document = {{"schema", "clothbench.sweep"},
                {"schema_version", kSweepSchemaVersion},
                {"created_utc", utc_now()},
                {"rows", json::array()}};
    document["machine"] = machine;
  }
  document["reference"] = reference_entry;
  document["updated_utc"] = utc_now();
  document["complete"] = false;
  document["command"] = options.command_line;
  document["settings"] = settings_json(options, threads, scene.steps);
  document["scene"] = {{"name", scene.name},
                       {"file", scene.file.string()},
                       {"hash", scene.source_sha256_or_fnv},
                       {"source", scene.source_text}};
  // The first session's machine context stays the document's (a resume checked that the
  // fields that matter are the same); every session adds its start, load and reference.
  if (!document["sessions"].is_array()) document["sessions"] = json::array();
  document["sessions"].push_back({{"started_utc", machine["date_utc"]},
                                  {"load_average", machine["load_average"]},
                                  {"rows_at_start", document["rows"].size()},
                                  {"reference", reference_source}});
  document["openmp_environment"] = openmp_environment();
  if (const json& load = machine["load_average"];
      !load.empty() && load[0].get<double>() > 0.5 && !options.quiet) {
    fmt::print(stderr,
               "clothbench: warning: load average {:.2f} on {} hardware threads - other "
               "processes compete for the cores and the timings will show it\n",
               load[0].get<double>(), hardware);
  }
  // Without a warm-up or binding, the reference run was measured exactly as an uninstrumented
  // 1-thread run of the first scheduler's row (fresh simulation, same driver, same clocks and
  // disturbance check): when it is long enough that the process's start-up costs do not show
  // (the tiny test scene's first run is about 1.5x its later ones), it becomes that row's first
  // run instead of being thrown away. At the paper's size it is the longest run of the sweep
  // (about 53 minutes on a 2-core VM).
  if (reference_run &&
      reference_counts_in_row(options, threads,
                              {resuming, reference_run->disturbance.disturbed,
                               reference_run->accounting.wall_seconds})) {
    reference_run->reference = true;
    store_partial_row(document, {grid.front().canonical, 1}, {*reference_run}, {});
    document["reference"]["counted_in_row"] = true;
    if (!options.quiet) {
      fmt::print("  reference: counted as the first uninstrumented run of {} x 1 thread\n",
                 grid.front().canonical);
    }
  }
  write_outputs(document, options.output_dir);

  auto runs_per_row = [&](const GridScheduler& s) {
    return options.repeat * (instruments(s.canonical) ? 2 : 1);
  };
  double units_to_do = 0.0;
  for (const auto& s : grid) {
    for (int n : threads) {
      if (has_row(document, {s.canonical, n})) continue;
      units_to_do += options.warmup_steps + static_cast<double>(runs_per_row(s)) * scene.steps;
    }
  }
  ProgressBar progress(units_to_do, !options.quiet);
  bool all_passed = true;
  for (const json& row : document["rows"]) all_passed = all_passed && row["verification"]["passed"].get<bool>();

  // One row: the warm-up and the measured runs; nullopt when a stop was asked for during it
  // (checked after every run, so Ctrl-C waits for one run at most, not for a whole row).
  auto measure_row = [&](const GridScheduler& s, int n) -> std::optional<json> {
    const std::string label = fmt::format("{} x {} threads", s.canonical, n);
    const bool instrumented = instruments(s.canonical);
    const kernels::Instrumentation level =
        instrumented ? options.instrument : kernels::Instrumentation::off;
    const auto driver = schedulers::make_driver(s.given);
    omp_set_num_threads(n);
    const bool bound = options.bind == BindMode::core && binder.bind_team(options.bind);
    // The runs an interrupted session finished for this row are taken up; each run finished
    // here is stored at once, so a stop or a kill loses at most the run in progress.
    std::vector<MeasuredRun> plain, timed;
    const RowKey key{s.canonical, n};
    double stored_round_trip = 0.0;
    const bool taken_up = take_partial_row(document, key, plain, timed, &stored_round_trip);
    // Where the host put the cores the team runs on (core_round_trip.hpp): before the row's
    // first run (kept with its runs when a session began the row) and after its last.
    const double round_trip_before =
        n < 2 ? 0.0 : stored_round_trip > 0.0 ? stored_round_trip : core_round_trip_ns();
    if (options.warmup_steps > 0) {
      fresh_run(scene, *driver, n, std::min(options.warmup_steps, scene.steps),
                kernels::Instrumentation::off, nullptr);
      if (stop.signal() != 0) return std::nullopt;
    }
    progress.advance(options.warmup_steps, label);
    // One repetition at `level`, re-run while other work disturbed it (up to --retries
    // times); nullopt when a stop was asked for before a re-run (the resume measures that
    // repetition again). A run that finished is returned even when a stop is pending: the
    // caller keeps it, then stops.
    auto repetition = [&](kernels::Instrumentation level) -> std::optional<MeasuredRun> {
      auto measured = [&] {
        return fresh_run(scene, *driver, n, scene.steps, level, &reference);
      };
      MeasuredRun run = measured();
      for (int retry = 0; retry < options.retries && run.disturbance.disturbed; ++retry) {
        if (stop.signal() != 0) return std::nullopt;
        const int attempts = run.attempts + 1;
        run = measured();
        run.attempts = attempts;
      }
      progress.advance(scene.steps, label);
      return run;
    };
    if (taken_up) {
      if (!options.quiet) {
        progress.clear();
        fmt::print("  {}: {} run(s) taken from the interrupted session\n", label,
                   plain.size() + timed.size());
      }
      progress.advance(static_cast<double>(scene.steps) *
                           static_cast<double>(plain.size() + timed.size()),
                       label);
    }
    // Stores a finished run; false when a stop was asked for meanwhile and the row still
    // needs runs (a row whose last run finished is completed before the sweep stops).
    auto keep = [&](std::vector<MeasuredRun>& list, MeasuredRun&& run) {
      list.push_back(std::move(run));
      store_partial_row(document, key, plain, timed, round_trip_before);
      write_outputs(document, options.output_dir);
      return stop.signal() == 0 ||
             plain.size() + timed.size() >= static_cast<std::size_t>(runs_per_row(s));
    };
    for (int r = 0; r < options.repeat; ++r) {  // interleaved, so drift hits both alike
      if (static_cast<std::size_t>(r) >= plain.size()) {
        std::optional<MeasuredRun> run = repetition(kernels::Instrumentation::off);
        if (!run || !keep(plain, std::move(*run))) return std::nullopt;
      }
      if (instrumented && static_cast<std::size_t>(r) >= timed.size()) {
        std::optional<MeasuredRun> run = repetition(level);
        if (!run || !keep(timed, std::move(*run))) return std::nullopt;
      }
    }
    const double round_trip_after = n >= 2 ? core_round_trip_ns() : 0.0;
    if (options.trace_dir) {
      if (stop.signal() != 0) return std::nullopt;  // the resume makes the traced runs
      traced_row_run(scene, *driver, n, std::min(3, options.repeat), reference,
                     *options.trace_dir, trace_models, options.quiet);
      if (stop.signal() != 0) return std::nullopt;
    }
    json binding = {{"mode", to_string(options.bind)},
                    {"bound", bound},
                    {"threads", binder.record_team()}};
    json row = make_row(s.given, s.canonical, s.note, n, n > hardware, plain, timed, level,
                        scene.steps, std::move(binding));
    if (n >= 2) {
      row["core_round_trip_ns"] = {{"before", round_trip_before}, {"after", round_trip_after}};
    }
    return row;
  };

  for (const GridScheduler& s : grid) {
    for (int n : threads) {
      if (has_row(document, {s.canonical, n})) continue;
      if (stop.signal() != 0) break;
      std::optional<json> row = measure_row(s, n);
      if (!row) break;
      all_passed = all_passed && (*row)["verification"]["passed"].get<bool>();
      drop_partial_row(document, {s.canonical, n});
      document["rows"].push_back(*row);
      write_outputs(document, options.output_dir);  // an interrupted sweep keeps this row
      if (!options.quiet) {
        progress.clear();
        fmt::print("{}", format_row_line(*row));
        std::fflush(stdout);
      }
    }
  }
  std::size_t finished = 0;
  for (const auto& s : grid) {
    for (int n : threads) finished += has_row(document, {s.canonical, n}) ? 1 : 0;
  }
  if (stop.signal() != 0 && finished < grid.size() * threads.size()) {
    progress.clear();
    std::size_t partial_runs = 0;
    if (document.contains("partial_rows")) {
      for (const json& entry : document["partial_rows"]) {
        partial_runs += entry["plain"].size() + entry["timed"].size();
      }
    }
    fmt::print(stderr,
               "clothbench sweep: stopped by {}: {} of {} rows are finished and kept in {}{}\n"
               "  resume with: {}\n"
               "  (the resumed sweep does not run the reference again: it compares its rows with "
               "the reference's final state kept in {}, or with its digest in sweep.json)\n",
               signal_name(stop.signal()), finished, grid.size() * threads.size(),
               json_file.string(),
               partial_runs == 0
                   ? std::string()
                   : fmt::format(",\n  with {} finished run(s) of the unfinished row (the resume "
                                 "takes them up)",
                                 partial_runs),
               resume_command(options), reference_file.string());
    return 128 + stop.signal();
  }
  progress.clear();
  document["complete"] = true;
  write_outputs(document, options.output_dir);

  if (options.plots) {
    if (!gnuplot_available()) {
      fmt::print(stderr, "clothbench: gnuplot not found; no plots written\n");
    } else {
      PlotOutcome figures = plot_sweep(document, options.output_dir);
      figures.images.insert(figures.images.end(), cloth.images.begin(), cloth.images.end());
      figures.problems.insert(figures.problems.end(), cloth.problems.begin(), cloth.problems.end());
      for (const std::string& p : figures.problems) fmt::print(stderr, "clothbench: {}\n", p);
      if (!options.quiet) {
        for (const auto& image : figures.images) fmt::print("  wrote {}\n", image.string());
      }
    }
  }
  if (!options.quiet) {
    fmt::print("  wrote {}, table.md, table.csv\nVerification: {}\n", json_file.string(),
               all_passed ? "PASSED" : "FAILED");
  }
  return all_passed ? 0 : 1;
}

}  // namespace clothbench::harness
