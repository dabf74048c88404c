// Trends and non-finite values of stress cells (see stress_metrics.hpp).
#include "harness/stress/stress_metrics.hpp"

#include <algorithm>
#include <regex>

namespace clothbench::harness {

Trend trend_of(const std::vector<double>& values, double floor) {
  Trend t;
  const std::size_t n = values.size();
  if (n < 4) return t;
  t.assessed = true;
  for (std::size_t q = 0; q < 4; ++q) {
    // Quarter q holds [q n / 4, (q + 1) n / 4): sizes differ by at most one.
    const std::size_t begin = q * n / 4, end = (q + 1) * n / 4;
    double sum = 0.0;
    for (std::size_t k = begin; k < end; ++k) sum += values[k];
    t.quarter_mean[q] = sum / static_cast<double>(end - begin);
  }
  const double first = t.quarter_mean[0], last = t.quarter_mean[3];
  if (first > 0.0) t.ratio = last / first;
  t.growing = last > kUnboundedGrowthFactor * std::max(first, floor) && last >= t.quarter_mean[2];
  return t;
}

NonFiniteValue parse_non_finite(int step, std::string_view text) {
  NonFiniteValue v;
  v.step = step;
  v.text = std::string(text);
  // "<what> of <kind>[ centred at] <(i, j)[->(k, l)]>[ component <c>| along <d>] = <value>"
  static const std::regex sentence(
      R"(^(.+?) of (particle|ghost|edge|triple)(?: centred at)? (\([0-9, ]+\)(?:->\([0-9, ]+\))?))"
      R"((?: (component [xyz]|along [ij]))? = (nan|inf|-inf)$)");
  std::smatch m;
  if (std::regex_match(v.text, m, sentence)) {
    v.element = m[2].str();
    v.index = m[3].str();
    std::string detail = m[4].str();
    if (detail.rfind("component ", 0) == 0) detail = detail.substr(10);  // "position x"
    v.term = detail.empty() ? m[1].str() : m[1].str() + " " + detail;
    v.value = m[5].str();
    return v;
  }
  v.element = "step";
  v.term = v.text == "the step's cost" ? "cost" : v.text;
  return v;
}

}  // namespace clothbench::harness
