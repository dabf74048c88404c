// Self-test probes of scheduling drivers (see self_test.hpp).
#include "schedulers/self_test.hpp"

#include <omp.h>

#include <array>
#include <atomic>
#include <vector>

#include "schedulers/registry.hpp"
#include "schedulers/text.hpp"

namespace clothbench::schedulers {

std::string ProbeReport::describe() const {
  if (exactly_once) return concat("every index visited exactly once with ", threads, " threads");
  std::string text;
  if (first_wrong_index >= 0) {
    text =
        concat("index ", first_wrong_index, " of ", first_wrong_n, " visited ", first_wrong_visits,
               " times with ", threads, " threads (", wrong_indices, " indices wrong)");
  }
  if (range_out_of_bounds)
    text += concat(text.empty() ? "" : "; ", "a range was empty or out of bounds");
  return text;
}

ProbeReport probe_exactly_once(LoopDriver& driver, int threads) {
  constexpr std::array<std::int64_t, 3> sizes{1000, 0, 3};
  std::array<std::vector<std::atomic<int>>, sizes.size()> visits;
  for (std::size_t loop = 0; loop < sizes.size(); ++loop) {
    visits[loop] = std::vector<std::atomic<int>>(static_cast<std::size_t>(sizes[loop]));
  }
  std::atomic<bool> out_of_bounds{false};
  std::atomic<int> team_size{1};
#pragma omp parallel num_threads(threads)
  {
#pragma omp single nowait
    team_size.store(omp_get_num_threads(), std::memory_order_relaxed);
    for (std::size_t loop = 0; loop < sizes.size(); ++loop) {
      std::vector<std::atomic<int>>& counts = visits[loop];
      const std::int64_t n = sizes[loop];
      auto body = [&](std::int64_t begin, std::int64_t end) {
        if (begin < 0 || end > n || begin >= end) {
          out_of_bounds.store(true, std::memory_order_relaxed);
          return;
        }
        for (std::int64_t i = begin; i < end; ++i) {
          counts[static_cast<std::size_t>(i)].fetch_add(1, std::memory_order_relaxed);
        }
      };
      driver.for_range(n, body);
    }
  }
  ProbeReport report;
  report.threads = team_size.load();
  report.range_out_of_bounds = out_of_bounds.load();
  for (std::size_t loop = 0; loop < sizes.size(); ++loop) {
    for (std::size_t i = 0; i < visits[loop].size(); ++i) {
      const int count = visits[loop][i].load();
      if (count == 1) continue;
      if (report.wrong_indices++ == 0) {
        report.first_wrong_n = sizes[loop];
        report.first_wrong_index = static_cast<std::int64_t>(i);
        report.first_wrong_visits = count;
      }
    }
  }
  report.exactly_once = report.wrong_indices == 0 && !report.range_out_of_bounds;
  return report;
}

std::vector<RuntimeDefect> detect_runtime_defects() {
  std::vector<RuntimeDefect> defects;
  for (const char* spec :
       {"monotonic:static", "monotonic:static:3", "nonmonotonic:static", "nonmonotonic:static:3"}) {
    const std::unique_ptr<LoopDriver> driver = make_driver_without_self_test(spec);
    const ProbeReport report = probe_exactly_once(*driver);
    if (!report.exactly_once) defects.push_back({driver->name(), report.describe()});
  }
  return defects;
}

}  // namespace clothbench::schedulers
