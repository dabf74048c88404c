// Disturbance of a timed run by other work on the machine (see disturbance.hpp).
#include "harness/run/disturbance.hpp"

#include <fmt/core.h>
#include <sys/resource.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>

#include "kernels/loop_runner.hpp"

namespace clothbench::harness {

namespace {

double seconds(const timeval& t) {
  return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec);
}

}  // namespace

ResourceSample sample_resources() {
  ResourceSample s;
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) == 0) {
    s.cpu_seconds = seconds(usage.ru_utime) + seconds(usage.ru_stime);
    s.involuntary_switches = usage.ru_nivcsw;
  }
  double load[1];
  if (getloadavg(load, 1) == 1) s.load_average = load[0];
  s.wall_seconds = kernels::monotonic_seconds();
  return s;
}

std::string omp_wait_policy() {
  const char* value = std::getenv("OMP_WAIT_POLICY");  // NOLINT(concurrency-mt-unsafe)
  if (value == nullptr || *value == '\0') return "unset";
  std::string policy(value);
  std::transform(policy.begin(), policy.end(), policy.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return policy;
}

Disturbance assess_disturbance(const ResourceSample& before, const ResourceSample& after,
                               int threads, int hardware_threads, const std::string& wait_policy,
                               const DisturbanceCriteria& criteria) {
  Disturbance d;
  d.threads = std::max(1, threads);
  d.usable_cores = std::max(1, std::min(d.threads, std::max(1, hardware_threads)));
  d.oversubscribed = hardware_threads > 0 && d.threads > hardware_threads;
  d.wall_seconds = after.wall_seconds - before.wall_seconds;
  d.cpu_seconds = after.cpu_seconds - before.cpu_seconds;
  d.involuntary_switches = after.involuntary_switches - before.involuntary_switches;
  d.load_before = before.load_average;
  d.load_after = after.load_average;
  d.wait_policy = wait_policy;
  const double core_seconds = d.wall_seconds * d.usable_cores;
  d.cpu_share = core_seconds > 0.0 ? d.cpu_seconds / core_seconds : 0.0;
  d.switch_rate =
      core_seconds > 0.0 ? static_cast<double>(d.involuntary_switches) / core_seconds : 0.0;

  if (!d.oversubscribed && d.involuntary_switches > criteria.min_switches &&
      d.switch_rate > criteria.max_switch_rate) {
    d.reasons.push_back(fmt::format(
        "{} involuntary context switches ({:.0f} per second per core, above {:.0f}): another "
        "process took the cores",
        d.involuntary_switches, d.switch_rate, criteria.max_switch_rate));
  }
  if (wait_policy == "active" && d.wall_seconds > 0.0 && d.cpu_share < criteria.min_cpu_share) {
    d.reasons.push_back(fmt::format(
        "CPU time {:.3g} s is {:.0f} % of wall x {} cores (below {:.0f} % with spinning waits)",
        d.cpu_seconds, 100.0 * d.cpu_share, d.usable_cores, 100.0 * criteria.min_cpu_share));
  }
  const double limit = hardware_threads + criteria.load_margin;
  if (hardware_threads > 0 && d.load_before > limit && d.load_after > limit) {
    d.reasons.push_back(fmt::format(
        "load average {:.2f} before and {:.2f} after, above {} hardware threads + {:g}",
        d.load_before, d.load_after, hardware_threads, criteria.load_margin));
  }
  d.disturbed = !d.reasons.empty();
  return d;
}

nlohmann::json disturbance_json(const Disturbance& d) {
  auto load = [](double value) { return value < 0.0 ? nlohmann::json(nullptr) : nlohmann::json(value); };
  return {{"disturbed", d.disturbed},
          {"reasons", d.reasons},
          {"cpu_seconds", d.cpu_seconds},
          {"wall_seconds", d.wall_seconds},
          {"cpu_share", d.cpu_share},
          {"involuntary_switches", d.involuntary_switches},
          {"switch_rate_per_core_second", d.switch_rate},
          {"load_before", load(d.load_before)},
          {"load_after", load(d.load_after)},
          {"wait_policy", d.wait_policy},
          {"oversubscribed", d.oversubscribed}};
}

}  // namespace clothbench::harness
