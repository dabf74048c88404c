// Progress bar with ETA (see progress_bar.hpp).
#include "harness/sweep/progress_bar.hpp"

#include <fmt/core.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "kernels/loop_runner.hpp"

namespace clothbench::harness {

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0.0) return "?";
  const long s = std::lround(seconds);
  if (s >= 3600) return fmt::format("{}h{:02d}m", s / 3600, (s % 3600) / 60);
  if (s >= 60) return fmt::format("{}m{:02d}s", s / 60, s % 60);
  return fmt::format("{}s", s);
}

ProgressBar::ProgressBar(double total, bool enabled)
    : total_(total), start_(kernels::monotonic_seconds()),
      enabled_(enabled && isatty(fileno(stderr)) != 0) {}

ProgressBar::~ProgressBar() { clear(); }

std::string ProgressBar::render(double fraction, double elapsed_seconds, const std::string& label,
                                int width) {
  fraction = std::clamp(fraction, 0.0, 1.0);
  const int filled = static_cast<int>(std::lround(fraction * width));
  const double eta = fraction > 0.0 ? elapsed_seconds * (1.0 - fraction) / fraction : -1.0;
  return fmt::format("[{}{}] {:3.0f}%  ETA {:>6}  {}", std::string(filled, '#'),
                     std::string(width - filled, '.'), 100.0 * fraction, format_duration(eta),
                     label);
}

void ProgressBar::advance(double units, const std::string& label) {
  done_ += units;
  if (!enabled_) return;
  const double fraction = total_ > 0.0 ? done_ / total_ : 1.0;
  const std::string line =
      render(fraction, kernels::monotonic_seconds() - start_, label, 30);
  std::fprintf(stderr, "\r\033[K%s", line.c_str());
  std::fflush(stderr);
}

void ProgressBar::clear() {
  if (!enabled_) return;
  std::fprintf(stderr, "\r\033[K");
  std::fflush(stderr);
}

}  // namespace clothbench::harness
