// `clothbench stress`: the stress matrix of issue 7 (stress_matrix.hpp) run cell by cell, each
// judged PASSED or FAILED (stress_cell.hpp), recorded in OUT/stress.json, stress.csv and
// stress.md (stress_report.hpp), rewritten atomically after every cell.
#pragma once

#include "harness/stress/stress_options.hpp"

namespace clothbench::harness {

/// Runs the selected cells. Bad input (base scene, --only matching nothing, scheduler, thread
/// count) throws SceneError or std::invalid_argument before anything runs; the caller maps
/// those to exit code 2. Returns 0 when every cell passed, 1 when any failed. SIGINT or SIGTERM
/// stops the matrix after the step in progress (a second one ends it at once): the unfinished
/// cell is dropped, the finished ones stay in the output files, and the return value is
/// 128 + the signal number (130 for Ctrl-C, 143 for SIGTERM).
int run_stress(const StressOptions& options);

}  // namespace clothbench::harness
