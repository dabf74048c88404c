// `clothbench predict` on the command line (see predict_command.hpp).
#include "harness/predict/predict_command.hpp"

#include <fmt/core.h>

#include <cstdio>
#include <exception>
#include <iostream>
#include <optional>
#include <stdexcept>

#include "harness/output/atomic_file.hpp"
#include "harness/predict/predict_validation.hpp"
#include "harness/predict/prediction.hpp"
#include "harness/report/sweep_table.hpp"
#include "harness/sweep/sweep_options.hpp"
#include "harness/trace/trace_file.hpp"

namespace clothbench::harness {

namespace {
constexpr int kExitBadInput = 2;
constexpr int kMostThreads = 1 << 16;

int bad(const std::string& text) {
  std::fprintf(stderr, "clothbench predict: %s\n", text.c_str());
  return kExitBadInput;
}
}  // namespace

PredictCommand::PredictCommand(CLI::App& app) : schedulers_(kPaperSchedulers) {
  command_ = app.add_subcommand(
      "predict",
      "Predict Table 2 and Fig. 12 at any thread count by replaying a trace's per-iteration "
      "work through each scheduler on a virtual clock; --validate: against a measured sweep");
  command_->add_option("TRACE", trace_file_, "Trace file (`run --trace` or `sweep --trace`)");
  command_->add_option("--threads", threads_, "Thread counts to predict, e.g. 1,2,4 or 1-8")
      ->capture_default_str();
  command_->add_option("--schedulers", schedulers_, "Comma-separated scheduler specs")
      ->capture_default_str();
  command_->add_option("--overheads", overheads_file_,
                       "Per-loop and per-chunk costs: clothbench-micro "
                       "--benchmark_filter=scheduling_overhead --benchmark_format=json "
                       "--benchmark_out=FILE; what P threads cost beyond 1 thread is added "
                       "above 1 thread (default: the trace's stored costs, else zero; the output "
                       "says which)");
  command_->add_option("--bandwidth", bandwidth_file_,
                       "STREAM triad at 1..cores threads: clothbench-micro "
                       "--benchmark_filter=^triad --benchmark_format=json --benchmark_out=FILE; "
                       "a loop takes at least its bytes / the triad at P threads (default: the "
                       "trace's stored triad, else no ceiling; the output says which)");
  command_->add_option("--out", out_dir_,
                       "Write prediction.json, table.md and fig12.{dat,gp,png} here");
  command_->add_option("--json", json_file_, "Also write the result as JSON to this file");
  command_->add_option("--validate", validate_file_,
                       "sweep.json: predict each measured row and print the error");
  command_->add_option("--trace-dir", trace_dir_,
                       "With --validate: the sweep's `--trace DIR` (its *-1t.cbtrace files)");
  command_->add_option("--from", from_file_,
                       "With --validate: predict every row from this trace instead");
  command_->add_option(
      "--loop-times", loop_times_file_,
      "A trace of the same run with fewer chunks (e.g. static at 1 thread): each loop's time, the "
      "loop spans and the time outside loops are taken from it, and TRACE (e.g. guided:1 at 1 "
      "thread) gives only how each loop's time splits over its iterations, so the cost of "
      "recording hundreds of thousands of chunks drops out (--validate picks it by itself)");
}

int PredictCommand::run() {
  std::optional<OverheadModel> given;  // --overheads; else the trace's stored costs, else 0
  try {
    if (!overheads_file_.empty()) given = read_overhead_model(overheads_file_);
  } catch (const std::invalid_argument& error) {
    return bad(fmt::format("--overheads: {}", error.what()));
  }
  std::optional<BandwidthModel> bandwidth;  // --bandwidth; else the trace's triad, else none
  try {
    if (!bandwidth_file_.empty()) bandwidth = read_bandwidth_model(bandwidth_file_);
  } catch (const std::invalid_argument& error) {
    return bad(fmt::format("--bandwidth: {}", error.what()));
  }
  if (!validate_file_.empty()) return run_validation(given, bandwidth);
  if (trace_file_.empty()) return bad("TRACE: a trace file is required (or --validate SWEEP.json)");
  std::vector<int> threads;
  std::vector<std::string> schedulers;
  try {
    threads = parse_thread_list(threads_, "--threads");
    for (int t : threads) {
      if (t > kMostThreads) {
        throw std::invalid_argument(fmt::format(
            "--threads: {} is more than the {} the predictor simulates", t, kMostThreads));
      }
    }
    schedulers = split_list(schedulers_, "--schedulers");
    for (const std::string& s : schedulers) {
      try {
        (void)ScheduleModel::parse(s, OmpRuntimeModel::libgomp);
      } catch (const std::invalid_argument& error) {
        throw std::invalid_argument(fmt::format("--schedulers: {}", error.what()));
      }
    }
  } catch (const std::invalid_argument& error) {
    return bad(error.what());
  }
  TraceWorkload workload;
  try {
    workload = build_workload(read_trace(trace_file_), trace_file_.string());
  } catch (const std::exception& error) {
    return bad(fmt::format("TRACE: {}", error.what()));
  }
  if (!loop_times_file_.empty()) {
    try {
      const TraceWorkload totals =
          build_workload(read_trace(loop_times_file_), loop_times_file_.string());
      take_loop_times(workload, totals, trace_file_.string(), loop_times_file_.string());
    } catch (const std::exception& error) {
      return bad(fmt::format("--loop-times: {}", error.what()));
    }
  }
  Prediction prediction;
  try {
    prediction = predict(workload, trace_file_.string(), schedulers, threads,
                         choose_overheads(given, workload), choose_bandwidth(bandwidth, workload));
  } catch (const std::invalid_argument& error) {
    return bad(fmt::format("--schedulers: {}", error.what()));
  }
  std::cout << format_prediction_markdown(prediction);
  try {
    if (!out_dir_.empty()) {
      const PlotOutcome plots = write_prediction_outputs(prediction, out_dir_);
      for (const auto& image : plots.images) std::cout << "wrote " << image.string() << "\n";
      for (const auto& problem : plots.problems) std::cerr << "clothbench: " << problem << "\n";
    }
    if (!json_file_.empty()) {
      write_file_atomically(json_file_, prediction_json(prediction).dump(2) + "\n");
    }
  } catch (const std::exception& error) {
    return bad(fmt::format("--out/--json: {}", error.what()));
  }
  return 0;
}

int PredictCommand::run_validation(const std::optional<OverheadModel>& given,
                                   const std::optional<BandwidthModel>& bandwidth) {
  if (trace_dir_.empty() && from_file_.empty()) {
    return bad("--validate: needs --trace-dir DIR (the sweep's --trace DIR) or --from TRACE");
  }
  nlohmann::json sweep;
  try {
    sweep = load_sweep_document(validate_file_);
  } catch (const std::invalid_argument& error) {
    return bad(fmt::format("--validate: {}", error.what()));
  }
  Validation validation;
  try {
    validation = validate_prediction(
        sweep, validate_file_.string(), trace_dir_,
        from_file_.empty() ? std::nullopt : std::optional<std::filesystem::path>(from_file_), given,
        bandwidth);
  } catch (const std::invalid_argument& error) {
    return bad(error.what());
  }
  std::cout << format_validation_markdown(validation);
  if (!json_file_.empty()) {
    try {
      write_file_atomically(json_file_, validation_json(validation).dump(2) + "\n");
    } catch (const std::exception& error) {
      return bad(fmt::format("--json: {}", error.what()));
    }
  }
  return 0;
}

}  // namespace clothbench::harness
