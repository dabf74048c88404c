// Figures of a stress cell that are more than a maximum: the trend of a per-step series
// (does it grow without bound?) and the first non-finite value split into its parts.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace clothbench::harness {

/// A series "grows without bound" when its last-quarter mean exceeds this many times the
/// larger of its first-quarter mean and the series' floor, and is not falling at the end.
inline constexpr double kUnboundedGrowthFactor = 10.0;

/// Quarter means of a per-step series (step order) and whether it grows without bound.
struct Trend {
  bool assessed = false;                 ///< at least 4 values (otherwise nothing below is set)
  std::array<double, 4> quarter_mean{};  ///< means of the four consecutive quarters
  std::optional<double> ratio;           ///< last / first quarter mean; none when the first is 0
  bool growing = false;                  ///< see kUnboundedGrowthFactor
};

/// The trend of `values`. `floor` is the level below which the series counts as bounded
/// whatever its ratio (e.g. the converged level of a residual; 0 for none). Quarters split
/// the series as evenly as possible (sizes differ by at most one, the later ones larger).
Trend trend_of(const std::vector<double>& values, double floor);

/// The first non-finite value of a run, as kernels::Simulation::locate_non_finite names it.
struct NonFiniteValue {
  int step = 0;         ///< the step that produced it (1-based)
  std::string element;  ///< "particle", "ghost", "edge", "triple", or "step" (the step's cost)
  std::string index;    ///< grid position, e.g. "(3, 4)" or "(3, 4)->(3, 5)"; "" for "step"
  std::string term;     ///< what held it, e.g. "position x", "tension along j", "cost"
  std::string value;    ///< "nan", "inf" or "-inf"; "" when the text does not say
  std::string text;     ///< the kernel's whole sentence
};

/// Splits the kernel's sentence (e.g. "tension of edge (3, 4)->(3, 5) along j = nan") into
/// its parts; a sentence of another form is kept whole in `term` with element "step".
NonFiniteValue parse_non_finite(int step, std::string_view text);

}  // namespace clothbench::harness
