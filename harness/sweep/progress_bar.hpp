// A one-line progress bar with ETA on stderr for long sweeps; silent when stderr is not a
// terminal or when disabled (--quiet).
#pragma once

#include <string>

namespace clothbench::harness {

/// Progress over a fixed amount of work units (e.g. simulation steps to run).
class ProgressBar {
 public:
  /// `total` units; the bar draws only when `enabled` and stderr is a terminal.
  ProgressBar(double total, bool enabled);
  ~ProgressBar();
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  /// Adds finished units and redraws with `label` (e.g. "dynamic:2 x 4 threads").
  void advance(double units, const std::string& label);
  /// Clears the line (before printing other text) - the next advance() redraws it.
  void clear();
  [[nodiscard]] bool drawing() const { return enabled_; }

  /// "[#####.....]  42%  ETA 1m05s  label" for `fraction` done after `elapsed` seconds.
  static std::string render(double fraction, double elapsed_seconds, const std::string& label,
                            int width);

 private:
  double total_;
  double done_ = 0.0;
  double start_;
  bool enabled_;
};

/// "1h02m", "3m05s", "12s" (rounded to seconds; "?" for negative or non-finite).
std::string format_duration(double seconds);

}  // namespace clothbench::harness
