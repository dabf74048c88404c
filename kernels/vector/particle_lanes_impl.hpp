// The particle loop of the vector twin (ElementLanesKernels::particles), templated on an xsimd
// architecture; included by element_lanes_impl.hpp only (same one-TU-per-ISA rule).
//
// It mirrors PotentialObjective::evaluate's particle body and gather_elastic_at
// (potential_elements.hpp) in the reference's operation order: per lane, the neighbourhood of
// the particle along each direction is resolved in scalar integer code (which neighbours
// exist, which elements are active, element ids), then positions and element coefficients are
// gathered into lanes and combined. An absent neighbour stands in as the particle itself and
// an absent element's coefficients as zero, so every term the reference skips adds exactly
// zero here. The terms that stay scalar (contact, scripted forces, ghost children) arrive in
// `extra`. Sums are formed in slot order, as the reference's tile accumulator does.
#pragma once

#include <immintrin.h>
#include <xsimd/xsimd.hpp>

#include <type_traits>

#include "kernels/vector/element_lanes.hpp"

namespace clothbench::kernels::vector {
namespace {

template <class Arch>
struct ParticleLanes {
  using V = xsimd::batch<double, Arch>;
  using I = xsimd::batch<std::int64_t, Arch>;
  using M = xsimd::batch_bool<double, Arch>;
  static constexpr int kWidth = static_cast<int>(V::size);

  /// Lanes of xyz vectors.
  struct V3 {
    V x, y, z;
    V3 operator-(const V3& o) const { return {x - o.x, y - o.y, z - o.z}; }
    V3 operator+(const V3& o) const { return {x + o.x, y + o.y, z + o.z}; }
    friend V3 operator*(const V& k, const V3& v) { return {k * v.x, k * v.y, k * v.z}; }
    [[nodiscard]] V dot(const V3& o) const { return x * o.x + y * o.y + z * o.z; }
  };

  /// The xyz entries of an interleaved array at lane offsets `at` (3 * slot). Under AVX-512,
  /// lanes of consecutive slots (most of a tile: a block's row, and its neighbours along
  /// either direction) are read as three whole vectors and split into x, y and z by
  /// permutations instead of 24 single loads; the same values either way.
  static V3 gather3(const double* values, const I& at) {
    if constexpr (std::is_same_v<Arch, xsimd::avx512f>) {
      const __m512i offsets = at;
      const __m512i first = _mm512_broadcastq_epi64(_mm512_castsi512_si128(offsets));
      const __m512i run = _mm512_add_epi64(first, _mm512_setr_epi64(0, 3, 6, 9, 12, 15, 18, 21));
      if (_mm512_cmpeq_epi64_mask(offsets, run) == 0xFF) {
        const double* from = values + _mm_cvtsi128_si64(_mm512_castsi512_si128(offsets));
        // x0 y0 z0 x1 y1 z1 x2 y2 | z2 x3 y3 z3 x4 y4 z4 x5 | y5 z5 x6 y6 z6 x7 y7 z7
        const __m512d a = _mm512_loadu_pd(from), b = _mm512_loadu_pd(from + 8);
        const __m512d c = _mm512_loadu_pd(from + 16);
        const auto split = [&](__m512i in_ab, __m512i in_c) {
          return _mm512_permutex2var_pd(_mm512_permutex2var_pd(a, in_ab, b), in_c, c);
        };
        return {split(_mm512_setr_epi64(0, 3, 6, 9, 12, 15, 0, 0),
                      _mm512_setr_epi64(0, 1, 2, 3, 4, 5, 10, 13)),
                split(_mm512_setr_epi64(1, 4, 7, 10, 13, 0, 0, 0),
                      _mm512_setr_epi64(0, 1, 2, 3, 4, 8, 11, 14)),
                split(_mm512_setr_epi64(2, 5, 8, 11, 14, 0, 0, 0),
                      _mm512_setr_epi64(0, 1, 2, 3, 4, 9, 12, 15))};
      }
    }
    return {V::gather(values, at), V::gather(values + 1, at), V::gather(values + 2, at)};
  }
  static M mask(const double* ones) { return V::load_aligned(ones) > V(0.5); }
  /// Lane-wise `coefficient[at]` where `on`, zero elsewhere.
  static V coefficient(const double* values, const I& at, const double* on) {
    return xsimd::select(mask(on), V::gather(values, at), V(0.0));
  }

  /// One direction's neighbourhood of each lane's particle s: offsets 3 * slot of the next and
  /// previous nodes n, p and of the nodes beyond them along the triples through n and p (s
  /// itself where absent), element ids (id = 2s + d, tn = 2n + d, ep = 2p + d; s's own where
  /// absent) and which of the five elements gather_elastic_at adds exist (1 or 0).
  struct Side {
    alignas(64) std::int64_t n[kWidth], p[kWidth], nn[kWidth], pp[kWidth];
    alignas(64) std::int64_t id[kWidth], tn[kWidth], ep[kWidth];
    alignas(64) double edge_out[kWidth], edge_in[kWidth];                             // id, ep
    alignas(64) double triple_next[kWidth], triple_prev[kWidth], triple_own[kWidth];  // tn, ep, id

    void fill(const ParticleLanesArgs& a, int l, std::int64_t s, int d) {
      const std::int64_t own = 2 * s + d;
      const std::int32_t next = a.next[own], prev = a.prev[own];
      const std::int64_t ns = next >= 0 ? next : s, ps = prev >= 0 ? prev : s;
      const std::int64_t t_next = 2 * ns + d, e_prev = 2 * ps + d;
      const bool has_triple_next = next >= 0 && a.triple_active[t_next] && a.prev[t_next] == s;
      const bool ends_here = prev >= 0 && a.next[e_prev] == s;
      const bool has_triple_prev = ends_here && a.triple_active[e_prev];
      n[l] = 3 * ns;
      p[l] = 3 * ps;
      nn[l] = 3 * (has_triple_next ? a.next[t_next] : ns);
      pp[l] = 3 * (has_triple_prev ? a.prev[e_prev] : ps);
      id[l] = own;
      tn[l] = t_next;
      ep[l] = e_prev;
      edge_out[l] = next >= 0 && a.edge_active[own] ? 1.0 : 0.0;
      edge_in[l] = ends_here && a.edge_active[e_prev] ? 1.0 : 0.0;
      triple_next[l] = has_triple_next ? 1.0 : 0.0;
      triple_prev[l] = has_triple_prev ? 1.0 : 0.0;
      triple_own[l] = a.triple_active[own] ? 1.0 : 0.0;
    }

    /// gather_elastic_at's terms of this direction, added to g in its order.
    void add_elastic(const ParticleLanesArgs& a, const V3& xs, V3& g) const {
      const I at_id = I::load_aligned(id), at_tn = I::load_aligned(tn);
      const I at_ep = I::load_aligned(ep);
      const V3 xn = gather3(a.position, I::load_aligned(n));
      const V3 xp = gather3(a.position, I::load_aligned(p));
      const V3 to_next = xn - xs, from_prev = xs - xp;
      g = g - coefficient(a.edge_scratch, at_id, edge_out) * to_next;
      const I k_tn = at_tn + at_tn + at_tn, k_ep = at_ep + at_ep + at_ep;
      const I k_id = at_id + at_id + at_id;
      const V k0n = coefficient(a.triple_scratch, k_tn, triple_next);
      const V k1n = coefficient(a.triple_scratch + 1, k_tn, triple_next);
      g = g + ((-k0n) * to_next + k1n * (gather3(a.position, I::load_aligned(nn)) - xn));
      g = g + coefficient(a.edge_scratch, at_ep, edge_in) * from_prev;
      const V k1p = coefficient(a.triple_scratch + 1, k_ep, triple_prev);
      const V k2p = coefficient(a.triple_scratch + 2, k_ep, triple_prev);
      g = g + ((-k1p) * (xp - gather3(a.position, I::load_aligned(pp))) + k2p * from_prev);
      const V k0 = coefficient(a.triple_scratch, k_id, triple_own);
      const V k1 = coefficient(a.triple_scratch + 1, k_id, triple_own);
      const V k2 = coefficient(a.triple_scratch + 2, k_id, triple_own);
      g = g + ((k0 + k1) * from_prev - (k1 + k2) * to_next);
    }
  };

  /// The per-particle inputs read without gathers of neighbours, one lane each.
  struct Own {
    alignas(64) std::int64_t at[kWidth];  // 3 * slot
    alignas(64) double mass[kWidth], free[kWidth];
    alignas(64) double extra[4][kWidth];
    alignas(64) double block[6][kWidth];  // the preconditioner's symmetric block

    void fill(const ParticleLanesArgs& a, int l, std::int64_t s, const double* extra_of) {
      at[l] = 3 * s;
      mass[l] = a.mass[s];
      free[l] = (a.flags[s] & (kLanesActive | kLanesPinned)) == kLanesActive ? 1.0 : 0.0;
      for (int c = 0; c < 4; ++c) extra[c][l] = extra_of != nullptr ? extra_of[c] : 0.0;
      for (int c = 0; c < 6; ++c) block[c][l] = a.preconditioner[6 * s + c];
    }
  };

  static ParticleLanesSums particles(const ParticleLanesArgs& a, const std::int32_t* slots,
                                     const double* extra, std::int64_t count) {
    Own own;
    Side side[2];
    alignas(64) double out[3][kWidth], energy[kWidth], ratio[kWidth], slope[kWidth];
    alignas(64) double grad_dot_z[kWidth], grad_old_dot_z[kWidth];
    const V dt2(a.dt_squared), g_ref(a.gravity_reference);
    const V3 gravity{V(a.gravity[0]), V(a.gravity[1]), V(a.gravity[2])};
    ParticleLanesSums sums;
    for (std::int64_t g0 = 0; g0 < count; g0 += kWidth) {
      const int live = count - g0 < kWidth ? static_cast<int>(count - g0) : kWidth;
      for (int l = 0; l < kWidth; ++l) {
        const std::int64_t q = g0 + (l < live ? l : live - 1);
        own.fill(a, l, slots[q], extra != nullptr ? extra + 4 * q : nullptr);
        for (int d = 0; d < 2; ++d) side[d].fill(a, l, slots[q], d);
      }
      const I at = I::load_aligned(own.at);
      const V3 xs = gather3(a.position, at);
      const V m = V::load_aligned(own.mass);
      const V3 offset = xs - gather3(a.target, at);
      const V3 extra_g{V::load_aligned(own.extra[0]), V::load_aligned(own.extra[1]),
                       V::load_aligned(own.extra[2])};
      const V e = V(0.5) * m / dt2 * offset.dot(offset) -
                  m * gravity.dot(xs - gather3(a.step_start, at)) + V::load_aligned(own.extra[3]);
      V3 elastic{V(0.0), V(0.0), V(0.0)};
      for (const Side& s : side) s.add_elastic(a, xs, elastic);
      const V3 g = ((m / dt2) * offset - m * gravity + extra_g) + elastic;
      V b[6];
      for (int c = 0; c < 6; ++c) b[c] = V::load_aligned(own.block[c]);
      const V3 z{b[0] * g.x + b[1] * g.y + b[2] * g.z, b[1] * g.x + b[3] * g.y + b[4] * g.z,
                 b[2] * g.x + b[4] * g.y + b[5] * g.z};
      const M free = mask(own.free);
      xsimd::select(free, g.x, V(0.0)).store_aligned(out[0]);
      xsimd::select(free, g.y, V(0.0)).store_aligned(out[1]);
      xsimd::select(free, g.z, V(0.0)).store_aligned(out[2]);
      e.store_aligned(energy);
      (xsimd::sqrt(g.dot(g)) / (m * g_ref)).store_aligned(ratio);
      g.dot(gather3(a.direction, at)).store_aligned(slope);
      g.dot(z).store_aligned(grad_dot_z);
      if (a.gradient_old != nullptr) {  // nonlinear CG's g_old; none under Newton
        gather3(a.gradient_old, at).dot(z).store_aligned(grad_old_dot_z);
      } else {
        V(0.0).store_aligned(grad_old_dot_z);
      }
      for (int l = 0; l < live; ++l) {
        double* to = a.gradient + own.at[l];
        for (int c = 0; c < 3; ++c) to[c] = out[c][l];
        if (own.free[l] == 0.0) continue;
        sums.energy += energy[l];
        sums.residual_sq += ratio[l] * ratio[l];
        sums.residual_max = sums.residual_max < ratio[l] ? ratio[l] : sums.residual_max;
        sums.slope += slope[l];
        sums.grad_dot_z += grad_dot_z[l];
        sums.grad_old_dot_z += grad_old_dot_z[l];
      }
    }
    return sums;
  }
};

}  // namespace
}  // namespace clothbench::kernels::vector
