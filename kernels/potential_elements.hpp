// Element terms of the `potential` formulation (MODEL.md 4B): for each edge and triple the
// return-mapped force and its potential, from positions given by an accessor so that the
// analytic loops and the local numeric gradient share one definition.
#pragma once

#include <cstdint>
#include <type_traits>
#include <utility>
#include <vector>

#include "kernels/ghost_nodes.hpp"
#include "kernels/loop_bytes.hpp"
#include "kernels/step_context.hpp"
#include "kernels/tilted_plateau.hpp"

namespace clothbench::kernels {

// What the element terms below read, for the LoopBytes of the loops that call them
// (loop_bytes.hpp: each entry once per loop, positions as a slot's share per id).
/// Per edge id, edge_term besides positions: next, rest length and width (floats), the
/// previous force.
inline constexpr double kEdgeTermData = bytes::kIndex + 2 * bytes::kFloat + bytes::kDouble;
/// Per edge id, all edge_term reads: kEdgeTermData and its share of the positions.
inline constexpr double kEdgeTermRead = kEdgeTermData + bytes::kSlotShare * bytes::kVector3;
/// Per triple id, triple_term besides positions: prev and next, rest spacing and width
/// (floats), the previous moment and its two breakpoints.
inline constexpr double kTripleTermData =
    2 * bytes::kIndex + 2 * bytes::kFloat + 3 * bytes::kDouble;
/// Per triple id, all triple_term reads.
inline constexpr double kTripleTermRead = kTripleTermData + bytes::kSlotShare * bytes::kVector3;
/// Per particle, gather_elastic_gradient: its position, and of its slot's two ids next, prev,
/// both element flags and the scratch the element loops wrote (1 + 3 doubles).
inline constexpr double kGatherElasticRead =
    bytes::kVector3 +
    bytes::kIdsPerSlot * (2 * bytes::kIndex + 2 * bytes::kFlag + 4 * bytes::kDouble);

/// The branch of its hysteresis band an element in tension (or bending) is on, decided by the
/// curves at its strain and its previous force: loading where the previous force is not below
/// the loading curve, the plateau where it is not below the unloading curve, else unloading.
/// `slack` (no strain) is for the caller to decide; fast_return_map and the edge census of
/// Newton's log both take their branch from here.
enum class BandBranch : std::uint8_t { slack = 0, loading = 1, plateau = 2, unloading = 3 };
inline BandBranch band_branch(const BandCurves& c, double previous) {
  if (!(previous < c.upper)) return BandBranch::loading;
  return !(previous < c.lower) ? BandBranch::plateau : BandBranch::unloading;
}

/// Return mapping evaluated regime first: the curves at `strain` (one log and two exp for
/// tension, one expm1 for bending) decide the branch, and the breakpoints (curve inverses) are
/// only needed off the loading branch. `cached` holds {lower, upper} breakpoints computed once
/// per step, or is null to compute them here. Same values as return_map() of kes_material.hpp.
template <class Band>
inline ReturnMapped fast_return_map(const Band& band, double previous, double strain,
                                    const double* cached) {
  constexpr bool tension = std::is_same_v<Band, TensileBand>;
  ReturnMapped r;
  if (!(strain > 0.0)) return r;
  const BandCurves c = band.curves(strain);
  const BandBranch branch = band_branch(c, previous);
  if (branch == BandBranch::loading) {
    r.force = c.upper;
    r.slope = c.upper_slope;
    if constexpr (tension) {
      r.potential = strain < band.emt ? c.upper * strain / (band.p + 1.0)
                                      : band.loading_integral(strain);
    } else {
      r.potential = band.loading_integral(strain);
    }
    return r;
  }
  double lower, upper;
  if (cached != nullptr) {
    lower = cached[0];
    upper = cached[1];
  } else {
    lower = band.loading_inverse(previous);
    upper = std::max(lower, band.unloading_inverse(previous));
  }
  // Tension below EMT: a power curve's integral is its value times eps / (exponent + 1), and
  // at the breakpoints the curves' values are the previous force (no further pow).
  double lower_potential;
  if constexpr (tension) {
    lower_potential =
        lower < band.emt ? previous * lower / (band.p + 1.0) : band.loading_integral(lower);
  } else {
    lower_potential = band.loading_integral(lower);
  }
  if (branch == BandBranch::plateau) {  // the previous force is kept
    r.force = previous;
    r.potential = lower_potential + previous * (strain - lower);
    return r;
  }
  r.force = c.lower;  // unloading branch
  r.slope = c.lower_slope;
  double upper_integral, strain_integral;
  if constexpr (tension) {
    upper_integral =
        upper < band.emt ? previous * upper / (band.q + 1.0) : band.unloading_integral(upper);
    strain_integral =
        strain < band.emt ? c.lower * strain / (band.q + 1.0) : band.unloading_integral(strain);
  } else {
    upper_integral = band.unloading_integral(upper);
    strain_integral = band.unloading_integral(strain);
  }
  r.potential = lower_potential + previous * (upper - lower) - upper_integral + strain_integral;
  return r;
}

/// Breakpoints {lower, upper} of the bending band for previous moment `previous` (cached per step).
inline void bending_breakpoints(const BendingBand& band, double previous, double* out) {
  if (!(previous > 0.0)) {
    out[0] = out[1] = 0.0;
    return;
  }
  out[0] = band.loading_inverse(previous);
  out[1] = std::max(out[0], band.unloading_inverse(previous));
}

/// What fast_return_map's bending potential off the loading curve adds to the curvature's
/// terms, for previous moment `previous` and its `breakpoints` {lower, upper}: {plateau,
/// unloading}, the plateau's potential being out[0] + previous kappa and the unloading one
/// out[1] + unloading_integral(kappa). Cached per step for the vector kernel, whose lanes then
/// need no integral at the breakpoints (three expm1 and ramps fewer a lane group).
inline void bending_offloading(const BendingBand& band, double previous, const double* breakpoints,
                               double* out) {
  const double lower = breakpoints[0], upper = breakpoints[1];
  const double lower_potential = band.loading_integral(lower);
  out[0] = lower_potential - previous * lower;
  out[1] = lower_potential + previous * (upper - lower) - band.unloading_integral(upper);
}

/// Edge e = 2*slot+d: energy w L Psi(eps); force density w t / l (N/m / m * m) for the gather.
struct EdgeTerm {
  double energy = 0.0;
  double force_density = 0.0;  ///< w t / l: the gradient on b is force_density * (x_b - x_a)
  double force = 0.0;          ///< t, N/m
  double slope = 0.0;          ///< dt/deps, N/m
  double strain = 0.0;
  double length = 0.0;
};

template <class Positions>
inline EdgeTerm edge_term(const StepContext& ctx, std::int64_t id, const Positions& x) {
  const ClothMesh& mesh = ctx.mesh;
  const std::int64_t a = element_slot(id), b = mesh.next[id];
  const Eigen::Vector3d e = x(b) - x(a);
  EdgeTerm term;
  term.length = e.norm();
  const double rest = mesh.edge_rest[id], width = mesh.edge_width[id];
  term.strain = term.length / rest - 1.0;
  const TensileBand& band = ctx.material.tensile[element_direction(id)];
  const ReturnMapped r =
      band.plateau_slope > 0.0
          ? tilted_return_map(band, &ctx.state.edge_plateau[kTiltedPieceDoubles * id], term.strain)
          : fast_return_map(band, ctx.state.edge_force[id], term.strain, nullptr);
  term.energy = width * rest * r.potential;
  term.force = r.force;
  term.slope = r.slope;
  term.force_density = term.length > 0.0 ? width * r.force / term.length : 0.0;
  return term;
}

/// Triple t = 2*slot+d centred on slot: energy w Lbar Psi(kappa); gradient coefficients
/// w M (A, Bc, C) of element_geometry.hpp.
struct TripleTerm {
  double energy = 0.0;
  double coefficient[3] = {0.0, 0.0, 0.0};  ///< w M A, w M Bc, w M C
  double moment = 0.0;                      ///< M, N
  double slope = 0.0;                       ///< dM/dkappa, N m
  double curvature = 0.0;                   ///< 1/m
  TurningAngle<double> angle{};
};

template <class Positions>
inline TripleTerm triple_term(const StepContext& ctx, std::int64_t id, const Positions& x) {
  const ClothMesh& mesh = ctx.mesh;
  const std::int64_t c = element_slot(id), a = mesh.prev[id], b = mesh.next[id];
  const Eigen::Vector3d xc = x(c);
  const Eigen::Vector3d e1 = xc - x(a), e2 = x(b) - xc;
  TripleTerm term;
  term.angle = turning_angle<double>(e1, e2);
  const double rest = mesh.triple_rest(id), width = mesh.triple_width(id);
  term.curvature = term.angle.theta / rest;
  const ReturnMapped r =
      fast_return_map(ctx.material.bending[element_direction(id)], ctx.state.triple_moment[id],
                      term.curvature, &ctx.state.triple_breakpoints[2 * id]);
  term.energy = width * rest * r.potential;
  term.moment = r.force;
  term.slope = r.slope;
  const double wm = width * r.force;
  term.coefficient[0] = wm * term.angle.a;
  term.coefficient[1] = wm * term.angle.bc;
  term.coefficient[2] = wm * term.angle.c;
  return term;
}

/// The element terms around one particle at the stored positions, each computed once and read
/// by that particle's smoothing move (PotentialObjective::smooth): its gradient, its diagonal
/// block and its starting energy read the values they would compute themselves (the same
/// function of the same positions), so the memo changes no bit.
struct LocalTerms {
  std::vector<std::pair<std::int64_t, EdgeTerm>> edges;
  std::vector<std::pair<std::int64_t, TripleTerm>> triples;
  void clear() {
    edges.clear();
    triples.clear();
  }
  /// The memo's term of element id, computed by `compute()` the first time it is asked for.
  template <class Term, class Compute>
  static Term find_or_add(std::vector<std::pair<std::int64_t, Term>>& list, std::int64_t id,
                          Compute&& compute) {
    for (const auto& [known, term] : list) {
      if (known == id) return term;
    }
    list.emplace_back(id, compute());
    return list.back().second;
  }
};

/// edge_term at the stored positions x, through `memo` when there is one.
template <class Positions>
inline EdgeTerm edge_term(const StepContext& ctx, std::int64_t id, const Positions& x,
                          LocalTerms* memo) {
  if (memo == nullptr) return edge_term(ctx, id, x);
  return LocalTerms::find_or_add(memo->edges, id, [&] { return edge_term(ctx, id, x); });
}

/// triple_term at the stored positions x, through `memo` when there is one.
template <class Positions>
inline TripleTerm triple_term(const StepContext& ctx, std::int64_t id, const Positions& x,
                              LocalTerms* memo) {
  if (memo == nullptr) return triple_term(ctx, id, x);
  return LocalTerms::find_or_add(memo->triples, id, [&] { return triple_term(ctx, id, x); });
}

/// Calls edge(id) for every active edge and triple(id) for every active triple that node k
/// belongs to (an element touching two given nodes is reported for each; ghosts' own
/// elements only when k is the ghost). The terms of Phi that a move of k changes.
template <class Edge, class Triple>
inline void for_each_element_at(const ClothMesh& mesh, std::int64_t k, Edge&& edge,
                                Triple&& triple) {
  for (int d = 0; d < 2; ++d) {
    const std::int64_t id = element_id(k, d);
    const std::int32_t n = mesh.next[id], p = mesh.prev[id];
    if (mesh.edge_active[id]) edge(id);
    if (mesh.triple_active[id]) triple(id);
    if (p >= 0 && mesh.next[element_id(p, d)] == k) {
      const std::int64_t ep = element_id(p, d);
      if (mesh.edge_active[ep]) edge(ep);
      if (mesh.triple_active[ep]) triple(ep);
    }
    if (n >= 0 && mesh.triple_active[element_id(n, d)] && mesh.prev[element_id(n, d)] == k) {
      triple(element_id(n, d));
    }
  }
}

/// The elastic part of a particle's gradient (= -F_s, MODEL.md 2):
/// sum_e t_e w_e dl/dx_s + sum_t M_t w_t dtheta/dx_s over every edge and triple touching s,
/// in a fixed order, with the element coefficients given by callables:
/// edge(id) = w t / l and triple(id) = {w M A, w M Bc, w M C}.
/// On an adaptive mesh the sum also takes half of what every ghost hanging on s receives
/// (ghost_nodes.hpp): the chain rule through the ghost's midpoint position.
template <class Positions, class EdgeCoefficient, class TripleCoefficients>
inline Eigen::Vector3d gather_elastic_at(const ClothMesh& mesh, std::int64_t s, const Positions& x,
                                         const EdgeCoefficient& edge,
                                         const TripleCoefficients& triple) {
  Eigen::Vector3d g = Eigen::Vector3d::Zero();
  const Eigen::Vector3d xs = x(s);
  for (int d = 0; d < 2; ++d) {
    const std::int64_t id = element_id(s, d);
    const std::int32_t n = mesh.next[id], p = mesh.prev[id];
    if (n >= 0) {
      const Eigen::Vector3d xn = x(n);
      if (mesh.edge_active[id]) g -= edge(id) * (xn - xs);
      const std::int64_t tn = element_id(n, d);
      if (mesh.triple_active[tn] && mesh.prev[tn] == s) {
        const Eigen::Vector3d k = triple(tn);
        g += -k[0] * (xn - xs) + k[1] * (x(mesh.next[tn]) - xn);
      }
    }
    if (p >= 0) {
      const Eigen::Vector3d xp = x(p);
      const std::int64_t ep = element_id(p, d);
      if (mesh.edge_active[ep] && mesh.next[ep] == s) g += edge(ep) * (xs - xp);
      if (mesh.triple_active[ep] && mesh.next[ep] == s) {
        const Eigen::Vector3d k = triple(ep);
        g += -k[1] * (xp - x(mesh.prev[ep])) + k[2] * (xs - xp);
      }
    }
    if (mesh.triple_active[id]) {
      const Eigen::Vector3d k = triple(id);
      const Eigen::Vector3d e1 = xs - x(p), e2 = x(n) - xs;
      g += (k[0] + k[1]) * e1 - (k[1] + k[2]) * e2;
    }
  }
  return g;
}

template <class Positions, class EdgeCoefficient, class TripleCoefficients>
inline Eigen::Vector3d gather_elastic(const ClothMesh& mesh, std::int64_t s, const Positions& x,
                                      const EdgeCoefficient& edge,
                                      const TripleCoefficients& triple) {
  return with_ghost_children(
      mesh, s, [&](std::int64_t k) { return gather_elastic_at(mesh, k, x, edge, triple); });
}

/// gather_elastic with the coefficients the element loops wrote to the scratch arrays.
template <class Positions>
inline Eigen::Vector3d gather_elastic_gradient(const ClothMesh& mesh, const ClothState& state,
                                               std::int64_t s, const Positions& x) {
  return gather_elastic(
      mesh, s, x, [&](std::int64_t id) { return state.edge_scratch[id]; },
      [&](std::int64_t id) { return Eigen::Vector3d(&state.triple_scratch[3 * id]); });
}

}  // namespace clothbench::kernels
