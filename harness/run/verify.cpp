// The one verifier of a simulation state (see verify.hpp).
#include "harness/run/verify.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <string_view>

#include "harness/scene/scene.hpp"

namespace clothbench::harness {

namespace {

/// Calls f(bytes) on each array of the state, in the order state_bytes() concatenates them.
template <class F>
void for_each_state_array(const kernels::Simulation& simulation, F&& f) {
  const kernels::ClothState& state = simulation.state();
  for (const std::vector<double>* values :
       {&state.position, &state.edge_force, &state.triple_moment}) {
    f(std::string_view(reinterpret_cast<const char*>(values->data()),
                       values->size() * sizeof(double)));
  }
}

/// The state's bytes against `reference_bytes` (a state_bytes()), array by array in place:
/// size, first_difference and identical, nothing hashed.
ReferenceComparison compare_bytes(const kernels::Simulation& simulation,
                                  std::string_view reference_bytes) {
  ReferenceComparison c;
  bool differs = false;
  for_each_state_array(simulation, [&](std::string_view array) {
    const std::size_t at = c.size;
    c.size += array.size();
    if (differs || at >= reference_bytes.size()) return;
    const std::string_view reference = reference_bytes.substr(at, array.size());
    const auto mine =
        std::mismatch(array.begin(), array.begin() + static_cast<std::ptrdiff_t>(reference.size()),
                      reference.begin())
            .first;
    c.first_difference = at + static_cast<std::size_t>(mine - array.begin());
    differs = mine != array.begin() + static_cast<std::ptrdiff_t>(reference.size());
  });
  c.identical = !differs && c.size == reference_bytes.size();
  return c;
}

}  // namespace

std::string state_bytes(const kernels::Simulation& simulation) {
  std::string bytes;
  std::size_t size = 0;
  for_each_state_array(simulation, [&](std::string_view array) { size += array.size(); });
  bytes.reserve(size);  // one allocation of the final size
  for_each_state_array(simulation, [&](std::string_view array) { bytes.append(array); });
  return bytes;
}

std::string state_digest(const kernels::Simulation& simulation) {
  Fnv1a64 hash;
  for_each_state_array(simulation, [&](std::string_view array) { hash.add(array); });
  return hash.hex();
}

StateReference StateReference::of_bytes(std::string bytes) {
  StateReference r;
  r.digest = fnv1a64_hex(bytes);
  r.bytes = std::move(bytes);
  return r;
}

StateReference StateReference::of_digest(std::string digest) {
  StateReference r;
  r.digest = std::move(digest);
  return r;
}

ReferenceComparison compare_state(const kernels::Simulation& simulation,
                                  const StateReference& reference,
                                  std::string_view known_digest) {
  ReferenceComparison c;
  if (reference.bytes) {
    c = compare_bytes(simulation, *reference.bytes);
  } else {
    c.by_digest = true;
    for_each_state_array(simulation, [&](std::string_view array) { c.size += array.size(); });
    c.identical = (known_digest.empty() ? state_digest(simulation) : std::string(known_digest)) ==
                  reference.digest;
  }
  c.reference_digest = reference.digest;
  return c;
}

StateFigures measure_state(const kernels::Simulation& simulation,
                           const kernels::StateDiagnostics& d,
                           const StateReference* reference) {
  StateFigures f;
  f.finite = d.finite;
  if (!d.finite) f.non_finite = simulation.locate_non_finite();
  const kernels::ClothConfig& cloth = simulation.config().cloth;
  const double expected = simulation.mesh().areal_density() * cloth.size_i * cloth.size_j;
  f.mass_error = std::abs(d.total_mass - expected) / expected;
  f.ghost_offset = d.max_ghost_offset;
  f.max_strain = d.max_strain;
  f.particle_penetration =
      simulation.obstacles().empty() ? 0.0 : std::max(0.0, -d.min_particle_distance);
  if (reference != nullptr) {
    f.state_digest = state_digest(simulation);
    f.reference = compare_state(simulation, *reference, f.state_digest);
  }
  return f;
}

std::vector<std::string> judge_state(const StateFigures& f) {
  std::vector<std::string> failures;
  if (!f.finite) {
    failures.push_back(f.non_finite.empty() ? std::string("non-finite state")
                                            : "non-finite value: " + f.non_finite);
  }
  if (!(f.mass_error <= kMassTolerance)) {
    failures.push_back(fmt::format("mass drift {:.3g} (relative to density x area; tolerance {:.0e})",
                                   f.mass_error, kMassTolerance));
  }
  if (!(f.ghost_offset <= 0.0)) {
    failures.push_back(fmt::format(
        "crack: a ghost is {:.3g} m off the midpoint of its coarse edge", f.ghost_offset));
  }
  if (!(f.particle_penetration <= 0.0)) {
    failures.push_back(
        fmt::format("a particle is {:.3g} m inside an obstacle", f.particle_penetration));
  }
  if (!(f.max_strain <= kMaxStrain)) {
    failures.push_back(fmt::format(
        "an edge is stretched to strain {:.3g} (more than {:g}): the state has blown up",
        f.max_strain, kMaxStrain));
  }
  if (f.reference && !f.reference->identical) {
    const ReferenceComparison& r = *f.reference;
    failures.push_back(fmt::format(
        "final state differs from the 1-thread reference (digest {} vs {}, {})", f.state_digest,
        r.reference_digest,
        r.by_digest ? std::string("compared by digest: the reference's state file was not kept")
                    : fmt::format("first differing byte {} of {}", r.first_difference, r.size)));
  }
  return failures;
}

StateFigures verify_state(const kernels::Simulation& simulation, int step,
                          Verification& verification, const StateReference* reference) {
  StateFigures f = measure_state(simulation, simulation.diagnostics(), reference);
  if (f.state_digest.empty()) f.state_digest = state_digest(simulation);
  for (std::string& failure : judge_state(f)) {
    verification.fail(fmt::format("step {}: {}", step, failure));
  }
  return f;
}

}  // namespace clothbench::harness
