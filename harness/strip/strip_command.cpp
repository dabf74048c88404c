// `clothbench strip` on the command line (see strip_command.hpp).
#include "harness/strip/strip_command.hpp"

#include <fmt/core.h>
#include <stdio.h>  // open_memstream (POSIX)

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "harness/machine/machine_context.hpp"
#include "harness/output/atomic_file.hpp"
#include "harness/scene/scene.hpp"

namespace clothbench::harness {

namespace {
constexpr int kExitFailed = 1;
constexpr int kExitBadInput = 2;

int bad(const std::string& text) {
  std::fprintf(stderr, "clothbench strip: %s\n", text.c_str());
  return kExitBadInput;
}

/// Text written through a FILE* into memory (the trace), handed over at the end so that a
/// file is written whole or not at all.
class MemoryStream {
 public:
  MemoryStream() : file_(open_memstream(&buffer_, &size_)) {}
  ~MemoryStream() {
    if (file_ != nullptr) std::fclose(file_);
    std::free(buffer_);
  }
  MemoryStream(const MemoryStream&) = delete;
  MemoryStream& operator=(const MemoryStream&) = delete;
  std::FILE* file() { return file_; }
  std::string text() {
    if (file_ == nullptr) return {};
    std::fflush(file_);
    return buffer_ == nullptr ? std::string() : std::string(buffer_, size_);
  }

 private:
  char* buffer_ = nullptr;
  std::size_t size_ = 0;
  std::FILE* file_ = nullptr;
};
}  // namespace

StripCommand::StripCommand(CLI::App& app) {
  command_ = app.add_subcommand(
      "strip",
      "A plane-strain strip of the box drape (the kernel's bands, one grid line, exact Newton "
      "solves): the step solver's outer iteration in seconds; PASSED when every step converged");
  auto& s = settings_;
  command_->add_option("--particles", s.particles, "Particles along the 1 m strip")
      ->capture_default_str()->check(CLI::Range(3, 1 << 20));
  command_->add_option("--steps", s.steps, "Time steps")
      ->capture_default_str()->check(CLI::Range(1, 1 << 20));
  command_->add_option("--step", s.step_s, "Time step, s")
      ->capture_default_str()->check(CLI::Range(1e-6, 0.1));
  command_->add_option("--damping", s.damping, "Velocity lost per 4 ms, applied as a rate")
      ->capture_default_str()->check(CLI::Range(0.0, 0.99));
  command_->add_option("--tolerance", s.tolerance,
                       "Stop test: RMS of |residual| / (m |g|) over the particles")
      ->capture_default_str()->check(CLI::Range(1e-12, 1e3));
  command_->add_option("--max-iterations", s.max_iterations,
                       "Newton iterations a step before it counts as failed")
      ->capture_default_str()->check(CLI::Range(1, 1 << 20));
  command_->add_option("--smoothing-sweeps", s.smoothing_sweeps,
                       "Nonlinear smoothing sweeps after each line search")
      ->capture_default_str()->check(CLI::Range(0, 1000));
  command_->add_option("--hat-levels", s.hat_levels,
                       "Coarse levels of hat-function moves before the fine smoothing (0 = none)")
      ->capture_default_str()->check(CLI::Range(0, 30));
  command_->add_option("--hat-sweeps", s.hat_sweeps, "Passes over the coarse levels")
      ->capture_default_str()->check(CLI::Range(1, 100));
  command_->add_option("--coarse-newton", s.coarse_newton,
                       "Newton iterations on the coarse subspace after each fine one (0 = none)")
      ->capture_default_str()->check(CLI::Range(0, 100));
  command_->add_option("--coarse-factor", s.coarse_factor,
                       "Coarse spacing in particles (divides --particles - 1)")
      ->capture_default_str()->check(CLI::Range(2, 1 << 20));
  command_->add_option("--inner-stiffness", s.inner_stiffness,
                       "Tilt the tension plateau: the force inside the band moves with slope "
                       "this x Fm/EMT from the last step's strain (0 = MODEL.md 4B's rule)")
      ->capture_default_str()->check(CLI::Range(0.0, 1.0));
  command_->add_option("--model-refinements", s.model_refinements,
                       "Models assembled again along their own direction")
      ->capture_default_str()->check(CLI::Range(0, 100));
  command_->add_flag("--no-reach", no_reach_,
                     "The model takes each element's tangent only (no secant along the last "
                     "direction, no memory, no bending M / kappa, no refinement)");
  command_->add_option("--memory", s.memory, "Share of an element's previous model stiffness kept")
      ->capture_default_str()->check(CLI::Range(0.0, 1.0));
  command_->add_option("--path-mu0", s.path_mu0,
                       "Path-following on the band: the first smoothing width (0 = off)")
      ->capture_default_str()->check(CLI::Range(0.0, 1e3));
  command_->add_option("--path-shrink", s.path_shrink, "Factor on mu from one stage to the next")
      ->capture_default_str()->check(CLI::Range(1e-6, 0.999));
  command_->add_option("--path-sigma", s.path_sigma,
                       "A stage ends when its smoothed residual is this share of its first")
      ->capture_default_str()->check(CLI::Range(1e-9, 0.999));
  command_->add_option("--path-mu-min", s.path_mu_min, "mu below this becomes 0 (the exact law)")
      ->capture_default_str()->check(CLI::Range(0.0, 1e3));
  command_->add_option("--fabric", fabric_, "Fabric preset (its warp direction is used)")
      ->capture_default_str();
  command_->add_option("--rt-percent", rt_percent_,
                       "Override the warp's RT (100 = no tension hysteresis)")
      ->check(CLI::Range(1.0, 100.0));
  command_->add_option("--bending-2hb", bending_2hb_,
                       "Override the warp's 2HB, gf cm/cm (0 = no bending hysteresis)")
      ->check(CLI::Range(0.0, 10.0));
  command_->add_option("--trace", trace_file_,
                       "Write one CSV row per Newton iteration (residual, step kept, edges "
                       "changing branch)");
  command_->add_option("--json", json_file_,
                       "Write the settings, per-step counts, final positions and machine context");
}

int StripCommand::run() {
  kernels::StripSettings settings = settings_;
  settings.reach = !no_reach_;
  try {
    settings.fabric = load_fabric_preset(default_presets_file(), fabric_);
  } catch (const std::exception& error) {
    return bad(fmt::format("--fabric: {}", error.what()));
  }
  if (settings.coarse_newton > 0 &&
      (settings.coarse_factor >= settings.particles - 1 ||
       (settings.particles - 1) % settings.coarse_factor != 0)) {
    return bad(fmt::format("--coarse-factor: {} does not divide --particles - 1 = {} into at "
                           "least 2 coarse edges",
                           settings.coarse_factor, settings.particles - 1));
  }
  if (settings.inner_stiffness > 0.0 && settings.path_mu0 > 0.0) {
    return bad("--inner-stiffness: not with --path-mu0 (path-following smooths the flat plateau)");
  }
  if (rt_percent_) settings.fabric.warp.rt_percent = *rt_percent_;
  if (bending_2hb_) settings.fabric.warp.bending_2hb = *bending_2hb_;

  std::printf(
      "clothbench strip: %d particles, %d steps of %g ms, %s (warp: RT %g %%, 2HB %g), "
      "tolerance %g, smoothing %d, refinements %d, reach %s, path-following %s, hat levels %d "
      "x %d, coarse Newton %d (coarse spacing %d), tension plateau %s\n",
      settings.particles, settings.steps, settings.step_s * 1e3, fabric_.c_str(),
      settings.fabric.warp.rt_percent, settings.fabric.warp.bending_2hb, settings.tolerance,
      settings.smoothing_sweeps, settings.reach ? settings.model_refinements : 0,
      settings.reach ? fmt::format("on (memory {})", settings.memory).c_str() : "off",
      settings.path_mu0 > 0.0
          ? fmt::format("mu0 {} x{} a stage at {} of its first, 0 below {}", settings.path_mu0,
                        settings.path_shrink, settings.path_sigma, settings.path_mu_min)
                .c_str()
          : "off",
      settings.hat_levels, settings.hat_sweeps, settings.coarse_newton, settings.coarse_factor,
      settings.inner_stiffness > 0.0
          ? fmt::format("tilted, slope {} Fm/EMT (not MODEL.md 4B's rule)", settings.inner_stiffness)
                .c_str()
          : "flat (MODEL.md 4B)");
  std::fflush(stdout);

  MemoryStream trace;
  if (!trace_file_.empty() && trace.file() == nullptr) return bad("--trace: no memory for it");
  kernels::StripResult result;
  const auto start = std::chrono::steady_clock::now();
  try {
    result = kernels::run_strip(settings, trace_file_.empty() ? nullptr : trace.file());
  } catch (const std::exception& error) {
    std::fprintf(stderr, "clothbench strip: %s\nFAILED\n", error.what());
    return kExitFailed;
  }
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  std::vector<int> counts;
  for (const auto& step : result.steps) counts.push_back(step.newton);
  std::sort(counts.begin(), counts.end());
  const int median = counts.empty() ? 0 : counts[counts.size() / 2];
  const int most = counts.empty() ? 0 : counts.back();
  bool finite = true;
  for (const auto& p : result.positions) finite = finite && std::isfinite(p.x()) && std::isfinite(p.y());
  int failed_steps = 0;
  for (const auto& step : result.steps) failed_steps += step.converged ? 0 : 1;
  const bool inside = result.deepest_penetration > 0.002;  // deeper than the contact layer
  const bool passed = result.all_converged && finite && !inside;

  std::printf("Newton iterations %ld (a step: median %d, max %d), line-search evaluations %ld, "
              "wall %.2f s on one thread\n",
              result.newton, median, most, result.evaluations, wall);
  if (settings.hat_levels > 0) {
    std::printf("hat moves that lowered the energy %ld\n", result.hat_moves);
  }
  if (settings.coarse_newton > 0) {
    std::printf("coarse-subspace Newton iterations %ld (each one more model, factorisation and "
                "line search)\n",
                result.coarse);
  }
  std::printf("lowest particle at z = %.4f m; deepest inside the box %.3g m; %d of %d steps "
              "not converged\n",
              result.lowest_z, result.deepest_penetration, failed_steps, settings.steps);

  try {
    if (!trace_file_.empty()) write_file_atomically(trace_file_, trace.text());
    if (!json_file_.empty()) {
      nlohmann::json steps = nlohmann::json::array();
      for (const auto& step : result.steps) {
        steps.push_back({{"newton", step.newton},
                         {"evaluations", step.evaluations},
                         {"coarse", step.coarse},
                         {"hat_moves", step.hat_moves},
                         {"residual", step.residual},
                         {"converged", step.converged}});
      }
      nlohmann::json positions = nlohmann::json::array();
      for (const auto& p : result.positions) positions.push_back({p.x(), p.y()});
      const nlohmann::json document = {
          {"settings",
           {{"particles", settings.particles}, {"steps", settings.steps},
            {"step_s", settings.step_s}, {"damping", settings.damping},
            {"tolerance", settings.tolerance}, {"max_iterations", settings.max_iterations},
            {"smoothing_sweeps", settings.smoothing_sweeps},
            {"model_refinements", settings.model_refinements}, {"reach", settings.reach},
            {"memory", settings.memory}, {"path_mu0", settings.path_mu0},
            {"path_shrink", settings.path_shrink}, {"path_sigma", settings.path_sigma},
            {"path_mu_min", settings.path_mu_min}, {"hat_levels", settings.hat_levels},
            {"hat_sweeps", settings.hat_sweeps}, {"coarse_newton", settings.coarse_newton},
            {"coarse_factor", settings.coarse_factor},
            {"inner_stiffness", settings.inner_stiffness}, {"fabric", fabric_},
            {"warp_rt_percent", settings.fabric.warp.rt_percent},
            {"warp_bending_2hb", settings.fabric.warp.bending_2hb}}},
          {"newton", result.newton},
          {"evaluations", result.evaluations},
          {"coarse", result.coarse},
          {"hat_moves", result.hat_moves},
          {"newton_median", median},
          {"newton_max", most},
          {"wall_seconds", wall},
          {"passed", passed},
          {"lowest_z_m", result.lowest_z},
          {"deepest_penetration_m", result.deepest_penetration},
          {"steps", steps},
          {"positions_m", positions},
          {"machine", machine_context()}};
      write_file_atomically(json_file_, document.dump(1) + "\n");
    }
  } catch (const std::exception& error) {
    std::fprintf(stderr, "clothbench strip: %s\n", error.what());
    return kExitBadInput;
  }
  std::printf("%s\n", passed ? "PASSED" : "FAILED");
  return passed ? 0 : kExitFailed;
}

}  // namespace clothbench::harness
