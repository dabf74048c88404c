// `clothbench sweep`: every scheduler x thread count of a scene, timed, decomposed into the
// paper's Table 2 overheads, verified, and written as sweep.json / table.md / table.csv /
// PNG plots (results/README.md describes the files).
#pragma once

#include "harness/sweep/sweep_options.hpp"

namespace clothbench::harness {

/// Runs the sweep. Bad input (scene, scheduler names, thread counts, an incompatible
/// --resume file) throws SceneError or std::invalid_argument before anything runs; the
/// caller maps those to exit code 2. Returns 0 when every row passed verification, 1 when
/// any failed. OUT/sweep.json is rewritten atomically after each finished row. SIGINT or
/// SIGTERM stops the sweep after the run in progress (a second one ends it at once): the
/// finished rows stay in OUT/sweep.json, the command that resumes it is printed, and the
/// return value is 128 + the signal number (130 for Ctrl-C, 143 for SIGTERM).
int run_sweep(const SweepOptions& options);

}  // namespace clothbench::harness
