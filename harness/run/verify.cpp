// The one verifier of a simulation state (see verify.hpp).
#include "harness/run/verify.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "harness/scene/scene.hpp"

namespace clothbench::harness {

namespace {

template <class T>
void append_bytes(std::string& out, const std::vector<T>& values) {
  const std::size_t bytes = values.size() * sizeof(T);
  const std::size_t at = out.size();
  out.resize(at + bytes);
  if (bytes > 0) std::memcpy(out.data() + at, values.data(), bytes);
}

}  // namespace

std::string state_bytes(const kernels::Simulation& simulation) {
  const kernels::ClothState& state = simulation.state();
  std::string bytes;
  // One allocation of the final size (growing by doubling held up to twice the state).
  bytes.reserve((state.position.size() + state.edge_force.size() + state.triple_moment.size()) *
                sizeof(double));
  append_bytes(bytes, state.position);
  append_bytes(bytes, state.edge_force);
  append_bytes(bytes, state.triple_moment);
  return bytes;
}

StateFigures measure_state(const kernels::Simulation& simulation,
                           const kernels::StateDiagnostics& d,
                           const std::string* reference_bytes) {
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
  if (reference_bytes != nullptr) {
    const std::string bytes = state_bytes(simulation);
    f.state_digest = fnv1a64_hex(bytes);
    ReferenceComparison c;
    c.size = bytes.size();
    c.reference_digest = fnv1a64_hex(*reference_bytes);
    const std::size_t common = std::min(bytes.size(), reference_bytes->size());
    while (c.first_difference < common &&
           bytes[c.first_difference] == (*reference_bytes)[c.first_difference]) {
      ++c.first_difference;
    }
    c.identical = bytes.size() == reference_bytes->size() && c.first_difference == common;
    f.reference = c;
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
    failures.push_back(fmt::format(
        "final state differs from the 1-thread reference (digest {} vs {}, first differing "
        "byte {} of {})",
        f.state_digest, f.reference->reference_digest, f.reference->first_difference,
        f.reference->size));
  }
  return failures;
}

StateFigures verify_state(const kernels::Simulation& simulation, int step,
                          Verification& verification, const std::string* reference_bytes) {
  StateFigures f = measure_state(simulation, simulation.diagnostics(), reference_bytes);
  if (f.state_digest.empty()) f.state_digest = fnv1a64_hex(state_bytes(simulation));
  for (std::string& failure : judge_state(f)) {
    verification.fail(fmt::format("step {}: {}", step, failure));
  }
  return f;
}

}  // namespace clothbench::harness
