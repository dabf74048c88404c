// Shared pieces of the paper experiments: scene sizes, one verified run, surface distances.
#include "harness/experiment/experiment_runs.hpp"

#include <fmt/core.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numeric>
#include <stdexcept>

#include "kernels/simulation.hpp"

namespace clothbench::harness {

ExperimentSize parse_experiment_size(const std::string& text, const char* flag) {
  if (text == "paper") return ExperimentSize::paper;
  if (text == "small") return ExperimentSize::small;
  if (text == "tiny") return ExperimentSize::tiny;
  throw std::invalid_argument(
      fmt::format("{}: unknown size '{}' (paper, small, tiny)", flag, text));
}

std::string to_string(ExperimentSize size) {
  switch (size) {
    case ExperimentSize::paper: return "paper";
    case ExperimentSize::small: return "small";
    case ExperimentSize::tiny: return "tiny";
  }
  return "?";
}

Eigen::Vector3d SurfaceSample::at(double u, double v) const {
  const double x = std::clamp(u, 0.0, 1.0) * (size_i - 1);
  const double y = std::clamp(v, 0.0, 1.0) * (size_j - 1);
  const int i = std::min(static_cast<int>(x), size_i - 2);
  const int j = std::min(static_cast<int>(y), size_j - 2);
  const double a = x - i, b = y - j;
  auto p = [&](int di, int dj) -> const Eigen::Vector3d& {
    return points[static_cast<std::size_t>(i + di) + static_cast<std::size_t>(size_i) * (j + dj)];
  };
  return (1 - a) * (1 - b) * p(0, 0) + a * (1 - b) * p(1, 0) + (1 - a) * b * p(0, 1) +
         a * b * p(1, 1);
}

SurfaceError surface_error(const SurfaceSample& surface, const SurfaceSample& reference) {
  SurfaceError error;
  double sum = 0.0;
  for (int j = 0; j < reference.size_j; ++j) {
    for (int i = 0; i < reference.size_i; ++i) {
      const double u = static_cast<double>(i) / (reference.size_i - 1);
      const double v = static_cast<double>(j) / (reference.size_j - 1);
      const double d =
          (surface.at(u, v) - reference.points[static_cast<std::size_t>(i + reference.size_i * j)])
              .norm();
      sum += d * d;
      error.max = std::max(error.max, d);
    }
  }
  error.rms = std::sqrt(sum / (static_cast<double>(reference.size_i) * reference.size_j));
  return error;
}

Scene load_experiment_scene(const std::filesystem::path& file) {
  return load_scene(file, default_presets_file());
}

void resize_cloth(Scene& scene, int particles) {
  kernels::SimulationConfig& config = scene.simulation;
  if (config.amrc.enabled && (particles - 1) % (1 << config.amrc.levels) != 0) {
    throw std::invalid_argument(fmt::format(
        "{}: {} particles per side do not fit AMRC with {} levels (need 2^L n + 1)",
        scene.file.string(), particles, config.amrc.levels));
  }
  config.cloth.particles_i = particles;
  config.cloth.particles_j = particles;
}

namespace {

SurfaceSample sample_surface(const kernels::Simulation& simulation) {
  const kernels::ClothMesh& mesh = simulation.mesh();
  const std::vector<double> x = simulation.surface_positions();
  SurfaceSample sample;
  sample.size_i = mesh.size_i();
  sample.size_j = mesh.size_j();
  sample.points.reserve(static_cast<std::size_t>(sample.size_i) * sample.size_j);
  for (int j = 0; j < sample.size_j; ++j) {
    for (int i = 0; i < sample.size_i; ++i) {
      const std::size_t s = static_cast<std::size_t>(mesh.slot(i, j));
      sample.points.emplace_back(x[3 * s], x[3 * s + 1], x[3 * s + 2]);
    }
  }
  return sample;
}

}  // namespace

VariantRun run_variant(const Scene& scene, const std::string& label, const std::string& setting,
                       schedulers::LoopDriver& driver, int threads, bool quiet) {
  check_memory(scene);
  omp_set_num_threads(threads);
  const auto simulation = std::make_unique<kernels::Simulation>(scene.simulation);
  VariantRun run;
  run.label = label;
  run.setting = setting;
  run.particles_start = simulation->diagnostics().active_particles;
  run.summary = simulate(*simulation, driver, scene.steps, /*quiet=*/true);
  run.summary.threads = threads;
  run.seconds = run.summary.wall_seconds;
  run.particles_end = run.summary.final_state.active_particles;
  for (const StepRecord& step : run.summary.steps) {
    run.element_updates += static_cast<double>(step.active_elements) * step.evaluations;
  }
  run.contact_force = run.summary.final_state.contact_force;
  run.surface = sample_surface(*simulation);
  run.passed = run.summary.verification.passed && run.summary.non_finite.empty();
  if (!quiet) {
    fmt::print("  {:<22} {:>4} x {:<4} {:>4} steps  {:9.3f} s  particles {:>8} -> {:<8}  {}\n",
               label, scene.simulation.cloth.particles_i, scene.simulation.cloth.particles_j,
               run.summary.steps.size(), run.seconds, run.particles_start, run.particles_end,
               run.passed ? "PASSED" : "FAILED");
    for (const std::string& failure : run.summary.verification.failures) {
      fmt::print("      {}\n", failure);
    }
    std::fflush(stdout);
  }
  return run;
}

std::vector<std::size_t> pareto_front(const std::vector<double>& time,
                                      const std::vector<double>& error) {
  std::vector<std::size_t> order(time.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return time[a] != time[b] ? time[a] < time[b] : error[a] < error[b];
  });
  std::vector<std::size_t> front;
  double best_error = INFINITY;
  for (std::size_t k : order) {
    if (!std::isfinite(time[k]) || !std::isfinite(error[k])) continue;
    if (error[k] < best_error) {  // faster points all had a larger error
      front.push_back(k);
      best_error = error[k];
    }
  }
  return front;
}

std::string cell(double value, int digits) {
  if (!std::isfinite(value)) return "-";
  return fmt::format("{:.{}g}", value, digits);
}

}  // namespace clothbench::harness
