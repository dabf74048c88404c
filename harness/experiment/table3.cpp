// `clothbench experiment table3`: the sphere and three-spheres drapes with AMRC, active
// particles after every AMRC event (paper Table 3), beside the paper's start and end counts.
#include <fmt/core.h>

#include <string>
#include <vector>

#include "harness/experiment/experiment.hpp"

namespace clothbench::harness {

namespace {

/// The paper's Table 3: 1,000,000 particles at the start, active particles after 100 steps.
struct PaperScene {
  const char* name;  ///< scene stem without the size
  double start;
  double end;
};
constexpr PaperScene kPaper[] = {{"sphere", 1e6, 30592}, {"three-spheres", 1e6, 32832}};

/// Scene file size, particles per side and steps for a size (the paper: 1001, 100 steps).
struct Table3Size {
  int file_size;
  int particles;
  int steps;
};
Table3Size table3_size(ExperimentSize size) {
  switch (size) {
    case ExperimentSize::paper: return {1001, 1001, 100};
    case ExperimentSize::small: return {257, 257, 100};
    case ExperimentSize::tiny: return {257, 65, 24};
  }
  return {1001, 1001, 100};
}

}  // namespace

int run_table3(const ExperimentContext& context) {
  const Table3Size size = table3_size(context.options.size);
  nlohmann::json scenes = nlohmann::json::array();
  std::string md = fmt::format(
      "# clothbench experiment table3 ({} size)\n\nActive particles after every AMRC event; "
      "scheduler {}, {} thread(s). Paper: 1001 x 1001 particles, 100 steps.\n\n",
      to_string(context.options.size), context.driver.name(), context.threads);
  bool passed = true;
  for (const PaperScene& paper : kPaper) {
    Scene scene = load_experiment_scene(scenario_directory() / "paper" /
                                        fmt::format("{}-{}.toml", paper.name, size.file_size));
    resize_cloth(scene, size.particles);
    scene.steps = context.options.steps.value_or(size.steps);
    const VariantRun run = run_variant(scene, paper.name, "AMRC", context.driver, context.threads,
                                       context.options.quiet);
    passed = passed && run.passed;
    nlohmann::json events = nlohmann::json::array();
    std::string counts = fmt::format("{}", run.particles_start);
    for (const kernels::AmrcEvent& e : run.summary.amrc_events) {
      events.push_back({{"step", e.step}, {"particles", e.particles}, {"ghosts", e.ghosts},
                        {"refined", e.refined}, {"coarsened", e.coarsened}});
      counts += fmt::format(" -> {}", e.particles);
    }
    const double ratio = static_cast<double>(run.particles_end) / static_cast<double>(run.particles_start);
    nlohmann::json j = variant_json(run);
    j["events"] = events;
    j["end_over_start"] = ratio;
    j["paper"] = {{"particles_start", paper.start}, {"particles_end", paper.end},
                  {"end_over_start", paper.end / paper.start}};
    scenes.push_back(j);
    md += fmt::format(
        "## {}\n\n{} x {} particles, {} steps, {:.3f} s, {}.\n\n| | Start | End | End / start |\n"
        "|---|--:|--:|--:|\n| clothbench | {} | {} | {:.4f} |\n| paper | {:.0f} | {:.0f} | {:.4f} |\n\n"
        "After every AMRC event: {}\n\n",
        paper.name, size.particles, size.particles, run.summary.steps.size(), run.seconds,
        run.passed ? "PASSED" : "FAILED", run.particles_start, run.particles_end, ratio,
        paper.start, paper.end, paper.end / paper.start, counts);
    write_experiment_outputs(context, "table3", {{"complete", false}, {"scenes", scenes}}, md);
  }
  write_experiment_outputs(context, "table3", {{"complete", true}, {"scenes", scenes}}, md);
  fmt::print("\n{}wrote {}\nVerification: {}\n", md, (context.dir / "table3.md").string(),
             passed ? "PASSED" : "FAILED");
  return passed ? 0 : 1;
}

}  // namespace clothbench::harness
