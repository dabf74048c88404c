// CLOTHBENCH_MICRO_SMOKE=1 runs every clothbench-micro benchmark at a tiny size and for a few
// steps or samples (the suite's smoke test: each benchmark runs once and its counters are
// finite). Smoke figures are not measurements: every benchmark labels them "smoke".
#pragma once

#include <cstdlib>
#include <cstring>

#include "kernels/simulation_config.hpp"

namespace clothbench::micro {

/// True when CLOTHBENCH_MICRO_SMOKE=1 (read once).
inline bool smoke() {
  static const bool on = [] {
    const char* v = std::getenv("CLOTHBENCH_MICRO_SMOKE");
    return v != nullptr && std::strcmp(v, "1") == 0;
  }();
  return on;
}

/// `normal` in a measuring run, `tiny` in a smoke run (sizes, steps, samples).
inline int scaled(int normal, int tiny) { return smoke() ? tiny : normal; }

/// Particles per side of a smoke run's cloth: 2^4 + 1, so that AMRC with up to four coarser
/// levels (every shipped scene) still fits.
constexpr int kSmokeParticles = 17;

/// A scene's cloth at kSmokeParticles per side in a smoke run (same sheet, coarser spacing).
inline void shrink_for_smoke(kernels::SimulationConfig& c) {
  if (smoke()) c.cloth.particles_i = c.cloth.particles_j = kSmokeParticles;
}

}  // namespace clothbench::micro
