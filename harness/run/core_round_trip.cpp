// A cache line bounced between two threads (see core_round_trip.hpp).
#include "harness/run/core_round_trip.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <vector>

#include "harness/machine/machine_context.hpp"

namespace clothbench::harness {

double core_round_trip_ns(int trips, int samples) {
  if (hardware_threads() < 2 || trips < 1 || samples < 1) return 0.0;
  using Clock = std::chrono::steady_clock;
  std::vector<double> measured;
  alignas(64) std::atomic<int> ball{0};
#pragma omp parallel num_threads(2)
  {
    const int me = omp_get_thread_num();
    const bool pair = omp_get_num_threads() == 2;  // the same on both threads
    for (int sample = 0; pair && sample < samples; ++sample) {
#pragma omp barrier
      const Clock::time_point start = Clock::now();
      for (int trip = 0; trip < trips; ++trip) {
        const int mine = 2 * trip + me;  // thread 0 serves the even values, 1 the odd ones
        while (ball.load(std::memory_order_acquire) != mine) {
        }
        ball.store(mine + 1, std::memory_order_release);
      }
      const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
#pragma omp barrier
      if (me == 0) {
        measured.push_back(seconds / trips * 1e9);
        ball.store(0, std::memory_order_relaxed);
      }
    }
  }
  if (measured.empty()) return 0.0;
  const auto middle = measured.begin() + static_cast<std::ptrdiff_t>(measured.size() / 2);
  std::nth_element(measured.begin(), middle, measured.end());
  return *middle;
}

bool round_trip_changed(double before_ns, double after_ns) {
  if (before_ns <= 0.0 || after_ns <= 0.0) return false;
  return std::max(before_ns, after_ns) > 2.0 * std::min(before_ns, after_ns);
}

}  // namespace clothbench::harness
