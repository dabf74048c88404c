// gnuplot figures of a sweep (see sweep_plots.hpp).
#include "harness/report/sweep_plots.hpp"
#include "harness/report/sweep_table.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <sstream>

#include "harness/output/atomic_file.hpp"
#include "harness/sweep/sweep_document.hpp"

namespace clothbench::harness {

using nlohmann::json;

namespace {

/// `text` as a single-quoted shell word.
std::string shell_quote(const std::string& text) {
  std::string out = "'";
  for (char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

}  // namespace

/// `text` as a gnuplot double-quoted string.
std::string gnuplot_quote(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

// Writes `script` as dir/name.gp and runs gnuplot on it in `dir`; records the PNG or a problem.
void run_gnuplot(const std::filesystem::path& dir, const std::string& name,
                 const std::string& script, PlotOutcome& outcome) {
  write_file_atomically(dir / (name + ".gp"), script);
  const std::string command = fmt::format("cd {} && gnuplot {}.gp > {}.log 2>&1",
                                          shell_quote(dir.string()), name, name);
  const int status = std::system(command.c_str());  // NOLINT(cert-env33-c): fixed command
  if (status != 0) {
    outcome.problems.push_back(
        fmt::format("gnuplot failed on {} (see {})", (dir / (name + ".gp")).string(),
                    (dir / (name + ".log")).string()));
  } else {
    std::filesystem::remove(dir / (name + ".log"));
    outcome.images.push_back(dir / (name + ".png"));
  }
}

std::string png_terminal(int width, int height) {
  return fmt::format(
      "set terminal pngcairo size {},{} enhanced font 'DejaVu Sans,11' noenhanced\n", width,
      height);
}

namespace {

/// Rows per scheduler in document order, threads ascending.
std::vector<std::pair<std::string, std::vector<const json*>>> by_scheduler(const json& doc) {
  std::vector<std::pair<std::string, std::vector<const json*>>> groups;
  for (const json& row : doc["rows"]) {
    const std::string name = row["scheduler_canonical"];
    auto it = std::find_if(groups.begin(), groups.end(),
                           [&](const auto& g) { return g.first == name; });
    if (it == groups.end()) {
      groups.emplace_back(name, std::vector<const json*>{});
      it = groups.end() - 1;
    }
    it->second.push_back(&row);
  }
  for (auto& g : groups) {
    std::stable_sort(g.second.begin(), g.second.end(), [](const json* a, const json* b) {
      return (*a)["threads"].get<int>() < (*b)["threads"].get<int>();
    });
  }
  return groups;
}

std::string number_or_missing(const json& value) {
  return value.is_number() ? fmt::format("{:.9g}", value.get<double>()) : "?";
}

double accounting_value(const json& row, const char* key) {
  const json& a = row["accounting"];
  return a.is_object() ? std::max(0.0, a[key].get<double>()) : 0.0;
}

}  // namespace

bool gnuplot_available() {
  return std::system("gnuplot --version > /dev/null 2>&1") == 0;  // NOLINT(cert-env33-c)
}

PlotOutcome plot_sweep(const json& document, const std::filesystem::path& dir) {
  PlotOutcome outcome;
  const auto groups = by_scheduler(document);
  if (groups.empty()) return outcome;
  int max_threads = 1;
  std::ostringstream data;
  std::ostringstream disturbed_labels;  // gnuplot labels on the time plot's disturbed points
  int label_number = 10;
  for (const auto& [name, rows] : groups) {
    data << "# " << name << "\n# threads time_median time_min time_max speedup\n";
    for (const json* r : rows) {
      const json& row = *r;
      max_threads = std::max(max_threads, row["threads"].get<int>());
      const bool ok = row["verification"]["passed"].get<bool>();
      if (ok && row_disturbed(row)) {
        disturbed_labels << fmt::format(
            "set label {} 'DISTURBED' at {}, {:.9g} rotate by 90 left offset 0,1 font ',8' "
            "tc 'red'\n",
            label_number++, row["threads"].get<int>(), row["time_seconds"]["median"].get<double>());
      }
      data << fmt::format("{} {} {} {} {}\n", row["threads"].get<int>(),
                          number_or_missing(ok ? row["time_seconds"]["median"] : json()),
                          number_or_missing(row["time_seconds"]["min"]),
                          number_or_missing(row["time_seconds"]["max"]),
                          number_or_missing(row["derived"]["speedup"]));
    }
    data << "\n\n";
  }
  write_file_atomically(dir / "fig12.dat", data.str());

  const int pus = document["machine"].contains("cpu") ? document["machine"]["cpu"].value("pus", 0) : 0;
  const json& s = document["settings"];
  std::ostringstream gp;
  gp << png_terminal(1400, 580) << "set output 'fig12.png'\nset datafile missing '?'\n";
  gp << fmt::format("set multiplot layout 1,2 title {}\n",
                    gnuplot_quote(fmt::format("{} - {} steps, median of {} runs (bars: min-max)",
                                              document["scene"]["name"].get<std::string>(),
                                              s["steps"].get<int>(), s["repeat"].get<int>())));
  gp << fmt::format("set grid\nset xlabel 'threads'\nset logscale x 2\nset xrange [0.8:{}]\n",
                    max_threads * 1.25);
  gp << "set xtics (";
  for (int t = 1, first = 1; t <= max_threads; t *= 2, first = 0) gp << (first ? "" : ", ") << t;
  gp << ")\nset key top right\n";
  if (pus > 0 && max_threads > pus) {
    gp << fmt::format("set arrow 1 from {0}, graph 0 to {0}, graph 1 nohead dt 3 lc 'gray40'\n"
                      "set label 1 'hardware threads' at {0}, graph 0.95 right offset -0.5,0\n",
                      pus);
  }
  gp << disturbed_labels.str();
  gp << "set title 'Time vs threads (DISTURBED: other work took the cores; no speed-up shown)'\n"
        "set ylabel 'time [s]'\nset yrange [0:*]\nplot ";
  for (std::size_t i = 0; i < groups.size(); ++i) {
    gp << fmt::format(
        "{}'fig12.dat' index {} using 1:2:3:4 with yerrorlines lt {} lw 2 pt {} title {}",
        i ? ", \\\n     " : "", i, i + 1, 5 + 2 * static_cast<int>(i % 4),
        gnuplot_quote(groups[i].first));
  }
  for (int k = 10; k < label_number; ++k) gp << fmt::format("\nunset label {}", k);
  gp << "\nset title 'Speed-up vs threads (against each scheduler''s 1-thread time)'\n"
        "set ylabel 'speed-up'\nset key top left\n";
  gp << fmt::format("set yrange [0:{}]\n", max_threads * 1.15);
  gp << "plot x with lines dt 2 lc 'black' title 'ideal'";
  for (std::size_t i = 0; i < groups.size(); ++i) {
    gp << fmt::format(
        ", \\\n     'fig12.dat' index {} using 1:5 with linespoints lt {} lw 2 pt {} title {}", i,
        i + 1, 5 + 2 * static_cast<int>(i % 4), gnuplot_quote(groups[i].first));
  }
  gp << "\nunset multiplot\n";
  run_gnuplot(dir, "fig12", gp.str(), outcome);

  // Overhead breakdown: one stacked bar per (scheduler, threads), a gap between schedulers.
  const bool instrumented = std::any_of(document["rows"].begin(), document["rows"].end(),
                                        [](const json& r) { return r["accounting"].is_object(); });
  if (!instrumented) return outcome;
  // Each bar is the instrumented run the row's overheads come from (sweep_document.hpp,
  // AccountingIdentity): its parts stack up to that run's wall; the dot is the row's Time
  // (median of the uninstrumented runs), so a bar above its dot is a run that took longer.
  std::ostringstream bars;
  bars << "# label sequential parallel_overhead imbalance parallel_work residual "
          "time_median run_wall\n";
  bars << "# bars: the median instrumented run of the row (the run its overheads come from); "
          "time_median: the row's Time (uninstrumented); a label starting with a dagger: its "
          "overheads exceed that Time (table.md says why)\n";
  for (std::size_t g = 0; g < groups.size(); ++g) {
    if (g > 0) bars << "\"\" 0 0 0 0 0 ? ?\n";
    for (const json* r : groups[g].second) {
      const std::optional<AccountingIdentity> id = accounting_identity(*r);
      bars << fmt::format("\"{}{} {}t{}\" {:.9g} {:.9g} {:.9g} {:.9g} {:.9g} {:.9g} {:.9g}\n",
                          id && id->overheads_exceed_time ? "\u2020 " : "", groups[g].first,
                          (*r)["threads"].get<int>(), row_disturbed(*r) ? " DISTURBED" : "",
                          accounting_value(*r, "sequential_overhead_seconds"),
                          accounting_value(*r, "parallel_overhead_seconds"),
                          accounting_value(*r, "load_imbalance_seconds"),
                          accounting_value(*r, "parallel_work_seconds"),
                          id ? std::max(0.0, id->residual_seconds) : 0.0,
                          (*r)["time_seconds"]["median"].get<double>(),
                          id ? id->wall_seconds : 0.0);
    }
  }
  write_file_atomically(dir / "overhead.dat", bars.str());
  std::ostringstream og;
  og << png_terminal(1500, 650) << "set output 'overhead.png'\n"
     << "set datafile missing '?'\n"
     << "set multiplot layout 1,2 title 'Where the time goes: the median instrumented run of "
        "each row (its overheads, summed over loops); dot: the row''s Time (uninstrumented "
        "median)'\n"
     << "set style data histograms\nset style histogram rowstacked\n"
     << "set style fill solid 0.85 border -1\nset boxwidth 0.75\nset grid ytics\n"
     << "set xtics rotate by -50 scale 0 font ',9'\nset yrange [0:*]\nset rmargin 7\n"
     << "set bmargin 9\nset key outside top center horizontal\n"
     << "set title 'That run''s wall = work + overheads + residual'\nset ylabel 'seconds'\n"
     << "plot 'overhead.dat' using 5:xtic(1) title 'parallel work' lc rgb '#9ecae1', \\\n"
     << "     '' using 2 title 'sequential overhead' lc rgb '#e6550d', \\\n"
     << "     '' using 3 title 'parallel overhead' lc rgb '#31a354', \\\n"
     << "     '' using 4 title 'load imbalance' lc rgb '#756bb1', \\\n"
     << "     '' using 6 title 'residual (outside the step timer)' lc rgb '#bdbdbd', \\\n"
     << "     '' using 0:7 with points pt 7 ps 1.2 lc rgb 'black' title 'Time (timed median)'\n"
     << "set title 'Overheads only (of the same run)'\n"
     << "plot 'overhead.dat' using 2:xtic(1) title 'sequential overhead' lc rgb '#e6550d', \\\n"
     << "     '' using 3 title 'parallel overhead' lc rgb '#31a354', \\\n"
     << "     '' using 4 title 'load imbalance' lc rgb '#756bb1'\n"
     << "unset multiplot\n";
  run_gnuplot(dir, "overhead", og.str(), outcome);
  return outcome;
}

std::string cloth_colour_field(const SurfaceMesh& surface) {
  for (const auto& [name, values] : surface.point_scalars) {
    if (name == "mesh_level") return name;
  }
  for (const auto& [name, values] : surface.point_scalars) {
    if (name == "contact_force_N" &&
        std::any_of(values.begin(), values.end(), [](double v) { return v != 0.0; })) {
      return name;
    }
  }
  return "";
}

namespace {

/// The point field called `name`, or null.
const std::vector<double>* point_field(const SurfaceMesh& surface, const std::string& name) {
  for (const auto& [field, values] : surface.point_scalars) {
    if (field == name) return &values;
  }
  return nullptr;
}

}  // namespace

std::string cloth_plot_data(const SurfaceMesh& surface) {
  const std::string field = cloth_colour_field(surface);
  const std::vector<double>* colour = point_field(surface, field);
  auto point_line = [&](std::int32_t p) {
    const auto& x = surface.points[static_cast<std::size_t>(p)];
    const double c = colour != nullptr ? (*colour)[static_cast<std::size_t>(p)] : x.z();
    return fmt::format("{:.7g} {:.7g} {:.7g} {:.7g}\n", x.x(), x.y(), x.z(), c);
  };
  std::string data;
  data.reserve(surface.quads.size() * 180);
  for (const auto& q : surface.quads) {  // each quad is a 2 x 2 pm3d patch
    data += point_line(q[0]) + point_line(q[1]) + "\n" + point_line(q[3]) + point_line(q[2]) +
            "\n\n";
  }
  return data;
}

PlotOutcome plot_cloth(const SurfaceMesh& surface, const std::string& title,
                       const std::filesystem::path& dir) {
  PlotOutcome outcome;
  const std::string field = cloth_colour_field(surface);
  const std::vector<double>* colour = point_field(surface, field);
  write_file_atomically(dir / "cloth.dat", cloth_plot_data(surface));
  const std::string label = field.empty() ? "height z [m]"
                            : field == "mesh_level" ? "mesh level (0 = finest)"
                                                    : "contact force [N]";
  // Mesh levels are integers: one colour per level, integer tics, level 0 (finest) first.
  std::string discrete_levels;
  if (field == "mesh_level" && colour != nullptr && !colour->empty()) {
    const int top = static_cast<int>(std::lround(*std::max_element(colour->begin(), colour->end())));
    discrete_levels = fmt::format("set cbrange [-0.5:{}.5]\nset cbtics 1\nset palette maxcolors {}\n",
                                  top, top + 1);
  }
  std::ostringstream gp;
  gp << png_terminal(1100, 850) << "set output 'cloth.png'\n"
     << fmt::format("set title {}\n", gnuplot_quote(title + " - coloured by " + label))
     << "set view 58, 32, 1, 1.1\nset view equal xyz\nset xyplane relative 0\n"
     << "set xlabel 'x [m]'\nset ylabel 'y [m]'\nset zlabel 'z [m]' rotate\n"
     << "set ztics 0.1 format '%.1f'\n"
     << (surface.quads.size() <= 2500  // mesh lines only where they do not hide the colours
             ? "set pm3d depthorder corners2color mean border lc rgb '#00000020' lw 0.3\n"
             : "set pm3d depthorder corners2color mean noborder\n")
     << "set palette rgb 33,13,10\n" << discrete_levels
     << fmt::format("set cblabel {}\n", gnuplot_quote(label))
     << "unset key\nset grid\n"
     << "splot 'cloth.dat' using 1:2:3:4 with pm3d\n";
  run_gnuplot(dir, "cloth", gp.str(), outcome);
  return outcome;
}

}  // namespace clothbench::harness
