// KES bands, return mapping and band violation (MODEL.md 3, 4): conversions, band ordering,
// slopes/integrals/inverses against finite differences and quadrature, Psi' == force,
// and the KES re-measurement reproducing the inputs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "kernels/kes_material.hpp"

namespace clothbench::kernels {
namespace {

// Three representative direction sets (cotton warp, wool weft, denim warp), Kawabata units.
const std::vector<KesDirection> kDirections = {
    {4.2, 0.70, 38.0, 0.085, 0.080},
    {8.5, 0.58, 62.0, 0.085, 0.045},
    {2.8, 0.78, 36.0, 0.95, 0.90},
};
constexpr double kFm = 500.0;     // gf/cm
constexpr double kKappa0 = 0.1;   // 1/cm

/// A band with the strain scale and the kinks (where slopes jump) of its curves.
template <class Band>
struct Case {
  Band band;
  double scale;                // typical strain / curvature
  std::vector<double> kinks;   // avoided by finite differences
};

std::vector<Case<TensileBand>> tensile_cases() {
  std::vector<Case<TensileBand>> cases;
  for (const auto& d : kDirections) {
    const TensileBand band = TensileBand::from_kes(d, kFm);
    cases.push_back({band, band.emt, {0.0, band.emt}});
  }
  return cases;
}

std::vector<Case<BendingBand>> bending_cases() {
  std::vector<Case<BendingBand>> cases;
  for (const auto& d : kDirections) {
    const BendingBand band = BendingBand::from_kes(d, kKappa0);
    cases.push_back({band, 100.0, {0.0, band.unloading_onset}});  // 1/cm = 100/m
  }
  return cases;
}

/// Strains from 0.01 to 2.5 scales (both sides of EMT), none within 1e-3 of a kink.
template <class Band>
std::vector<double> samples(const Case<Band>& c) {
  std::vector<double> xs;
  for (double f = 0.01; f < 2.5; f *= 1.17) {
    const double x = f * c.scale;
    const bool near_kink = std::any_of(c.kinks.begin(), c.kinks.end(), [&](double k) {
      return std::abs(x - k) < 1e-3 * c.scale;
    });
    if (!near_kink) xs.push_back(x);
  }
  return xs;
}

/// Central difference of f at x with step 1e-6 x.
double derivative(const std::function<double(double)>& f, double x) {
  const double h = 1e-6 * x;
  return (f(x + h) - f(x - h)) / (2.0 * h);
}

/// Integral of f over [0, x], split at the kinks, each piece by s = a + (b-a) u^4 and
/// composite 5-point Gauss-Legendre (not the closed forms).
double quadrature(const std::function<double(double)>& f, double x, std::vector<double> kinks) {
  static const double nodes[5] = {0.0, -0.5384693101056831, 0.5384693101056831,
                                  -0.9061798459386640, 0.9061798459386640};
  static const double weights[5] = {0.5688888888888889, 0.4786286704993665, 0.4786286704993665,
                                    0.2369268850561891, 0.2369268850561891};
  kinks.push_back(x);
  std::sort(kinks.begin(), kinks.end());
  double total = 0.0;
  double a = 0.0;
  for (double b : kinks) {
    if (b <= a || b > x) continue;
    const int panels = 400;
    const double h = 1.0 / panels;
    for (int p = 0; p < panels; ++p) {
      for (int k = 0; k < 5; ++k) {
        const double u = (p + 0.5 + 0.5 * nodes[k]) * h;
        const double u3 = u * u * u;
        total += 0.5 * h * weights[k] * f(a + (b - a) * u3 * u) * 4.0 * (b - a) * u3;
      }
    }
    a = b;
  }
  return total;
}

TEST(KesMaterial, ConvertsKawabataUnitsToSi) {
  KesParameters fabric;
  fabric.warp = kDirections[0];
  fabric.weft = kDirections[2];
  fabric.weight_mg_per_cm2 = 13.5;
  fabric.thickness_mm = 0.30;
  fabric.fm_gf_per_cm = 500.0;
  fabric.kappa0_per_cm = 0.1;
  const FabricMaterial m = FabricMaterial::from_kes(fabric);
  EXPECT_NEAR(m.tensile[0].fm, 490.3325, 1e-9);           // 500 gf/cm = 490.3325 N/m
  EXPECT_NEAR(m.tensile[0].emt, 0.042, 1e-15);
  EXPECT_NEAR(m.tensile[0].p, 2.0 / 0.7 - 1.0, 1e-15);     // 1.857142857...
  EXPECT_NEAR(m.tensile[0].q, (2.0 / 0.7) / 0.38 - 1.0, 1e-13);  // 6.518796992...
  EXPECT_NEAR(m.tensile[1].emt, 0.028, 1e-15);
  EXPECT_NEAR(m.bending[0].b, 8.3356525e-6, 1e-18);       // 0.085 gf cm^2/cm in N m
  EXPECT_NEAR(m.bending[0].hb, 3.92266e-4, 1e-16);        // 0.08/2 gf cm/cm in N
  EXPECT_NEAR(m.bending[0].kappa0, 10.0, 1e-12);          // 0.1 1/cm in 1/m
  EXPECT_NEAR(m.bending[1].b, 9.3163175e-5, 1e-17);
  EXPECT_NEAR(m.areal_density, 0.135, 1e-15);             // 13.5 mg/cm^2 in kg/m^2
  EXPECT_NEAR(m.thickness, 3.0e-4, 1e-18);
}

TEST(KesMaterial, BendingOnsetSolvesItsEquation) {
  for (const auto& c : bending_cases()) {
    const BendingBand& b = c.band;
    ASSERT_GT(b.unloading_onset, 0.0);  // all three sets have B < HB/kappa0
    const double on = b.unloading_onset;
    const double residual = b.b * on - b.hb * (1.0 - std::exp(-on / b.kappa0));
    EXPECT_LT(std::abs(residual), 1e-13 * b.b * on);
    EXPECT_EQ(b.unloading(0.999 * on), 0.0);
    EXPECT_GT(b.unloading(1.001 * on), 0.0);
  }
  EXPECT_EQ(BendingBand::solve_unloading_onset(2.0, 1.0, 1.0), 0.0);  // B >= HB/kappa0
}

template <class Band>
void check_band_shape(const Case<Band>& c) {
  const Band& band = c.band;
  for (double x : {-1.0 * c.scale, -1e-9, 0.0}) {
    const BandCurves k = band.curves(x);
    EXPECT_EQ(k.lower, 0.0);
    EXPECT_EQ(k.upper, 0.0);
    EXPECT_EQ(band.loading_integral(x), 0.0);
  }
  double previous_upper = 0.0;
  for (double x : samples(c)) {
    const BandCurves k = band.curves(x);
    EXPECT_GE(k.lower, 0.0);
    EXPECT_LE(k.lower, k.upper * (1.0 + 1e-15));
    EXPECT_GT(k.upper, previous_upper);
    previous_upper = k.upper;
    // curves() shares one log between both power laws: ~|q log(eps/EMT)| ulp from pow.
    EXPECT_NEAR(k.upper, band.loading(x), 1e-13 * k.upper);
    EXPECT_NEAR(k.lower, band.unloading(x), 1e-13 * k.upper);
    EXPECT_NEAR(k.upper_slope, band.loading_slope(x), 1e-13 * k.upper_slope);
    EXPECT_NEAR(k.lower_slope, band.unloading_slope(x), 1e-13 * k.upper_slope);
  }
}

TEST(KesMaterial, BandsAreOrderedAndEmptyInCompression) {
  for (const auto& c : tensile_cases()) check_band_shape(c);
  for (const auto& c : bending_cases()) {
    check_band_shape(c);
    EXPECT_EQ(c.band.loading(0.0), 0.0);  // closed at zero curvature
    EXPECT_EQ(c.band.unloading(0.0), 0.0);
    EXPECT_LT(c.band.loading(1e-9), 1e-9 * (c.band.b + c.band.hb / c.band.kappa0) * 1.0001);
  }
  for (const auto& c : tensile_cases()) {  // beyond EMT both follow the loading tangent
    const TensileBand& t = c.band;
    EXPECT_DOUBLE_EQ(t.loading(2.0 * t.emt), t.fm * (1.0 + t.p));
    EXPECT_DOUBLE_EQ(t.unloading(2.0 * t.emt), t.loading(2.0 * t.emt));
  }
}

template <class Band>
void check_slopes_integrals_inverses(const Case<Band>& c) {
  const Band& band = c.band;
  const auto loading = [&](double x) { return band.loading(x); };
  const auto unloading = [&](double x) { return band.unloading(x); };
  for (double x : samples(c)) {
    const double secant = band.loading(x) / x;
    EXPECT_NEAR(band.loading_slope(x), derivative(loading, x),
                1e-8 * (std::abs(band.loading_slope(x)) + secant))
        << x;
    EXPECT_NEAR(band.unloading_slope(x), derivative(unloading, x),
                1e-8 * (std::abs(band.unloading_slope(x)) + secant))
        << x;
    const double int_l = quadrature(loading, x, c.kinks);
    const double int_u = quadrature(unloading, x, c.kinks);
    EXPECT_NEAR(band.loading_integral(x), int_l, 1e-8 * int_l) << x;
    EXPECT_NEAR(band.unloading_integral(x), int_u, 1e-8 * int_l) << x;
    EXPECT_NEAR(band.loading_inverse(band.loading(x)), x, 1e-12 * x) << x;
    if (band.unloading(x) > 0.0) {
      EXPECT_NEAR(band.unloading_inverse(band.unloading(x)), x, 1e-12 * x) << x;
    }
  }
  EXPECT_EQ(band.loading_inverse(0.0), 0.0);
  EXPECT_EQ(band.unloading_inverse(-1.0), 0.0);
}

TEST(KesMaterial, SlopesIntegralsAndInversesAreConsistent) {
  for (const auto& c : tensile_cases()) check_slopes_integrals_inverses(c);
  for (const auto& c : bending_cases()) check_slopes_integrals_inverses(c);
}

template <class Band>
void check_violation(const Case<Band>& c) {
  const Band& band = c.band;
  for (double x : samples(c)) {
    const BandCurves k = band.curves(x);
    for (double a : {0.0, 0.3, 1.0}) {
      EXPECT_EQ(band_violation(band, k.lower + a * (k.upper - k.lower), x).value, 0.0);
    }
    const double unit = band.loading(c.scale);
    double above = 0.0;
    double below = 0.0;
    for (double d : {1e-6, 1e-3, 0.1, 1.0}) {
      const BandViolation up = band_violation(band, k.upper + d * unit, x);
      EXPECT_GT(up.value, above);
      EXPECT_NEAR(up.value, d * unit, 1e-12 * unit);
      EXPECT_EQ(up.d_force, 1.0);
      EXPECT_DOUBLE_EQ(up.d_strain, -k.upper_slope);
      above = up.value;
      if (k.lower > d * unit) {
        const BandViolation down = band_violation(band, k.lower - d * unit, x);
        EXPECT_GT(down.value, below);
        EXPECT_NEAR(down.value, d * unit, 1e-12 * unit);
        EXPECT_EQ(down.d_force, -1.0);
        EXPECT_DOUBLE_EQ(down.d_strain, k.lower_slope);
        below = down.value;
      }
    }
  }
}

TEST(KesMaterial, ViolationIsZeroInsideAndGrowsOutside) {
  for (const auto& c : tensile_cases()) check_violation(c);
  for (const auto& c : bending_cases()) check_violation(c);
}

template <class Band>
void check_return_map(const Case<Band>& c) {
  const Band& band = c.band;
  const double fm = band.loading(c.scale);
  for (double f_prev : {0.0, -1.0, 1e-300, 1e-12 * fm, 0.05 * fm, 0.4 * fm, 1.0 * fm, 1.7 * fm}) {
    const BandBreakpoints bp = band_breakpoints(band, f_prev);
    EXPECT_LE(bp.lower, bp.upper);
    for (double x : {-0.1 * c.scale, 0.0}) {
      const ReturnMapped r = return_map(band, f_prev, bp, x);
      EXPECT_EQ(r.force, 0.0);
      EXPECT_EQ(r.slope, 0.0);
      EXPECT_EQ(r.potential, 0.0);
    }
    std::vector<double> xs = samples(c);
    for (double f : {0.5, 0.999, 1.001}) {  // each regime and both sides of each breakpoint
      xs.push_back(f * bp.lower);
      xs.push_back(f * bp.upper);
    }
    xs.push_back(0.5 * (bp.lower + bp.upper));
    std::vector<double> kinks = c.kinks;
    kinks.push_back(bp.lower);
    kinks.push_back(bp.upper);
    const auto force = [&](double x) { return return_map(band, f_prev, bp, x).force; };
    const auto potential = [&](double x) { return return_map(band, f_prev, bp, x).potential; };
    for (double x : xs) {
      if (!(x > 0.0)) continue;
      const ReturnMapped r = return_map(band, f_prev, bp, x);
      const BandCurves k = band.curves(x);
      const double clamped = std::max(k.lower, std::min(f_prev, k.upper));
      EXPECT_NEAR(r.force, clamped, 1e-12 * (clamped + fm * 1e-300)) << f_prev << " " << x;
      ASSERT_TRUE(std::isfinite(r.potential));
      const bool near_kink = std::any_of(kinks.begin(), kinks.end(),
                                         [&](double k) { return std::abs(x - k) < 1e-4 * x; });
      if (near_kink) continue;
      // Central differences of Psi: 1e-7 relative plus rounding of Psi (~1e-16 ML x) / h;
      // 1e-250 absorbs underflow of f_prev * eps for f_prev = 1e-300.
      EXPECT_NEAR(derivative(potential, x), r.force,
                  1e-7 * r.force + 1e-9 * band.loading(x) + 1e-250)
          << f_prev << " " << x;
      EXPECT_NEAR(derivative(force, x), r.slope, 1e-7 * (r.slope + r.force / x)) << x;
      const double psi = quadrature(force, x, kinks);
      EXPECT_NEAR(r.potential, psi, 1e-8 * psi + 1e-300) << f_prev << " " << x;
    }
    for (double b : {bp.lower, bp.upper}) {  // Psi and force continuous at the breakpoints
      if (!(b > 0.0)) continue;
      const double h = 1e-10 * b;
      EXPECT_NEAR(potential(b - h), potential(b + h), 1e-8 * potential(b) + 2.0 * h * fm);
      const auto slope = [&](double x) { return return_map(band, f_prev, bp, x).slope; };
      EXPECT_NEAR(force(b - h), force(b + h),
                  1e-6 * force(b) + 4.0 * h * (slope(b - h) + slope(b + h)) + 1e-300);
    }
  }
}

TEST(KesMaterial, ReturnMapClampsAndPotentialIntegratesForce) {
  for (const auto& c : tensile_cases()) check_return_map(c);
  for (const auto& c : bending_cases()) check_return_map(c);
}

TEST(KesMaterial, RemeasuredTensileTestReproducesInputs) {
  for (const auto& d : kDirections) {
    const KesDirection m = remeasure_tensile(TensileBand::from_kes(d, kFm));
    EXPECT_NEAR(m.emt_percent, d.emt_percent, 1e-6 * d.emt_percent);
    EXPECT_NEAR(m.lt, d.lt, 1e-6 * d.lt);
    EXPECT_NEAR(m.rt_percent, d.rt_percent, 1e-6 * d.rt_percent);
  }
}

}  // namespace
}  // namespace clothbench::kernels
