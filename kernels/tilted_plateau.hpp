// The tilted tension plateau: an opt-in variant of the tensile return mapping (MODEL.md 4B,
// kernels/MODEL-NOTES.md "A tilted tension plateau in the cloth").
//
// MODEL.md keeps an edge's force flat inside its KES band: t(eps) = clamp(t^n, tU(eps),
// tL(eps)). With [fabric] tension_plateau_slope = R > 0 the force inside the band changes with
// the strain at the small slope E = R Fm / EMT through the previous step's point (eps^n, t^n):
//   t(eps) = clamp(t^n + E (eps - eps^n), tU(eps), tL(eps))   for eps > 0, 0 otherwise.
// It is the clamp of a nondecreasing line between nondecreasing bounds, so still monotone with
// a convex potential Psi(eps) = integral_0^eps t, and R -> 0 gives the flat plateau back. Its
// pieces in strain, found once a step for each edge, are in order
//   unloading curve [0, u1), line [u1, l1), loading curve [l1, l2], line (l2, u2], unloading
//   curve beyond u2,
// any of which may be empty: the line minus either curve, g(eps) = alpha + E eps - t(eps), rises
// then falls (the curves' slopes grow to at least p Fm / EMT > E, given R < p), so where the line
// is above a curve is one interval.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "kernels/kes_material.hpp"

namespace clothbench::kernels {

/// Doubles stored per edge and step: {alpha, u1, l1, l2, u2}, alpha = t^n - E eps^n the line's
/// value at zero strain and the four piece boundaries above.
inline constexpr int kTiltedPieceDoubles = 5;

namespace tilted_detail {

/// Strain where g = alpha + E eps - curve(eps) is largest, for the loading (exponent p) or the
/// unloading curve (q): where the curve's slope reaches E (below EMT), 0 when the curve is
/// never less steep than E.
inline double top_of_gap(const TensileBand& band, bool loading) {
  const double exponent = loading ? band.p : band.q;
  const double ratio = band.plateau_slope * band.emt / band.fm;  // R
  if (!(exponent > 1.0) || !(ratio > 0.0)) return 0.0;
  return band.emt * std::pow(ratio / exponent, 1.0 / (exponent - 1.0));
}

inline double curve(const TensileBand& band, bool loading, double eps) {
  return loading ? band.loading(eps) : band.unloading(eps);
}
/// The curve's slope at eps > 0 from its value there (no second pow).
inline double curve_slope(const TensileBand& band, bool loading, double eps, double value) {
  if (eps >= band.emt) return band.fm * band.p / band.emt;
  return (loading ? band.p : band.q) * value / eps;
}

/// Root of g in [lo, hi] where g(lo) and g(hi) differ in sign (g monotone there): Newton's
/// method kept inside the bracket, bisection when a step leaves it or stalls. Deterministic:
/// the same inputs give the same bits.
inline double bracketed_root(const TensileBand& band, bool loading, double alpha, double lo,
                             double hi) {
  const double E = band.plateau_slope;
  const bool rising = alpha + E * lo - curve(band, loading, lo) < 0.0;  // else g(hi) < 0
  double s = rising ? lo : hi;  // start on the side of the bracket where g < 0
  for (int it = 0; it < 200; ++it) {
    const double c = s > 0.0 ? curve(band, loading, s) : 0.0;
    const double value = alpha + E * s - c;
    if (value == 0.0) return s;
    if ((value < 0.0) == rising) {
      lo = s;
    } else {
      hi = s;
    }
    const double slope = E - (s > 0.0 ? curve_slope(band, loading, s, c) : 0.0);
    double next = slope != 0.0 ? s - value / slope : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - s) <= 4.0 * std::numeric_limits<double>::epsilon() * std::abs(s) ||
        !(hi - lo > 4.0 * std::numeric_limits<double>::epsilon() * hi)) {
      return next;
    }
    s = next;
  }
  return 0.5 * (lo + hi);
}

/// Where alpha + E eps >= curve(eps) for eps > 0: the interval [first, second], or first >
/// second when it is empty. `first` is 0 when the line is above the curve from zero strain on.
struct Interval {
  double first = 1.0, second = 0.0;
};
inline Interval line_above_curve(const TensileBand& band, bool loading, double alpha) {
  const double E = band.plateau_slope;
  const double top = top_of_gap(band, loading);
  const double g_top = alpha + E * top - curve(band, loading, top);
  if (g_top < 0.0) return {};
  Interval in;
  in.first = alpha >= 0.0 || top == 0.0 ? 0.0 : bracketed_root(band, loading, alpha, 0.0, top);
  // Beyond EMT both curves are the loading curve's tangent, steeper than E: a closed form.
  const double k = band.fm * band.p / band.emt;
  const double g_emt = alpha + E * band.emt - band.fm;
  if (top >= band.emt || g_emt >= 0.0) {
    in.second = std::max(top, band.emt + g_emt / (k - E));
  } else {
    // Newton from the bracket's right end converges from that side (g is concave there for
    // exponent > 1), but from EMT to a root near zero strain it would shrink by only (1 - 1/k)
    // an iteration. A nearer right end: where the curve is at least twice both alpha and E eps
    // (the curve over eps grows with eps), g < 0.
    double hi = band.emt;
    const double exponent = loading ? band.p : band.q;
    if (exponent > 1.0) {
      const double ratio = E * band.emt / band.fm;
      const double nearer =
          std::max(band.emt * std::pow(2.0 * std::max(alpha, 0.0) / band.fm, 1.0 / exponent),
                   band.emt * std::pow(2.0 * ratio, 1.0 / (exponent - 1.0)));
      if (nearer > top && nearer < hi && alpha + E * nearer - curve(band, loading, nearer) < 0.0) {
        hi = nearer;
      }
    }
    in.second = bracketed_root(band, loading, alpha, top, hi);
  }
  return in;
}

/// Integral of the loading or unloading curve from 0 to eps where the curve's value there is
/// `value` (below EMT a power curve's integral is its value times eps / (exponent + 1)).
inline double curve_integral(const TensileBand& band, bool loading, double eps, double value) {
  if (!(eps > 0.0)) return 0.0;
  if (eps < band.emt) return value * eps / ((loading ? band.p : band.q) + 1.0);
  return loading ? band.loading_integral(eps) : band.unloading_integral(eps);
}

/// Integral of the line alpha + E s from a to b.
inline double line_integral(double alpha, double E, double a, double b) {
  return alpha * (b - a) + 0.5 * E * (b - a) * (b + a);
}

}  // namespace tilted_detail

/// The pieces of one edge's tilted law for a step: previous force t^n at previous strain
/// eps^n. Writes kTiltedPieceDoubles doubles to `out`. Needs band.plateau_slope > 0.
inline void tilted_pieces(const TensileBand& band, double previous_force, double previous_strain,
                          double* out) {
  using namespace tilted_detail;
  const double alpha = previous_force - band.plateau_slope * previous_strain;
  const Interval upper = line_above_curve(band, /*loading=*/false, alpha);  // inside or above the band
  double u1 = 0.0, u2 = 0.0;
  if (upper.first <= upper.second) {
    u1 = upper.first;
    u2 = upper.second;
  }
  // Above the loading curve, within the interval above the unloading one (tL >= tU: a subset,
  // kept one after rounding); empty as l1 = l2 = u2.
  const Interval lower = line_above_curve(band, /*loading=*/true, alpha);
  double l1 = u2, l2 = u2;
  if (lower.first <= lower.second) {
    l1 = std::clamp(lower.first, u1, u2);
    l2 = std::clamp(lower.second, l1, u2);
    if (!(l1 < l2)) l1 = l2 = u2;
  }
  out[0] = alpha;
  out[1] = u1;
  out[2] = l1;
  out[3] = l2;
  out[4] = u2;
}

/// True when `material` asks for the tilted plateau (both directions share R).
inline bool tilted_plateau(const FabricMaterial& material) {
  return material.tensile[0].plateau_slope > 0.0 || material.tensile[1].plateau_slope > 0.0;
}

/// The piece of the tilted law a strain is on.
enum class TiltedPiece : std::uint8_t { slack, unloading, line, loading };

inline TiltedPiece tilted_piece(const double* pieces, double strain) {
  if (!(strain > 0.0)) return TiltedPiece::slack;
  if (strain < pieces[1]) return TiltedPiece::unloading;
  if (strain < pieces[2]) return TiltedPiece::line;
  if (strain <= pieces[3] && pieces[2] < pieces[3]) return TiltedPiece::loading;
  return strain <= pieces[4] ? TiltedPiece::line : TiltedPiece::unloading;
}

/// Force, slope and potential of the tilted law at `strain` from its pieces (tilted_pieces).
/// On the line no curve is evaluated; on a curve one (one pow), and the potential's constants
/// come from the curves' values at the boundaries, which are the line's there.
inline ReturnMapped tilted_return_map(const TensileBand& band, const double* pieces,
                                      double strain) {
  using namespace tilted_detail;
  ReturnMapped r;
  const TiltedPiece piece = tilted_piece(pieces, strain);
  if (piece == TiltedPiece::slack) return r;
  const double alpha = pieces[0], E = band.plateau_slope;
  const double u1 = pieces[1], l1 = pieces[2], l2 = pieces[3], u2 = pieces[4];
  auto line = [&](double s) { return alpha + E * s; };
  if (piece == TiltedPiece::unloading && strain < u1) {
    r.force = band.unloading(strain);
    r.slope = curve_slope(band, /*loading=*/false, strain, r.force);
    r.potential = curve_integral(band, /*loading=*/false, strain, r.force);
    return r;
  }
  const double at_u1 = curve_integral(band, /*loading=*/false, u1, line(u1));
  if (piece == TiltedPiece::line && strain < l1) {
    r.force = line(strain);
    r.slope = E;
    r.potential = at_u1 + line_integral(alpha, E, u1, strain);
    return r;
  }
  const double at_l1 = at_u1 + line_integral(alpha, E, u1, l1);
  const double loading_l1 = curve_integral(band, /*loading=*/true, l1, line(l1));
  if (piece == TiltedPiece::loading) {
    r.force = band.loading(strain);
    r.slope = curve_slope(band, /*loading=*/true, strain, r.force);
    r.potential = at_l1 + curve_integral(band, /*loading=*/true, strain, r.force) - loading_l1;
    return r;
  }
  const double at_l2 =
      l1 < l2 ? at_l1 + curve_integral(band, /*loading=*/true, l2, line(l2)) - loading_l1 : at_l1;
  if (piece == TiltedPiece::line) {
    r.force = line(strain);
    r.slope = E;
    r.potential = at_l2 + line_integral(alpha, E, l2, strain);
    return r;
  }
  r.force = band.unloading(strain);  // beyond u2
  r.slope = curve_slope(band, /*loading=*/false, strain, r.force);
  r.potential = at_l2 + line_integral(alpha, E, l2, u2) +
                curve_integral(band, /*loading=*/false, strain, r.force) -
                curve_integral(band, /*loading=*/false, u2, line(u2));
  return r;
}

}  // namespace clothbench::kernels
