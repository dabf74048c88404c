// The one verifier of a simulation state (HPCG style: a run reports a time only when its
// result is right). `run`, `sweep`, `stress` and `experiment` all judge a state with the same
// criteria here - finite, mass exact to one tolerance, no crack between mesh levels, no
// particle inside an obstacle, no edge stretched to twice its length, and bytes identical to a reference when one is given; stress
// adds its stricter cell criteria on top (stress_cell.hpp).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "kernels/simulation.hpp"

namespace clothbench::harness {

/// Checks a run makes on its own result before any time is reported.
struct Verification {
  bool passed = true;
  std::vector<std::string> failures;  ///< one line per failed check
  void fail(std::string why) {
    passed = false;
    failures.push_back(std::move(why));
  }
};

/// Relative mass error a state may show: the rounding of the compensated mass sum. Mass is
/// exact by construction (AMRC moves mass between levels without creating or losing any).
inline constexpr double kMassTolerance = 1e-12;

/// Largest edge strain a state may show: an edge twice its rest length means the state has
/// blown up (a woven fabric tears long before; the hardest stress cell, a 10x softer fabric
/// under 50 g, reached 0.47), even while every value is still finite.
inline constexpr double kMaxStrain = 1.0;

/// What a state's bytes are checked against: the reference's state_bytes(), or only their
/// digest (a sweep resumed after its stored reference state was lost), with which a
/// difference is found but not the byte where it starts.
struct StateReference {
  std::optional<std::string> bytes;  ///< state_bytes() of the reference, when kept
  std::string digest;                ///< FNV-1a 64 of those bytes (fnv1a64_hex)
  /// A reference whose bytes are known; its digest is computed from them.
  static StateReference of_bytes(std::string bytes);
  /// A reference known only by its digest.
  static StateReference of_digest(std::string digest);
};

/// How a state's final bytes compare with a reference's (state_bytes of both).
struct ReferenceComparison {
  bool identical = true;
  bool by_digest = false;            ///< only the digests were compared: no first_difference
  std::string reference_digest;      ///< FNV-1a 64 of the reference bytes
  std::size_t first_difference = 0;  ///< first differing byte (the common length if one is a prefix)
  std::size_t size = 0;              ///< bytes of the state
};

/// The figures the verifier judges (SI units). A caller may fill them itself, e.g. stress
/// with maxima over every step of a cell.
struct StateFigures {
  bool finite = true;
  std::string non_finite;             ///< where the first non-finite value is ("" if unknown)
  double mass_error = 0.0;            ///< |total mass - density W H| / (density W H)
  double ghost_offset = 0.0;          ///< m, farthest ghost from its coarse edge's midpoint
  double particle_penetration = 0.0;  ///< m, deepest active particle inside an obstacle (0: none)
  double max_strain = 0.0;            ///< largest strain of an active edge
  std::string state_digest;           ///< FNV-1a 64 of state_bytes ("" when not computed)
  std::optional<ReferenceComparison> reference;  ///< set when a reference was given
};

/// The raw bytes of the final state that must be identical for every scheduler and thread
/// count: positions, edge forces and triple moments (MODEL.md section 7, Determinism).
std::string state_bytes(const kernels::Simulation& simulation);

/// FNV-1a 64 of state_bytes(simulation), hashed array by array without making that copy (56 MB
/// at the paper's 1001^2).
std::string state_digest(const kernels::Simulation& simulation);

/// How the state compares with `reference`: byte by byte, read in place, when its bytes are
/// kept, else by digest (`by_digest`). Neither side is hashed twice: the reference's digest
/// is the one it carries, and `known_digest`, when given, is taken as the state's own
/// (state_digest(simulation), already computed by the caller) instead of hashing the state
/// again (56 MB at the paper's 1001^2).
ReferenceComparison compare_state(const kernels::Simulation& simulation,
                                  const StateReference& reference,
                                  std::string_view known_digest = {});

/// Measures the figures of the current state of `simulation` from its diagnostics `d`; with
/// a `reference` also its digest and the comparison with the reference.
StateFigures measure_state(const kernels::Simulation& simulation,
                           const kernels::StateDiagnostics& d,
                           const StateReference* reference = nullptr);

/// One line per criterion `figures` breaks, without a step prefix: a non-finite value, a mass
/// error above kMassTolerance (a NaN error fails too), a ghost off its midpoint (a crack), a
/// particle inside an obstacle, an edge strain above kMaxStrain (a blown-up state), bytes that
/// differ from the reference (saying where, or that only the digests were compared).
std::vector<std::string> judge_state(const StateFigures& figures);

/// Measures and judges the current state of `simulation` (after step `step`): every failure
/// goes to `verification` as "step N: ..."; returns the figures, digest always included.
StateFigures verify_state(const kernels::Simulation& simulation, int step,
                          Verification& verification,
                          const StateReference* reference = nullptr);

}  // namespace clothbench::harness
