// gnuplot figures of a sweep: time and speed-up vs threads per scheduler (the paper's
// Fig. 12, with the ideal line), the overhead breakdown as stacked bars, and a rendering of
// the draped cloth coloured by a per-point field. Each figure is a data file plus a gnuplot
// script written next to the PNG, so it can be re-run or edited by hand.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "harness/output/vtk_writer.hpp"

namespace clothbench::harness {

/// What a plotting call produced.
struct PlotOutcome {
  std::vector<std::filesystem::path> images;  ///< PNGs written
  std::vector<std::string> problems;          ///< one line per figure that failed
};

/// `text` as a gnuplot double-quoted string.
std::string gnuplot_quote(const std::string& text);
/// The pngcairo terminal line of a `width` x `height` picture.
std::string png_terminal(int width, int height);
/// Writes `script` as dir/name.gp and runs gnuplot on it in `dir`; records the PNG in
/// `outcome.images` or a line in `outcome.problems` (gnuplot's messages stay in name.log).
void run_gnuplot(const std::filesystem::path& dir, const std::string& name,
                 const std::string& script, PlotOutcome& outcome);

/// True when `gnuplot` runs (searched on PATH).
bool gnuplot_available();

/// Writes fig12.{dat,gp,png} and, when the sweep was instrumented, overhead.{dat,gp,png}
/// into `dir`. Rows that failed verification are left out of the speed-up panel.
PlotOutcome plot_sweep(const nlohmann::json& document, const std::filesystem::path& dir);

/// The per-point field the cloth is coloured by: "mesh_level" when the surface has it
/// (AMRC), else "contact_force_N" when any value is non-zero, else "" (= height z).
std::string cloth_colour_field(const SurfaceMesh& surface);

/// The text of cloth.dat: one 2 x 2 pm3d patch per quad of `surface`, each point as
/// "x y z colour" with the colour of cloth_colour_field() (height z when there is none).
/// About 170 bytes a quad: callers bound the quads (cloth_picture.hpp), not this function.
std::string cloth_plot_data(const SurfaceMesh& surface);

/// Writes cloth.{dat,gp,png} into `dir`: a pm3d surface of `surface` (one 2x2 patch per
/// quad, cloth_plot_data), coloured by cloth_colour_field(). `title` heads the picture.
PlotOutcome plot_cloth(const SurfaceMesh& surface, const std::string& title,
                       const std::filesystem::path& dir);

}  // namespace clothbench::harness
