// KES bands in SI units and the hysteresis return mapping of MODEL.md sections 3 and 4.
// Tension t: force per unit width (N/m) against strain (dimensionless). Bending moment M:
// per unit width (N) against curvature kappa (1/m). Everything evaluated per element per
// gradient evaluation is inline here; per-step and set-up work lives in kes_material.cpp.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

#include "kernels/kes_parameters.hpp"

namespace clothbench::kernels {

/// Both boundary curves of a band and their slopes at one strain/curvature (MODEL.md 3).
/// Invariant: 0 <= lower <= upper.
struct BandCurves {
  double lower = 0.0;        ///< unloading curve (N/m or N)
  double upper = 0.0;        ///< loading curve
  double lower_slope = 0.0;  ///< d lower / d strain
  double upper_slope = 0.0;  ///< d upper / d strain
};

/// Kawabata's tensile band (MODEL.md 3): loading tL = Fm (eps/EMT)^p, p = 2/LT - 1;
/// unloading tU = Fm (eps/EMT)^q, q = (p+1)/(RT/100) - 1 (q >= p when RT <= 100).
/// eps <= 0: band [0, 0]. eps > EMT: both curves follow the loading tangent at (EMT, Fm).
struct TensileBand {
  double fm = 0.0;   ///< Fm, N/m (maximum load of the KES test per unit width)
  double emt = 0.0;  ///< EMT as a strain fraction (> 0)
  double p = 1.0;    ///< loading exponent (> 0)
  double q = 1.0;    ///< unloading exponent (>= p)
  /// E, N/m per unit strain: the slope of the force inside the band under the tilted plateau
  /// ([fabric] tension_plateau_slope R > 0, E = R Fm / EMT; tilted_plateau.hpp). 0: the flat
  /// plateau of MODEL.md 4B, which every kernel implements.
  double plateau_slope = 0.0;

  /// From Kawabata units: EMT %, LT, RT % of `direction`; Fm in gf/cm.
  static TensileBand from_kes(const KesDirection& direction, double fm_gf_per_cm);

  /// Both curves and slopes with one log and two exp (the hot call).
  BandCurves curves(double eps) const {
    BandCurves c;
    if (!(eps > 0.0)) return c;
    if (eps >= emt) {
      const double slope = fm * p / emt;
      c.lower = c.upper = fm + slope * (eps - emt);
      c.lower_slope = c.upper_slope = slope;
      return c;
    }
    const double log_ratio = std::log(eps / emt);
    c.upper = fm * std::exp(p * log_ratio);
    c.lower = fm * std::exp(q * log_ratio);
    c.upper_slope = p * c.upper / eps;
    c.lower_slope = q * c.lower / eps;
    return c;
  }
  /// tL(eps), N/m.
  double loading(double eps) const { return power_curve(eps, p); }
  /// tU(eps), N/m.
  double unloading(double eps) const { return power_curve(eps, q); }
  /// d tL / d eps, N/m.
  double loading_slope(double eps) const { return power_slope(eps, p); }
  /// d tU / d eps, N/m.
  double unloading_slope(double eps) const { return power_slope(eps, q); }
  /// Integral of tL from 0 to eps, N/m (0 for eps <= 0; closed form).
  double loading_integral(double eps) const { return power_integral(eps, p); }
  /// Integral of tU from 0 to eps, N/m.
  double unloading_integral(double eps) const { return power_integral(eps, q); }
  /// Strain where tL == t (0 for t <= 0).
  double loading_inverse(double t) const { return power_inverse(t, p); }
  /// Strain where tU == t (0 for t <= 0).
  double unloading_inverse(double t) const { return power_inverse(t, q); }

 private:
  double power_curve(double eps, double exponent) const {
    if (!(eps > 0.0)) return 0.0;
    if (eps >= emt) return fm + fm * p / emt * (eps - emt);
    return fm * std::pow(eps / emt, exponent);
  }
  double power_slope(double eps, double exponent) const {
    if (!(eps > 0.0)) return 0.0;
    if (eps >= emt) return fm * p / emt;
    return exponent * fm * std::pow(eps / emt, exponent) / eps;
  }
  double power_integral(double eps, double exponent) const {
    if (!(eps > 0.0)) return 0.0;
    if (eps >= emt) {
      const double beyond = eps - emt;
      return fm * emt / (exponent + 1.0) + fm * beyond + 0.5 * fm * p / emt * beyond * beyond;
    }
    return fm * std::pow(eps / emt, exponent) * eps / (exponent + 1.0);
  }
  double power_inverse(double t, double exponent) const {
    if (!(t > 0.0)) return 0.0;
    if (t >= fm) return emt + (t - fm) * emt / (fm * p);
    return emt * std::pow(t / fm, 1.0 / exponent);
  }
};

/// Kawabata's bending band closed at zero curvature (MODEL.md 3):
/// ML(k) = B k + HB s(k), MU(k) = max(0, B k - HB s(k)), s(k) = 1 - exp(-k/kappa0), HB = 2HB/2.
/// ML is concave increasing, MU convex increasing beyond `unloading_onset`. kappa <= 0: [0, 0].
struct BendingBand {
  double b = 0.0;       ///< B, N m (moment per unit width per curvature)
  double hb = 0.0;      ///< HB = 2HB/2, N
  double kappa0 = 1.0;  ///< closure curvature, 1/m (> 0)
  /// Curvature where MU leaves zero: root of B k = HB s(k), 0 if B >= HB/kappa0.
  /// Must match (b, hb, kappa0): build with from_kes or solve_unloading_onset.
  double unloading_onset = 0.0;

  /// From Kawabata units: B (gf cm^2/cm), 2HB (gf cm/cm) of `direction`; kappa0 in 1/cm.
  static BendingBand from_kes(const KesDirection& direction, double kappa0_per_cm);
  /// Positive root of b k = hb (1 - exp(-k/kappa0)) (0 if none), to ~1e-15 relative.
  static double solve_unloading_onset(double b, double hb, double kappa0);

  /// Both curves and slopes with one expm1 (the hot call).
  BandCurves curves(double kappa) const {
    BandCurves c;
    if (!(kappa > 0.0)) return c;
    const double em1 = std::expm1(-kappa / kappa0);  // exp(-k/k0) - 1 = -s(k)
    const double decay = hb * (1.0 + em1) / kappa0;  // HB s'(k)
    c.upper = b * kappa - hb * em1;
    c.upper_slope = b + decay;
    if (kappa > unloading_onset) {
      c.lower = std::max(0.0, b * kappa + hb * em1);
      c.lower_slope = b - decay;
    }
    return c;
  }
  /// ML(kappa), N.
  double loading(double kappa) const { return curves(kappa).upper; }
  /// MU(kappa), N.
  double unloading(double kappa) const { return curves(kappa).lower; }
  /// d ML / d kappa, N m.
  double loading_slope(double kappa) const { return curves(kappa).upper_slope; }
  /// d MU / d kappa, N m (0 below the onset).
  double unloading_slope(double kappa) const { return curves(kappa).lower_slope; }
  /// Integral of ML from 0 to kappa: B k^2/2 + HB (k + kappa0 (exp(-k/kappa0) - 1)), N/m.
  double loading_integral(double kappa) const {
    if (!(kappa > 0.0)) return 0.0;
    return 0.5 * b * kappa * kappa + hb * kappa0 * ramp_integral(kappa / kappa0);
  }
  /// Integral of MU from 0 to kappa (0 up to the onset), N/m.
  double unloading_integral(double kappa) const {
    if (!(kappa > unloading_onset)) return 0.0;
    const double on = unloading_onset;
    // G(k) = B k^2/2 - HB kappa0 r(k/kappa0); at the onset exp(-on/kappa0) = 1 - B on/HB.
    const double at_onset = 0.5 * b * on * on - hb * on + b * kappa0 * on;
    return 0.5 * b * kappa * kappa - hb * kappa0 * ramp_integral(kappa / kappa0) - at_onset;
  }
  /// Curvature where ML == m (0 for m <= 0; +inf if m is beyond the curve's supremum).
  double loading_inverse(double m) const;
  /// Curvature where MU == m beyond the onset (0 for m <= 0).
  double unloading_inverse(double m) const;

 private:
  /// r(x) = x + exp(-x) - 1 >= 0 without cancellation for small x.
  static double ramp_integral(double x) {
    if (x < 0.1) {
      // Taylor series x^2/2 - x^3/6 + ... to x^11; truncation < 1e-17 relative at x = 0.1.
      double sum = 0.0;
      double factorial = 39916800.0;  // 11!
      for (int k = 11; k >= 2; --k) {
        sum = sum * x + ((k % 2 == 0) ? 1.0 : -1.0) / factorial;
        factorial /= k;
      }
      return sum * x * x;
    }
    return x + std::expm1(-x);
  }
};

/// SI material of one fabric (MODEL.md 3): bands per thread direction, mass, thickness.
struct FabricMaterial {
  TensileBand tensile[2];  ///< [0] = warp (grid direction i), [1] = weft (j)
  BendingBand bending[2];  ///< [0] = warp, [1] = weft
  double areal_density = 0.0;  ///< kg/m^2
  double thickness = 0.0;      ///< m
  /// Converts Kawabata units once (1 gf = 9.80665e-3 N).
  static FabricMaterial from_kes(const KesParameters& fabric);
};

/// Where the plateau of the return mapping starts and ends for a previous force f_prev
/// (MODEL.md 4B), with the potential's constants cached (computed once per step).
/// Build with band_breakpoints; the defaulted NaNs make a hand-filled one visibly wrong.
struct BandBreakpoints {
  double lower = 0.0;  ///< strain where the loading curve reaches f_prev (0 if f_prev <= 0)
  double upper = 0.0;  ///< strain where the unloading curve reaches f_prev (0 if f_prev <= 0)
  double lower_potential = std::numeric_limits<double>::quiet_NaN();  ///< Psi(lower)
  /// Psi(upper) - unloading_integral(upper): Psi beyond `upper` is this + unloading_integral.
  double upper_offset = std::numeric_limits<double>::quiet_NaN();
};

/// Breakpoints of `band` for previous force `previous_force` (N/m or N).
template <class Band>
BandBreakpoints band_breakpoints(const Band& band, double previous_force) {
  BandBreakpoints bp{0.0, 0.0, 0.0, 0.0};
  if (!(previous_force > 0.0)) return bp;
  bp.lower = band.loading_inverse(previous_force);
  bp.upper = std::max(bp.lower, band.unloading_inverse(previous_force));
  bp.lower_potential = band.loading_integral(bp.lower);
  bp.upper_offset = bp.lower_potential + previous_force * (bp.upper - bp.lower) -
                    band.unloading_integral(bp.upper);
  return bp;
}

/// Force, its slope and its potential after the return mapping (MODEL.md 4B).
struct ReturnMapped {
  double force = 0.0;      ///< clamp(f_prev, unloading, loading), N/m or N
  double slope = 0.0;      ///< d force / d strain (0 on the plateau)
  double potential = 0.0;  ///< Psi(eps) = integral_0^eps force ds with f_prev fixed (C1)
};

/// Return mapping of one element at strain `eps` with previous force and its breakpoints
/// fixed: loading curve below bp.lower, plateau f_prev between, unloading curve above.
/// eps <= 0 gives all zero. One curve evaluation (one pow/exp) per call.
template <class Band>
ReturnMapped return_map(const Band& band, double previous_force, const BandBreakpoints& bp,
                        double eps) {
  ReturnMapped r;
  if (!(eps > 0.0)) return r;
  if (eps < bp.lower) {
    r.force = band.loading(eps);
    r.slope = band.loading_slope(eps);
    r.potential = band.loading_integral(eps);
  } else if (eps < bp.upper) {
    r.force = previous_force;
    r.potential = bp.lower_potential + previous_force * (eps - bp.lower);
  } else {
    r.force = band.unloading(eps);
    r.slope = band.unloading_slope(eps);
    r.potential = bp.upper_offset + band.unloading_integral(eps);
  }
  return r;
}

/// Band violation of a force given as an unknown (MODEL.md 4A) and its partial derivatives.
struct BandViolation {
  double value = 0.0;     ///< max(0, f - loading) + max(0, unloading - f) >= 0
  double d_force = 0.0;   ///< d value / d force (+1 above, -1 below, 0 inside)
  double d_strain = 0.0;  ///< d value / d strain
};

/// Violation of `force` against the band of `band` at strain `eps`.
template <class Band>
BandViolation band_violation(const Band& band, double force, double eps) {
  const BandCurves c = band.curves(eps);
  BandViolation v;
  if (force > c.upper) {
    v.value = force - c.upper;
    v.d_force = 1.0;
    v.d_strain = -c.upper_slope;
  } else if (force < c.lower) {
    v.value = c.lower - force;
    v.d_force = -1.0;
    v.d_strain = c.lower_slope;
  }
  return v;
}

/// Re-measures a KES tensile test on the curves (for tests): EMT by root finding of
/// tL = Fm, WT and WT' by Gauss-Legendre quadrature; returns emt_percent, lt = WT/(Fm EMT/2),
/// rt_percent = 100 WT'/WT. Bending fields are zero (not measured).
KesDirection remeasure_tensile(const TensileBand& band);

}  // namespace clothbench::kernels
