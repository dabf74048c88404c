// `clothbench run`: one verified simulation of a scene, with a summary.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

namespace clothbench::harness {

/// Options of one run, as given on the command line.
struct RunOptions {
  std::filesystem::path scene_file;
  std::string scheduler = "static";        ///< scheduler spec, e.g. "dynamic:2@blocks"
  int threads = 0;                         ///< 0 = OpenMP default (OMP_NUM_THREADS or cores)
  bool allow_oversubscribe = false;        ///< threads above hardware PUs only with this
  std::optional<int> steps;                ///< override the scene's step count
  std::optional<std::string> formulation;  ///< override: "potential" | "violation"
  std::optional<std::string> gradient;     ///< override: "analytic" | "numeric"
  std::optional<std::string> kernel;          ///< override: kernels::element_kernel_names()
  std::optional<std::string> method;          ///< override: kernels::step_method_names()
  std::optional<std::string> preconditioner;  ///< override: kernels::preconditioner_names()
  std::filesystem::path output_dir = "results/runs";  ///< where the VTK and JSON go
  bool write_vtk = true;
  bool quiet = false;  ///< no per-step lines
  /// --trace FILE: the per-chunk trace of every loop (harness/trace/trace_file.hpp).
  std::optional<std::filesystem::path> trace_file;
  /// --trace-step N: the step of the trace's timeline picture (default: most chunks).
  std::optional<int> trace_step;
  /// --trace-overheads FILE: the scheduling_overhead micro-benchmark's JSON, whose per-loop
  /// and per-chunk costs go into the trace header for `clothbench predict`.
  std::optional<std::filesystem::path> trace_overheads;
  /// --trace-bandwidth FILE: clothbench-micro's triad JSON, whose bandwidth by thread count
  /// goes into the trace header for the predictor's ceiling (bandwidth_model.hpp).
  std::optional<std::filesystem::path> trace_bandwidth;
  /// --newton-log FILE: every Newton iteration of every step as CSV (newton_log_csv).
  std::optional<std::filesystem::path> newton_log;
};

/// Runs the scene and prints per-step cost, final summary and `Verification: PASSED/FAILED`.
/// Returns the process exit code: 0 passed, 1 verification failed, 2 bad input.
int run_scene(const RunOptions& options);

}  // namespace clothbench::harness
