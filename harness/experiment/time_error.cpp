// `clothbench experiment time-error`: how much accuracy each second buys. A reference run (the
// base scene's finest mesh, 100x tighter CG tolerance, 10x the iteration cap, analytic
// gradient) and a grid of cheaper settings — coarser meshes, AMRC with three threshold pairs,
// looser and tighter tolerances, iteration caps, the solver (Newton + V-cycle, the paper's
// nonlinear CG with block Jacobi, CG with line solves), 2 and 4 times the time step, the
// numeric gradient, a wall-clock budget for the minimisation (the paper's time-budget mode).
// Each is timed and its final surface compared with the reference's at the same material
// points; the Pareto front of (time, RMS error) is marked in the table and the PNG.
#include <fmt/core.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "harness/experiment/experiment.hpp"
#include "harness/output/atomic_file.hpp"
#include "harness/report/sweep_plots.hpp"

namespace clothbench::harness {

namespace {

/// One point of the study.
struct Setting {
  std::string label;
  std::string description;
  std::function<void(Scene&)> apply;
};

struct Point {
  VariantRun run;
  SurfaceError error;
  double contact_error = 0.0;  ///< |F - F_ref| / |F_ref| of the total contact force
};

std::pair<int, int> base_size(ExperimentSize size) {
  switch (size) {
    case ExperimentSize::paper: return {77, 200};
    case ExperimentSize::small: return {41, 100};
    case ExperimentSize::tiny: return {21, 40};
  }
  return {77, 200};
}

/// The cheaper settings for a base of `particles` per side (`base_seconds` feeds the budget).
std::vector<Setting> settings(int particles, int steps, const double& base_seconds) {
  std::vector<Setting> list;
  list.push_back({"base", "the scene as written", [](Scene&) {}});
  for (int divisor : {2, 4}) {
    if ((particles - 1) % divisor != 0 || (particles - 1) / divisor < 2) continue;
    const int n = (particles - 1) / divisor + 1;
    list.push_back({fmt::format("mesh-{}", n), fmt::format("uniform {} x {} mesh", n, n),
                    [n](Scene& s) { resize_cloth(s, n); }});
  }
  // AMRC one level below the base on small meshes (a 21 x 21 base would otherwise coarsen to
  // 6 x 6, which cannot resolve the obstacle), two levels from 41 x 41 up.
  const int levels = particles >= 41 ? 2 : 1;
  if ((particles - 1) % (1 << levels) == 0) {
    const std::pair<double, double> thresholds[] = {{0.2, 0.05}, {0.4, 0.1}, {0.1, 0.025}};
    const char* names[] = {"amrc", "amrc-aggressive", "amrc-gentle"};
    for (int k = 0; k < 3; ++k) {
      const double refine = thresholds[k].first, coarsen = thresholds[k].second;
      list.push_back({names[k],
                      fmt::format("AMRC L = {}, refine above {} rad, merge below {} rad", levels,
                                  refine, coarsen),
                      [refine, coarsen, levels](Scene& s) {
                        s.simulation.amrc.enabled = true;
                        s.simulation.amrc.levels = levels;
                        s.simulation.amrc.check_every = 3;
                        s.simulation.amrc.refine_threshold = refine;
                        s.simulation.amrc.coarsen_threshold = coarsen;
                      }});
    }
  }
  for (double factor : {10.0, 0.1}) {
    list.push_back({fmt::format("tol-x{}", factor), fmt::format("solver tolerance x {}", factor),
                    [factor](Scene& s) { s.simulation.solver.tolerance *= factor; }});
  }
  // Caps on the iterations per step of the scene's method (Newton's, or nonlinear CG's).
  const auto cap = [](Scene& s, int newton, int cg) {
    kernels::SolverConfig& solver = s.simulation.solver;
    if (kernels::resolved_method(solver) == kernels::StepMethod::newton) {
      solver.max_newton_iterations = newton;
    } else {
      solver.max_iterations = cg;
    }
  };
  for (const std::pair<int, int>& caps : {std::pair{3, 10}, std::pair{10, 30}}) {
    const int newton = caps.first, cg = caps.second;  // named copies: lambdas capture them
    list.push_back({fmt::format("cap-{}", newton),
                    fmt::format("at most {} Newton ({} nonlinear CG) iterations per step", newton,
                                cg),
                    [cap, newton, cg](Scene& s) { cap(s, newton, cg); }});
  }
  // Longer time steps over the same simulated time: 2 and 4 times the scene's step, a half
  // and a quarter of its steps. Damping is a rate (MODEL.md 5): a step of f times the length
  // keeps (1 - c)^f of the velocity, so the scene's per-step damping c is converted.
  for (int factor : {2, 4}) {
    if (steps % factor != 0 || steps / factor < 1) continue;
    list.push_back(
        {fmt::format("dt-x{}", factor),
         fmt::format("time step x {}, 1/{} of the steps (same simulated time)", factor, factor),
         [factor](Scene& s) {
           kernels::TimeConfig& time = s.simulation.time;
           time.step *= factor;
           time.damping = 1.0 - std::pow(1.0 - time.damping, factor);
           s.steps /= factor;
         }});
  }
  // The scene's tolerance with a cap ten times the scene's: steps that the solver cannot finish
  // within the scene's cap are otherwise rejected and redone as two halves, which changes the
  // trajectory (kernels/MODEL-NOTES.md, "The experiments at the small size").
  list.push_back({"cap-x10", "iteration cap x 10 (as the reference's), scene tolerance",
                  [](Scene& s) {
                    s.simulation.solver.max_iterations *= 10;
                    s.simulation.solver.max_newton_iterations *= 10;
                  }});
  // The paper's solver (nonlinear CG with block Jacobi), and nonlinear CG with the line solves:
  // fewer CG iterations a step than block Jacobi (kernels/MODEL-NOTES.md, "Line solves").
  list.push_back({"paper-cg", "nonlinear CG with block Jacobi (the paper's), scene tolerance",
                  [](Scene& s) {
                    s.simulation.solver.method = kernels::StepMethod::nonlinear_cg;
                    s.simulation.solver.preconditioner = kernels::Preconditioner::block_jacobi;
                  }});
  list.push_back({"cg-line-solves", "nonlinear CG with the line solves, scene tolerance",
                  [](Scene& s) {
                    s.simulation.solver.method = kernels::StepMethod::nonlinear_cg;
                    s.simulation.solver.preconditioner = kernels::Preconditioner::line_solves;
                  }});
  list.push_back({"numeric-gradient", "numeric (local finite-difference) gradient", [](Scene& s) {
                    s.simulation.solver.gradient = kernels::GradientMode::numeric;
                  }});
  list.push_back({"time-budget-50%", "minimisation stops at half the base run's time", [&base_seconds](Scene& s) {
                    s.simulation.solver.time_budget = 0.5 * base_seconds;
                  }});
  return list;
}

std::string markdown(const std::vector<Point>& points, const std::vector<std::size_t>& front,
                     const ExperimentContext& context, const Scene& base) {
  std::string md = fmt::format(
      "# clothbench experiment time-error ({} size)\n\nBase scene `{}` at {} x {} particles, {} "
      "steps; scheduler {}, {} thread(s). Error: distance between the same material points of "
      "the final surface and the reference's; contact error: |F - F_ref| / |F_ref| of the total "
      "contact force; penetration: deepest point of the interpolated surface inside an obstacle. "
      "Pareto: no other setting is both faster and more accurate.\n\n",
      to_string(context.options.size), base.file.string(), base.simulation.cloth.particles_i,
      base.simulation.cloth.particles_j, base.steps, context.driver.name(), context.threads);
  md += "| Setting | What | Time [s] | Error RMS [mm] | Error max [mm] | Contact error | "
        "Penetration [mm] | Solver iterations | Rejected steps | Pareto | Verification |\n"
        "|---|---|--:|--:|--:|--:|--:|--:|--:|:-:|:--|\n";
  for (std::size_t k = 0; k < points.size(); ++k) {
    const Point& p = points[k];
    const bool on_front = std::find(front.begin(), front.end(), k) != front.end();
    md += fmt::format("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n", p.run.label,
                      p.run.setting, cell(p.run.seconds), cell(1e3 * p.error.rms, 3),
                      cell(1e3 * p.error.max, 3), cell(p.contact_error, 3),
                      cell(1e3 * p.run.summary.final_state.max_surface_penetration, 3),
                      solver_iterations(p.run.summary), p.run.summary.rejected_steps,
                      on_front ? "*" : "",
                      p.run.passed ? "PASSED" : "FAILED");
  }
  return md;
}

void plot(const std::vector<Point>& points, const std::vector<std::size_t>& front,
          const ExperimentContext& context) {
  std::ostringstream data;
  data << "# label time_s error_rms_mm pareto\n";
  for (std::size_t k = 1; k < points.size(); ++k) {  // the reference has no error to show
    const Point& p = points[k];
    if (!p.run.passed || !(p.error.rms > 0.0)) continue;
    const bool on_front = std::find(front.begin(), front.end(), k) != front.end();
    data << fmt::format("{} {:.6g} {:.6g} {}\n", p.run.label, p.run.seconds, 1e3 * p.error.rms,
                        on_front ? 1 : 0);
  }
  data << "\n\n# pareto front\n";
  for (std::size_t k : front) {
    data << fmt::format("{:.6g} {:.6g}\n", points[k].run.seconds, 1e3 * points[k].error.rms);
  }
  write_file_atomically(context.dir / "time_error.dat", data.str());
  std::ostringstream gp;
  gp << png_terminal(1100, 750) << "set output 'time_error.png'\n"
     << fmt::format("set title {}\n",
                    gnuplot_quote(fmt::format("Run time against error ({} size, reference {:.3g} s)",
                                              to_string(context.options.size),
                                              points.front().run.seconds)))
     << "set logscale xy\nset format x '%g'\nset format y '%g'\nset xlabel 'run time [s]'\nset ylabel 'RMS surface error [mm]'\n"
     << "set grid\nset key top right\nset offsets graph 0.05, graph 0.2, graph 0.1, graph 0.1\n"
     << "plot 'time_error.dat' index 1 using 1:2 with steps lw 2 lc rgb '#d95f02' title 'Pareto front', \\\n"
     << "     '' index 0 using 2:($4 > 0 ? $3 : 1/0) with points pt 7 ps 1.5 lc rgb '#1b9e77' title 'on the front', \\\n"
     << "     '' index 0 using 2:($4 > 0 ? 1/0 : $3) with points pt 7 ps 1.5 lc rgb '#7570b3' title 'dominated', \\\n"
     << "     '' index 0 using 2:3:1 with labels offset char 0.8, char 0.8 left font ',9' notitle\n";
  PlotOutcome outcome;
  run_gnuplot(context.dir, "time_error", gp.str(), outcome);
  for (const std::string& problem : outcome.problems) fmt::print("  plot: {}\n", problem);
}

}  // namespace

int run_time_error(const ExperimentContext& context) {
  const auto [particles, steps] = base_size(context.options.size);
  const bool scene_given = context.options.scene.has_value();
  Scene base = load_experiment_scene(
      scene_given ? *context.options.scene : scenario_directory() / "paper" / "table1-77-finer.toml");
  if (!scene_given) resize_cloth(base, particles);
  base.simulation.amrc.enabled = false;
  base.steps = context.options.steps.value_or(scene_given ? base.steps : steps);
  const int n = base.simulation.cloth.particles_i;

  Scene reference = base;
  reference.simulation.solver.tolerance *= 1e-2;
  reference.simulation.solver.max_iterations *= 10;
  reference.simulation.solver.gradient = kernels::GradientMode::analytic;

  std::vector<Point> points;
  std::vector<std::size_t> front;
  auto save = [&](bool complete) {
    nlohmann::json runs = nlohmann::json::array();
    for (std::size_t k = 0; k < points.size(); ++k) {
      nlohmann::json j = variant_json(points[k].run);
      j["error_rms_m"] = points[k].error.rms;
      j["error_max_m"] = points[k].error.max;
      j["contact_force_error"] = std::isfinite(points[k].contact_error)
                                     ? nlohmann::json(points[k].contact_error) : nlohmann::json(nullptr);
      j["pareto"] = std::find(front.begin(), front.end(), k) != front.end();
      runs.push_back(j);
    }
    write_experiment_outputs(context, "time_error",
                             {{"complete", complete}, {"base_scene", base.file.string()},
                              {"base_particles", n}, {"steps", base.steps},
                              {"only", context.options.only}, {"runs", runs}},
                             markdown(points, front, context, base));
  };

  // --only: every label must be one of this base's settings (checked before the first run).
  double no_seconds = 0.0;
  std::vector<std::string> known;
  for (const Setting& setting : settings(n, base.steps, no_seconds)) known.push_back(setting.label);
  for (const std::string& label : context.options.only) {
    if (std::find(known.begin(), known.end(), label) == known.end()) {
      throw std::invalid_argument(fmt::format("--only: no setting '{}' for this base (settings: {})",
                                              label, fmt::join(known, ", ")));
    }
  }
  auto chosen = [&](const Setting& setting) {
    return setting.label == "base" || context.options.only.empty() ||
           std::find(context.options.only.begin(), context.options.only.end(), setting.label) !=
               context.options.only.end();
  };

  const VariantRun ref = run_variant(reference, "reference",
                                     "tolerance x 0.01, iteration cap x 10, analytic gradient",
                                     context.driver, context.threads, context.options.quiet);
  points.push_back({ref, {}, 0.0});
  save(false);
  const double ref_force = ref.contact_force.norm();
  double base_seconds = 0.0;
  for (const Setting& setting : settings(n, base.steps, base_seconds)) {
    if (!chosen(setting)) continue;
    Scene scene = base;
    setting.apply(scene);
    Point p{run_variant(scene, setting.label, setting.description, context.driver,
                        context.threads, context.options.quiet), {}, 0.0};
    if (setting.label == "base") base_seconds = p.run.seconds;
    p.error = surface_error(p.run.surface, ref.surface);
    p.contact_error = ref_force > 0.0 ? (p.run.contact_force - ref.contact_force).norm() / ref_force
                                      : NAN;
    points.push_back(std::move(p));
    save(false);
  }
  // The front over the cheaper settings that passed (the reference is the yardstick).
  std::vector<double> time, error;
  for (std::size_t k = 0; k < points.size(); ++k) {
    const bool usable = k > 0 && points[k].run.passed;
    time.push_back(usable ? points[k].run.seconds : NAN);
    error.push_back(usable ? points[k].error.rms : NAN);
  }
  front = pareto_front(time, error);
  save(true);
  if (context.options.plots && gnuplot_available()) plot(points, front, context);

  const std::string md = markdown(points, front, context, base);
  bool passed = true;
  for (const Point& p : points) passed = passed && p.run.passed;
  fmt::print("\n{}\nwrote {}\nVerification: {}\n", md, (context.dir / "time_error.md").string(),
             passed ? "PASSED" : "FAILED");
  return passed ? 0 : 1;
}

}  // namespace clothbench::harness
