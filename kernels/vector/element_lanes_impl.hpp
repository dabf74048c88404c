// The element-lane kernels of element_lanes.hpp, templated on an xsimd architecture. Included
// only by element_lanes_<isa>.cpp, each compiled with its instruction set's flags; everything
// here sits in an unnamed namespace so no symbol is shared between those translation units.
//
// Each function mirrors its scalar reference branch for branch (potential_elements.hpp
// fast_return_map, element_geometry.hpp turning_angle, kes_material.hpp bands): every branch
// is evaluated for all lanes and the scalar code's choice is made with masks (select).
// Branches that need extra transcendental calls (a tension's plateau and unloading
// breakpoints, atan2 of a turning angle beyond the series) run only when a lane of the group
// takes them. The lanes multiply by quotients of the band's constants formed once per call,
// share one log between a force's two breakpoints, form the triple's three coefficients over
// one divisor, and take a bending potential's terms at its breakpoints from the step's cache
// (bending_offloading), where the reference divides and integrates; with xsimd's exp, log,
// expm1 and atan2 against libm's, that makes them differ from the reference by a few ulp,
// never in a branch's formula.
#pragma once

#include <xsimd/xsimd.hpp>

#include "kernels/vector/element_lanes.hpp"
#include "kernels/vector/particle_lanes_impl.hpp"

namespace clothbench::kernels::vector {
namespace {

template <class Arch>
struct Lanes {
  using V = xsimd::batch<double, Arch>;
  using M = xsimd::batch_bool<double, Arch>;
  static constexpr int kWidth = static_cast<int>(V::size);

  /// Lane-wise choice between the band parameters of direction 0 and 1.
  static V pick(const M& direction_one, double one, double zero) {
    return xsimd::select(direction_one, V(one), V(zero));
  }

  /// Lane l of the vector from particle slot `from` to slot `to`, split over x, y, z.
  static void gather_difference(const double* position, std::int64_t from, std::int64_t to, int l,
                                double* x, double* y, double* z) {
    const double* a = position + 3 * from;
    const double* b = position + 3 * to;
    x[l] = b[0] - a[0];
    y[l] = b[1] - a[1];
    z[l] = b[2] - a[2];
  }

  /// The per-element inputs both loops gather, one lane each: rest length and width (m), the
  /// previous force (N/m) or moment (N), and the direction (id % 2) as a double.
  struct ElementInputs {
    alignas(64) double rest[kWidth], width[kWidth], previous[kWidth], direction[kWidth];
    void gather(int l, std::int64_t id, const float* rest_of, const float* width_of,
                const double* previous_of) {
      rest[l] = rest_of[id];
      width[l] = width_of[id];
      previous[l] = previous_of[id];
      direction[l] = static_cast<double>(id % 2);
    }
    /// A triple's: its rest spacing and width are the means of its two edges' (in float, as
    /// ClothMesh::triple_rest and triple_width form them), `before` the id of the edge into its
    /// centre.
    void gather_triple(int l, std::int64_t id, std::int64_t before, const float* edge_rest,
                       const float* edge_width, const double* previous_of) {
      rest[l] = 0.5f * (edge_rest[before] + edge_rest[id]);
      width[l] = 0.5f * (edge_width[before] + edge_width[id]);
      previous[l] = previous_of[id];
      direction[l] = static_cast<double>(id % 2);
    }
  };

  /// ReturnMapped of potential_elements.hpp without the slope: force (moment) and potential.
  struct Mapped {
    V force, potential;
  };
  /// The potentials of the branches off the loading curve.
  struct OffLoading {
    V plateau, unloading;
  };
  /// The branch choice of fast_return_map, given the band's curves at the strain (curvature):
  /// a lane whose previous value is not below `upper` is loading; otherwise it is on the
  /// plateau (previous value not below `lower`: the previous value is kept) or unloading
  /// (follows `lower`); a lane without positive strain gives zero. off_loading() returns the
  /// plateau and unloading potentials and runs only when a positive lane leaves the loading
  /// curve (its breakpoints cost transcendental calls).
  template <class OffLoadingPotentials>
  static Mapped return_map(const M& positive, const V& prev, const V& upper, const V& lower,
                           const V& loading_potential, OffLoadingPotentials&& off_loading) {
    const M loading = !(prev < upper);
    V force = upper, potential = loading_potential;
    if (xsimd::any(positive & !loading)) {
      const OffLoading off = off_loading();
      const M plateau = !(prev < lower);
      force = xsimd::select(loading, upper, xsimd::select(plateau, prev, lower));
      potential = xsimd::select(loading, loading_potential,
                                xsimd::select(plateau, off.plateau, off.unloading));
    }
    return Mapped{xsimd::select(positive, force, V(0.0)),
                  xsimd::select(positive, potential, V(0.0))};
  }

  // --- tension (TensileBand, fast_return_map<TensileBand>) -----------------------------
  /// One direction's band with the quotients its formulas use, formed once per call (the
  /// lanes multiply by them instead of dividing: the divider is the lanes' slowest unit).
  struct TensileConstants {
    double fm, emt, p, q;
    double inv_emt, inv_fm, inv_p, inv_q;  ///< 1/EMT, 1/Fm, 1/p, 1/q
    double slope, inv_slope;               ///< Fm p / EMT (the linear continuation), its inverse
    double inv_p1, inv_q1;                 ///< 1/(p + 1), 1/(q + 1)
    double base_p, base_q;                 ///< Fm EMT/(p + 1), Fm EMT/(q + 1): integrals at EMT
    explicit TensileConstants(const TensileLanesBand& b)
        : fm(b.fm), emt(b.emt), p(b.p), q(b.q), inv_emt(1.0 / b.emt), inv_fm(1.0 / b.fm),
          inv_p(1.0 / b.p), inv_q(1.0 / b.q), slope(b.fm * b.p / b.emt),
          inv_slope(b.emt / (b.fm * b.p)), inv_p1(1.0 / (b.p + 1.0)), inv_q1(1.0 / (b.q + 1.0)),
          base_p(b.fm * b.emt / (b.p + 1.0)), base_q(b.fm * b.emt / (b.q + 1.0)) {}
  };
  struct Tensile {
    V fm, emt, p, q, inv_emt, inv_fm, inv_p, inv_q, slope, inv_slope, inv_p1, inv_q1, base_p,
        base_q;
    Tensile(const M& one, const TensileConstants& c1, const TensileConstants& c0)
        : fm(pick(one, c1.fm, c0.fm)), emt(pick(one, c1.emt, c0.emt)), p(pick(one, c1.p, c0.p)),
          q(pick(one, c1.q, c0.q)), inv_emt(pick(one, c1.inv_emt, c0.inv_emt)),
          inv_fm(pick(one, c1.inv_fm, c0.inv_fm)), inv_p(pick(one, c1.inv_p, c0.inv_p)),
          inv_q(pick(one, c1.inv_q, c0.inv_q)), slope(pick(one, c1.slope, c0.slope)),
          inv_slope(pick(one, c1.inv_slope, c0.inv_slope)),
          inv_p1(pick(one, c1.inv_p1, c0.inv_p1)), inv_q1(pick(one, c1.inv_q1, c0.inv_q1)),
          base_p(pick(one, c1.base_p, c0.base_p)), base_q(pick(one, c1.base_q, c0.base_q)) {}
  };
  /// power_integral(eps, exponent) of TensileBand for eps >= EMT (its linear continuation);
  /// `base` = Fm EMT/(exponent + 1).
  static V tensile_linear_integral(const Tensile& t, const V& eps, const V& base) {
    const V beyond = eps - t.emt;
    return base + t.fm * beyond + V(0.5) * t.slope * beyond * beyond;
  }
  /// power_inverse(force, p) and power_inverse(force, q) of TensileBand: one log for both.
  static void tensile_inverses(const Tensile& t, const V& force, V& at_p, V& at_q) {
    const V linear = t.emt + (force - t.fm) * t.inv_slope;
    // The log of a non-positive force is NaN, which xsimd turns into an integer inside its exp:
    // a float-to-integer conversion out of range, undefined behaviour. Such lanes are selected
    // away below; they take 1 instead. pow(r, 1/e) = exp(log(r)/e) for r > 0, as xsimd's pow.
    const M positive = force > V(0.0);
    const V log_ratio = xsimd::log(xsimd::select(positive, force * t.inv_fm, V(1.0)));
    const M beyond = force >= t.fm;
    at_p = xsimd::select(positive,
                         xsimd::select(beyond, linear, t.emt * xsimd::exp(t.inv_p * log_ratio)),
                         V(0.0));
    at_q = xsimd::select(positive,
                         xsimd::select(beyond, linear, t.emt * xsimd::exp(t.inv_q * log_ratio)),
                         V(0.0));
  }

  static double edges(const EdgeLanesArgs& args, const std::int32_t* ids, std::int64_t count) {
    alignas(64) double dx[kWidth], dy[kWidth], dz[kWidth], out_density[kWidth], out_energy[kWidth];
    ElementInputs in;
    const TensileConstants c0(args.band[0]), c1(args.band[1]);
    double sum = 0.0;
    for (std::int64_t g = 0; g < count; g += kWidth) {
      const int live = count - g < kWidth ? static_cast<int>(count - g) : kWidth;
      for (int l = 0; l < kWidth; ++l) {  // gather: the edge's vector x_b - x_a, per lane
        const std::int64_t id = ids[g + (l < live ? l : live - 1)];
        gather_difference(args.position, id / 2, args.next[id], l, dx, dy, dz);
        in.gather(l, id, args.rest, args.width, args.previous_force);
      }
      const M one = V::load_aligned(in.direction) > V(0.5);
      const Tensile t(one, c1, c0);
      const V ex = V::load_aligned(dx), ey = V::load_aligned(dy), ez = V::load_aligned(dz);
      const V length = xsimd::sqrt(ex * ex + ey * ey + ez * ez);
      const V l0 = V::load_aligned(in.rest), w = V::load_aligned(in.width);
      const V prev = V::load_aligned(in.previous);
      const V strain = length / l0 - V(1.0);
      // curves(strain)
      const M positive = strain > V(0.0);
      const M beyond = strain >= t.emt;
      const V linear = t.fm + t.slope * (strain - t.emt);
      // Lanes without positive strain are zeroed by return_map; their log takes 1, not a
      // non-positive ratio, whose NaN exp would convert to an integer (see tensile_inverses).
      const V log_ratio = xsimd::log(xsimd::select(positive, strain * t.inv_emt, V(1.0)));
      const V upper_power = t.fm * xsimd::exp(t.p * log_ratio);
      const V lower_power = t.fm * xsimd::exp(t.q * log_ratio);
      const V upper = xsimd::select(beyond, linear, upper_power);
      const V lower = xsimd::select(beyond, linear, lower_power);
      // loading branch (below EMT from the curve's value: no pow; a lane without positive
      // strain is zeroed by return_map)
      const V loading_potential =
          xsimd::select(strain < t.emt, upper * strain * t.inv_p1,
                        tensile_linear_integral(t, strain, t.base_p));
      const Mapped mapped = return_map(positive, prev, upper, lower, loading_potential, [&] {
        // plateau or unloading: the breakpoints of the previous force
        V lower_bp, at_q;
        tensile_inverses(t, prev, lower_bp, at_q);
        const V upper_bp = xsimd::max(lower_bp, at_q);
        // below EMT the integrals from the curves' values, as fast_return_map takes them
        const V lower_potential = xsimd::select(lower_bp < t.emt, prev * lower_bp * t.inv_p1,
                                                tensile_linear_integral(t, lower_bp, t.base_p));
        const V upper_integral = xsimd::select(upper_bp < t.emt, prev * upper_bp * t.inv_q1,
                                               tensile_linear_integral(t, upper_bp, t.base_q));
        const V strain_integral = xsimd::select(strain < t.emt, lower * strain * t.inv_q1,
                                                tensile_linear_integral(t, strain, t.base_q));
        return OffLoading{
            lower_potential + prev * (strain - lower_bp),
            lower_potential + prev * (upper_bp - lower_bp) - upper_integral + strain_integral};
      });
      const V energy = w * l0 * mapped.potential;
      const V density = xsimd::select(length > V(0.0), w * mapped.force / length, V(0.0));
      density.store_aligned(out_density);
      energy.store_aligned(out_energy);
      for (int l = 0; l < live; ++l) {
        args.force_density[ids[g + l]] = out_density[l];
        sum += out_energy[l];
      }
    }
    return sum;
  }

  // --- bending (BendingBand, fast_return_map<BendingBand> with the step's cache) ---------
  struct Bending {
    V b, hb, kappa0, onset, at_onset;
    V inv_kappa0;  ///< 1/kappa0, formed once per call
  };
  /// ramp_integral(x) = x + exp(-x) - 1, by its series below 0.1; `em1` = expm1(-x).
  static V ramp(const RampSeries& series, const V& x, const V& em1) {
    V sum(0.0);
    for (double c : series.coefficient) sum = sum * x + V(c);
    return xsimd::select(x < V(0.1), sum * x * x, x + em1);
  }
  /// loading_integral(kappa); `em1` = expm1(-kappa / kappa0) (as -(kappa * (1/kappa0))).
  static V bending_loading_integral(const Bending& b, const RampSeries& s, const V& kappa,
                                    const V& em1) {
    const V value = V(0.5) * b.b * kappa * kappa + b.hb * b.kappa0 * ramp(s, kappa * b.inv_kappa0, em1);
    return xsimd::select(kappa > V(0.0), value, V(0.0));
  }
  /// unloading_integral(kappa); `em1` = expm1(-kappa / kappa0).
  static V bending_unloading_integral(const Bending& b, const RampSeries& s, const V& kappa,
                                      const V& em1) {
    const V value = V(0.5) * b.b * kappa * kappa - b.hb * b.kappa0 * ramp(s, kappa * b.inv_kappa0, em1) -
                    b.at_onset;
    return xsimd::select(kappa > b.onset, value, V(0.0));
  }

  static double triples(const TripleLanesArgs& args, const std::int32_t* ids, std::int64_t count) {
    alignas(64) double e1x[kWidth], e1y[kWidth], e1z[kWidth], e2x[kWidth], e2y[kWidth], e2z[kWidth];
    alignas(64) double plateau_base[kWidth], unloading_base[kWidth];
    ElementInputs in;
    alignas(64) double out_a[kWidth], out_bc[kWidth], out_c[kWidth], out_energy[kWidth];
    const double inv_kappa0[2] = {1.0 / args.band[0].kappa0, 1.0 / args.band[1].kappa0};
    double sum = 0.0;
    for (std::int64_t g = 0; g < count; g += kWidth) {
      const int live = count - g < kWidth ? static_cast<int>(count - g) : kWidth;
      for (int l = 0; l < kWidth; ++l) {  // gather: e1 = x_c - x_a, e2 = x_b - x_c per lane
        const std::int64_t id = ids[g + (l < live ? l : live - 1)];
        gather_difference(args.position, args.prev[id], id / 2, l, e1x, e1y, e1z);
        gather_difference(args.position, id / 2, args.next[id], l, e2x, e2y, e2z);
        in.gather_triple(l, id, 2 * std::int64_t{args.prev[id]} + id % 2, args.edge_rest,
                         args.edge_width, args.previous_moment);
        plateau_base[l] = args.offloading[2 * id];
        unloading_base[l] = args.offloading[2 * id + 1];
      }
      const M one = V::load_aligned(in.direction) > V(0.5);
      const Bending bb{pick(one, args.band[1].b, args.band[0].b),
                       pick(one, args.band[1].hb, args.band[0].hb),
                       pick(one, args.band[1].kappa0, args.band[0].kappa0),
                       pick(one, args.band[1].onset, args.band[0].onset),
                       pick(one, args.band[1].at_onset, args.band[0].at_onset),
                       pick(one, inv_kappa0[1], inv_kappa0[0])};
      // turning_angle(e1, e2)
      const V ax = V::load_aligned(e1x), ay = V::load_aligned(e1y), az = V::load_aligned(e1z);
      const V bx = V::load_aligned(e2x), by = V::load_aligned(e2y), bz = V::load_aligned(e2z);
      const V n1sq = ax * ax + ay * ay + az * az;
      const V n2sq = bx * bx + by * by + bz * bz;
      const V cx = ay * bz - az * by, cy = az * bx - ax * bz, cz = ax * by - ay * bx;
      const V cross = xsimd::sqrt(cx * cx + cy * cy + cz * cz);
      const V dot = ax * bx + ay * by + az * bz;
      const M series = (dot > V(0.0)) & (cross < V(1e-3) * dot);
      const V r = cross / dot, r2 = r * r;
      V theta = r * (V(1.0) - r2 * (V(1.0) / V(3.0) - r2 * (V(1.0) / V(5.0) - r2 / V(7.0))));
      if (!xsimd::all(series)) theta = xsimd::select(series, theta, xsimd::atan2(cross, dot));
      const V n12 = xsimd::sqrt(n1sq * n2sq);
      const M bent = cross > V(1e-12) * n12;  // !degenerate (kStraightSine)
      // The reference's cos / (sin |e1|^2), 1 / (sin |e1||e2|) and cos / (sin |e2|^2) with
      // sin = cross / (|e1||e2|), cos = dot / (|e1||e2|), over one common divisor.
      const V n1sq_n2sq = n1sq * n2sq;
      const V inverse = V(1.0) / (cross * n1sq_n2sq);
      const V coef_a = xsimd::select(bent, dot * n2sq * inverse, V(0.0));
      const V coef_bc = xsimd::select(bent, n1sq_n2sq * inverse, V(0.0));
      const V coef_c = xsimd::select(bent, dot * n1sq * inverse, V(0.0));
      // fast_return_map(bending, previous, curvature, the step's cache)
      const V l0 = V::load_aligned(in.rest), w = V::load_aligned(in.width);
      const V prev = V::load_aligned(in.previous);
      const V kappa = theta / l0;
      const M positive = kappa > V(0.0);
      const V em1 = xsimd::expm1(-(kappa * bb.inv_kappa0));
      const V upper = bb.b * kappa - bb.hb * em1;
      const V lower = xsimd::select(kappa > bb.onset, xsimd::max(V(0.0), bb.b * kappa + bb.hb * em1),
                                    V(0.0));
      const V loading_potential = bending_loading_integral(bb, args.ramp, kappa, em1);
      const Mapped mapped = return_map(positive, prev, upper, lower, loading_potential, [&] {
        // plateau or unloading, from the step's cached constants (bending_offloading)
        return OffLoading{V::load_aligned(plateau_base) + prev * kappa,
                          V::load_aligned(unloading_base) +
                              bending_unloading_integral(bb, args.ramp, kappa, em1)};
      });
      const V energy = w * l0 * mapped.potential;
      const V wm = w * mapped.force;
      (wm * coef_a).store_aligned(out_a);
      (wm * coef_bc).store_aligned(out_bc);
      (wm * coef_c).store_aligned(out_c);
      energy.store_aligned(out_energy);
      for (int l = 0; l < live; ++l) {
        double* k = args.coefficients + 3 * static_cast<std::int64_t>(ids[g + l]);
        k[0] = out_a[l];
        k[1] = out_bc[l];
        k[2] = out_c[l];
        sum += out_energy[l];
      }
    }
    return sum;
  }
};

/// The kernels of `Arch` as an ElementLanesKernels row.
template <class Arch>
ElementLanesKernels lanes_kernels(const char* isa) {
  return ElementLanesKernels{isa, Lanes<Arch>::kWidth, &Lanes<Arch>::edges, &Lanes<Arch>::triples,
                             &ParticleLanes<Arch>::particles};
}

}  // namespace
}  // namespace clothbench::kernels::vector
