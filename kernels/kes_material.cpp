// Set-up and per-step parts of the KES bands (MODEL.md 3, 4B): unit conversion, the
// bending band's onset and inverses (safeguarded Newton), and the KES re-measurement.
#include "kernels/kes_material.hpp"

#include <array>
#include <cmath>
#include <limits>
#include <utility>

namespace clothbench::kernels {
namespace {

constexpr double kGramForce = 9.80665e-3;  // N

/// Root of an increasing function on [lo, hi] (value(lo) <= 0 <= value(hi)) by Newton from
/// `x`, falling back to bisection whenever a step leaves the bracket. `fn(x)` returns
/// {value, derivative}. Converges to ~1e-15 relative.
template <class Fn>
double solve_increasing(Fn fn, double lo, double hi, double x) {
  for (int iteration = 0; iteration < 200; ++iteration) {
    const auto [value, derivative] = fn(x);
    if (value == 0.0) return x;
    if (value > 0.0) {
      hi = std::min(hi, x);
    } else {
      lo = std::max(lo, x);
    }
    double next = derivative > 0.0 ? x - value / derivative : 0.5 * (lo + hi);
    if (std::abs(next - x) <= 1e-15 * std::abs(x)) return next;
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (hi - lo <= 1e-15 * hi) return next;
    x = next;
  }
  return x;
}

/// Integral of f over [0, a] by the substitution s = a u^4 (tames the power-law cusp at 0)
/// and composite 5-point Gauss-Legendre on `panels` equal panels of u in [0, 1].
template <class F>
double integrate_from_zero(F f, double a, int panels) {
  static constexpr std::array<double, 5> kNodes = {
      0.0, -0.5384693101056831, 0.5384693101056831, -0.9061798459386640, 0.9061798459386640};
  static constexpr std::array<double, 5> kWeights = {
      0.5688888888888889, 0.4786286704993665, 0.4786286704993665, 0.2369268850561891,
      0.2369268850561891};
  const double h = 1.0 / panels;
  double sum = 0.0;
  for (int panel = 0; panel < panels; ++panel) {
    const double mid = (panel + 0.5) * h;
    for (std::size_t k = 0; k < kNodes.size(); ++k) {
      const double u = mid + 0.5 * h * kNodes[k];
      const double u2 = u * u;
      sum += kWeights[k] * f(a * u2 * u2) * 4.0 * a * u2 * u;  // ds = 4 a u^3 du
    }
  }
  return 0.5 * h * sum;
}

}  // namespace

TensileBand TensileBand::from_kes(const KesDirection& direction, double fm_gf_per_cm) {
  TensileBand band;
  band.fm = fm_gf_per_cm * kGramForce * 100.0;  // gf/cm -> N/m
  band.emt = direction.emt_percent / 100.0;
  band.p = 2.0 / direction.lt - 1.0;
  band.q = (band.p + 1.0) / (direction.rt_percent / 100.0) - 1.0;
  return band;
}

BendingBand BendingBand::from_kes(const KesDirection& direction, double kappa0_per_cm) {
  BendingBand band;
  band.b = direction.bending_b * kGramForce * 1.0e-2;  // gf cm^2/cm = gf cm -> N m
  band.hb = 0.5 * direction.bending_2hb * kGramForce;  // gf cm/cm = gf -> N
  band.kappa0 = kappa0_per_cm * 100.0;                 // 1/cm -> 1/m
  band.unloading_onset = solve_unloading_onset(band.b, band.hb, band.kappa0);
  return band;
}

double BendingBand::solve_unloading_onset(double b, double hb, double kappa0) {
  if (!(hb > 0.0) || b * kappa0 >= hb) return 0.0;      // MU > 0 for every k > 0
  if (!(b > 0.0)) return std::numeric_limits<double>::infinity();  // MU == 0 everywhere
  // g(k) = b k - hb s(k) is convex, g(0) = 0, negative up to the root, minimal at k_min;
  // the root lies in (k_min, hb/b]. Newton from the right converges monotonically.
  const double k_min = kappa0 * std::log(hb / (b * kappa0));
  const double hi = hb / b;
  return solve_increasing(
      [&](double k) {
        const double em1 = std::expm1(-k / kappa0);
        return std::pair{b * k + hb * em1, b - hb * (1.0 + em1) / kappa0};
      },
      k_min, hi, hi);
}

double BendingBand::loading_inverse(double m) const {
  if (!(m > 0.0)) return 0.0;
  if (!(b > 0.0)) {  // ML = HB s(k) saturates at HB
    return m < hb ? -kappa0 * std::log1p(-m / hb) : std::numeric_limits<double>::infinity();
  }
  // ML is concave increasing with ML(k) <= (B + HB/kappa0) k and ML(k) >= B k: the root lies in
  // [m/(B + HB/kappa0), m/B]; Newton from the left converges monotonically.
  const double lo = m / (b + hb / kappa0);
  const double hi = m / b;
  return solve_increasing(
      [&](double k) {
        const double em1 = std::expm1(-k / kappa0);
        return std::pair{b * k - hb * em1 - m, b + hb * (1.0 + em1) / kappa0};
      },
      lo, hi, lo);
}

double BendingBand::unloading_inverse(double m) const {
  if (!(m > 0.0)) return 0.0;
  if (!(b > 0.0)) return std::numeric_limits<double>::infinity();  // MU == 0
  // Beyond the onset MU(k) = B k - HB s(k) is convex increasing and >= B k - HB: the root
  // lies in (onset, (m + HB)/B]; Newton from the right converges monotonically.
  const double hi = (m + hb) / b;
  return solve_increasing(
      [&](double k) {
        const double em1 = std::expm1(-k / kappa0);
        return std::pair{b * k + hb * em1 - m, b - hb * (1.0 + em1) / kappa0};
      },
      unloading_onset, hi, hi);
}

FabricMaterial FabricMaterial::from_kes(const KesParameters& fabric) {
  FabricMaterial material;
  material.tensile[0] = TensileBand::from_kes(fabric.warp, fabric.fm_gf_per_cm);
  material.tensile[1] = TensileBand::from_kes(fabric.weft, fabric.fm_gf_per_cm);
  for (TensileBand& band : material.tensile) {
    band.plateau_slope = fabric.tension_plateau_slope * band.fm / band.emt;
  }
  material.bending[0] = BendingBand::from_kes(fabric.warp, fabric.kappa0_per_cm);
  material.bending[1] = BendingBand::from_kes(fabric.weft, fabric.kappa0_per_cm);
  material.areal_density = fabric.weight_mg_per_cm2 * 0.01;  // mg/cm^2 -> kg/m^2
  material.thickness = fabric.thickness_mm * 1.0e-3;         // mm -> m
  return material;
}

KesDirection remeasure_tensile(const TensileBand& band) {
  // EMT: bisection for tL(eps) = Fm on a bracket grown from 1e-6.
  double lo = 0.0;
  double hi = 1.0e-6;
  while (band.loading(hi) < band.fm && hi < 1.0e6) hi *= 2.0;
  for (int iteration = 0; iteration < 200 && hi - lo > 1e-16 * hi; ++iteration) {
    const double mid = 0.5 * (lo + hi);
    (band.loading(mid) < band.fm ? lo : hi) = mid;
  }
  const double emt = 0.5 * (lo + hi);
  constexpr int kPanels = 400;
  const double work = integrate_from_zero([&](double s) { return band.loading(s); }, emt, kPanels);
  const double recovered =
      integrate_from_zero([&](double s) { return band.unloading(s); }, emt, kPanels);
  KesDirection measured;
  measured.emt_percent = 100.0 * emt;
  measured.lt = work / (0.5 * band.fm * emt);
  measured.rt_percent = 100.0 * recovered / work;
  measured.bending_b = 0.0;
  measured.bending_2hb = 0.0;
  return measured;
}

}  // namespace clothbench::kernels
