// The tilted tension plateau (kernels/tilted_plateau.hpp): its force is the clamp of the tilted
// line between the band's curves, its potential the integral of that force, its slope the
// force's derivative; its pieces cover the three- and five-piece shapes; a vanishing slope
// gives MODEL.md 4B's flat plateau back; and a cloth run with it keeps every edge's force
// inside its band.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "kernels/kes_material.hpp"
#include "kernels/potential_elements.hpp"
#include "kernels/simulation.hpp"
#include "kernels/tilted_plateau.hpp"
#include "schedulers/registry.hpp"
#include "kernel_fixtures.hpp"

namespace clothbench {
namespace {

using kernels::ReturnMapped;
using kernels::TensileBand;

/// The band of a fabric direction with the tilt R.
TensileBand band_of(double emt_percent, double lt, double rt_percent, double ratio) {
  kernels::KesDirection d;
  d.emt_percent = emt_percent;
  d.lt = lt;
  d.rt_percent = rt_percent;
  TensileBand band = TensileBand::from_kes(d, 500.0);
  band.plateau_slope = ratio * band.fm / band.emt;
  return band;
}

/// The law's definition, evaluated directly: clamp(t^n + E (eps - eps^n), tU, tL), 0 at eps <= 0.
double defined_force(const TensileBand& band, double fp, double ep, double s) {
  if (!(s > 0.0)) return 0.0;
  return std::clamp(fp + band.plateau_slope * (s - ep), band.unloading(s), band.loading(s));
}

/// Integral of defined_force from 0 to s by composite Gauss-Legendre (5 points a panel) on
/// panels that end at the pieces' boundaries, where the integrand has kinks.
double defined_potential(const TensileBand& band, double fp, double ep, const double* pieces,
                         double s) {
  std::vector<double> cuts{0.0};
  for (int k = 1; k <= 4; ++k) {
    if (pieces[k] > 0.0 && pieces[k] < s) cuts.push_back(pieces[k]);
  }
  if (band.emt < s) cuts.push_back(band.emt);
  cuts.push_back(s);
  std::sort(cuts.begin(), cuts.end());
  static const double x[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831,
                              0.9061798459386640};
  static const double w[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889,
                              0.4786286704993665, 0.2369268850561891};
  auto panel = [&](double a, double b) {
    double sum = 0.0;
    for (int g = 0; g < 5; ++g) {
      sum += 0.5 * (b - a) * w[g] * defined_force(band, fp, ep, 0.5 * (a + b) + 0.5 * (b - a) * x[g]);
    }
    return sum;
  };
  double sum = 0.0;
  // From zero strain, panels halving towards it: a curve with p < 1 is infinitely steep there.
  for (int k = 0; k < 60; ++k) sum += panel(std::ldexp(cuts[1], -k - 1), std::ldexp(cuts[1], -k));
  for (std::size_t c = 1; c + 1 < cuts.size(); ++c) {
    constexpr int kPanels = 64;
    const double h = (cuts[c + 1] - cuts[c]) / kPanels;
    for (int k = 0; k < kPanels; ++k) sum += panel(cuts[c] + k * h, cuts[c] + (k + 1) * h);
  }
  return sum;
}

struct LawCase {
  double fp, ep;
};

/// Previous states: inside the band at eps^n (as a completed step leaves them), on either
/// curve, and outside it (a force AMRC carried onto a new edge).
std::vector<LawCase> law_cases(const TensileBand& band, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<LawCase> cases;
  for (int k = 0; k < 300; ++k) {
    const double ep = band.emt * (k % 10 == 0 ? 1.5 * unit(rng) : std::pow(10.0, -4.0 * unit(rng)));
    const double lo = band.unloading(ep), hi = band.loading(ep);
    double fp = lo + unit(rng) * (hi - lo);
    if (k % 7 == 1) fp = lo;
    if (k % 7 == 2) fp = hi;
    if (k % 11 == 3) fp = hi * (1.0 + unit(rng));  // above the band
    if (k % 11 == 4) fp = lo * unit(rng);          // below it
    if (k % 13 == 5) fp = 0.0;
    cases.push_back({fp, ep});
  }
  return cases;
}

class TiltedLaw : public ::testing::TestWithParam<double> {};

TEST_P(TiltedLaw, ForcePotentialAndSlopeFollowTheDefinition) {
  const double ratio = GetParam();
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int five_pieces = 0, three_pieces = 0, empty_loading = 0;
  for (const TensileBand& band :
       {band_of(5.0, 0.65, 50.0, ratio), band_of(2.5, 0.8, 65.0, ratio),
        band_of(8.0, 1.4, 40.0, std::min(ratio, 0.2))}) {  // the last: p = 0.43 < 1
    const double fm = band.fm;
    for (const LawCase& c : law_cases(band, rng)) {
      double pieces[kernels::kTiltedPieceDoubles];
      kernels::tilted_pieces(band, c.fp, c.ep, pieces);
      ASSERT_LE(0.0, pieces[1]);
      ASSERT_LE(pieces[1], pieces[2]);
      ASSERT_LE(pieces[2], pieces[3]);
      ASSERT_LE(pieces[3], pieces[4]);
      if (pieces[1] > 0.0 && pieces[2] < pieces[3]) ++five_pieces;
      if (pieces[1] == 0.0 && pieces[2] == 0.0 && pieces[3] > 0.0) ++three_pieces;
      if (!(pieces[2] < pieces[3])) ++empty_loading;
      std::vector<double> strains{-0.01, 0.0, c.ep, 3.0 * band.emt};
      for (int k = 1; k <= 4; ++k) {  // either side of every boundary
        strains.push_back(pieces[k] * (1.0 - 1e-9));
        strains.push_back(pieces[k] * (1.0 + 1e-9));
      }
      for (int k = 0; k < 20; ++k) strains.push_back(2.0 * band.emt * unit(rng));
      double previous_strain = -1.0, previous_force = -1.0;
      std::sort(strains.begin(), strains.end());
      for (double s : strains) {
        const ReturnMapped r = kernels::tilted_return_map(band, pieces, s);
        const double expected = defined_force(band, c.fp, c.ep, s);
        ASSERT_NEAR(r.force, expected, 1e-12 * fm + 1e-9 * std::abs(expected))
            << "fp " << c.fp << " ep " << c.ep << " s " << s;
        if (s > previous_strain) {
          ASSERT_GE(r.force, previous_force - 1e-12 * fm) << "the force must not decrease";
        }
        previous_strain = s;
        previous_force = r.force;
        if (!(s > 0.0)) {
          EXPECT_EQ(r.potential, 0.0);
          continue;
        }
        const double integral = defined_potential(band, c.fp, c.ep, pieces, s);
        ASSERT_NEAR(r.potential, integral, 1e-11 * fm * s + 1e-9 * integral)
            << "fp " << c.fp << " ep " << c.ep << " s " << s;
        // The slope is the force's derivative (central differences inside a piece).
        const double h = 1e-7 * s;
        const auto piece = kernels::tilted_piece(pieces, s);
        if (kernels::tilted_piece(pieces, s - h) == piece &&
            kernels::tilted_piece(pieces, s + h) == piece && (s - h > band.emt || s + h < band.emt)) {
          const double derivative =
              (kernels::tilted_return_map(band, pieces, s + h).force -
               kernels::tilted_return_map(band, pieces, s - h).force) / (2.0 * h);
          ASSERT_NEAR(r.slope, derivative, 1e-6 * std::abs(derivative) + 1e-6 * fm / band.emt);
        }
      }
    }
  }
  // Both shapes of the law were met: line above both curves at zero strain (three pieces),
  // and below them (five, when the loading curve is reached inside the band's interval).
  EXPECT_GT(three_pieces, 0);
  EXPECT_GT(empty_loading, 0);
  if (ratio >= 1e-2) {
    EXPECT_GT(five_pieces, 0);
  }
}

INSTANTIATE_TEST_SUITE_P(Slopes, TiltedLaw, ::testing::Values(1e-6, 1e-3, 1e-2, 0.3));

TEST(TiltedLaw, AVanishingSlopeGivesTheFlatPlateau) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const TensileBand band = band_of(5.0, 0.65, 50.0, 1e-13);
  TensileBand flat = band;
  flat.plateau_slope = 0.0;
  for (const LawCase& c : law_cases(band, rng)) {
    double pieces[kernels::kTiltedPieceDoubles];
    kernels::tilted_pieces(band, c.fp, c.ep, pieces);
    for (int k = 0; k < 20; ++k) {
      const double s = 2.0 * band.emt * unit(rng);
      const ReturnMapped tilted = kernels::tilted_return_map(band, pieces, s);
      const ReturnMapped plateau = kernels::fast_return_map(flat, c.fp, s, nullptr);
      ASSERT_NEAR(tilted.force, plateau.force, 1e-9 * band.fm) << c.fp << " " << c.ep << " " << s;
      ASSERT_NEAR(tilted.potential, plateau.potential, 1e-9 * band.fm * s);
    }
  }
}

/// A small drape with the tilted plateau: Newton converges every step, and every edge's stored
/// force lies inside the band at its strain (the hysteresis invariant of MODEL.md 3), as the
/// flat law's does; the shape stays within millimetres of the flat law's.
TEST(TiltedLaw, ADrapeKeepsEveryForceInsideItsBand) {
  auto scene = [](double ratio) {
    kernels::SimulationConfig c;
    c.cloth.particles_i = c.cloth.particles_j = 17;
    c.cloth.block_size = 4;
    c.cloth.size_i = c.cloth.size_j = 0.32;
    c.cloth.origin = {-0.16, -0.16, 0.103};
    c.obstacles.push_back(testing::box_obstacle({0.0, 0.0, 0.05}, {0.08, 0.08, 0.05}));
    c.time.step = 0.004;
    c.time.damping = 0.1;
    c.solver.tolerance = 1e-4;
    c.fabric.tension_plateau_slope = ratio;
    return c;
  };
  auto driver = schedulers::make_driver("static");
  kernels::Simulation tilted(scene(1e-3)), flat(scene(0.0));
  for (int step = 0; step < 40; ++step) {
    const kernels::StepReport r = tilted.step(*driver);
    ASSERT_EQ(r.rejected, 0) << "step " << step;
    (void)flat.step(*driver);
  }
  const kernels::ClothMesh& mesh = tilted.mesh();
  const kernels::ClothState& st = tilted.state();
  int inside_plateau = 0, checked = 0;
  double largest_move = 0.0;
  for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
    if (!mesh.edge_active[id]) continue;
    const std::int64_t a = kernels::element_slot(id), b = mesh.next[id];
    const double strain =
        (kernels::vec3(st.position, b) - kernels::vec3(st.position, a)).norm() / mesh.edge_rest[id] -
        1.0;
    const TensileBand& band = tilted.material().tensile[kernels::element_direction(id)];
    const double t = st.edge_force[id];
    ++checked;
    if (!(strain > 0.0)) {
      EXPECT_EQ(t, 0.0);
      continue;
    }
    EXPECT_GE(t, band.unloading(strain) * (1.0 - 1e-12)) << "edge " << id;
    EXPECT_LE(t, band.loading(strain) * (1.0 + 1e-12)) << "edge " << id;
    if (t > band.unloading(strain) * (1.0 + 1e-9) && t < band.loading(strain) * (1.0 - 1e-9)) {
      ++inside_plateau;
    }
  }
  for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
    largest_move = std::max(largest_move, (kernels::vec3(tilted.state().position, s) -
                                           kernels::vec3(flat.state().position, s)).norm());
  }
  EXPECT_GT(checked, 0);
  EXPECT_GT(inside_plateau, 0) << "no edge is inside its band: the tilt was not exercised";
  EXPECT_LT(largest_move, 0.01) << "the tilt moved the drape by more than 1 cm";
  EXPECT_GT(largest_move, 0.0) << "the tilt changed nothing: is it wired in?";
}

}  // namespace
}  // namespace clothbench
