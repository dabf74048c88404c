// The vector element kernels (kernels/vector, ElementKernel::vector) against the scalar
// reference twin (potential_elements.hpp): per element force coefficients, tile energies and
// the whole gradient, for every instruction set this CPU supports, on random states in every
// band regime and on an adaptive mesh with ghosts.
//
// Stated bound: each scratch value (w t / l per edge; w M A, w M Bc, w M C per triple) is
// within 1e-12 relative of the reference, where "relative" is to the larger of the reference
// value and the element's loading-curve value w F_L (the unloading curve B k - HB s(k) cancels
// near its onset, and there a few-ulp difference of expm1 is relative to the curve's terms,
// not to their difference). The vector math (xsimd exp/log/expm1/pow/atan2) differs from
// libm's by a few ulp; everything else is the reference's operation order.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <string>
#include <vector>

#include "kernel_fixtures.hpp"
#include "kernels/element_geometry.hpp"
#include "kernels/potential_elements.hpp"
#include "kernels/vector_lanes_args.hpp"

namespace clothbench {
namespace {

using kernels::ClothMesh;
using kernels::ElementKind;

constexpr double kRelative = 1e-12;

/// Which branch of the return mapping an element takes (counted so the test covers all).
struct RegimeCounts {
  int loading = 0, plateau = 0, unloading = 0, zero = 0;
};

kernels::SimulationConfig with_kernel(kernels::SimulationConfig c, kernels::ElementKernel k) {
  c.solver.kernel = k;
  return c;
}

/// Live element ids of `kind`, tile by tile (as LoopRunner::for_each_tile hands them out).
std::vector<std::vector<std::int32_t>> tiles_of(const ClothMesh& mesh, ElementKind kind) {
  std::vector<std::vector<std::int32_t>> tiles;
  for (std::int64_t t = 0; t < mesh.tile_count(); ++t) {
    std::vector<std::int32_t> ids;
    const int per_slot = kind == ElementKind::particles ? 1 : 2;
    for (std::int64_t s = mesh.tile_slot_begin[t]; s < mesh.tile_slot_begin[t + 1]; ++s) {
      for (int d = 0; d < per_slot; ++d) {
        const std::int64_t id = per_slot * s + d;
        if (kernels::element_is_live(mesh, kind, id)) ids.push_back(static_cast<std::int32_t>(id));
      }
    }
    tiles.push_back(ids);
  }
  return tiles;
}

/// Sets previous forces so that every regime is taken: a third of the elements loading
/// (previous force 0), the rest with previous forces around the band at their current strain.
void spread_history(kernels::Simulation& sim, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const ClothMesh& mesh = sim.mesh();
  kernels::ClothState& st = sim.state();
  auto x = [&](std::int64_t k) { return kernels::vec3(st.position, k); };
  for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
    const int d = kernels::element_direction(id);
    const std::int64_t s = kernels::element_slot(id);
    if (mesh.edge_active[id]) {
      const double strain = (x(mesh.next[id]) - x(s)).norm() / mesh.edge_rest[id] - 1.0;
      const kernels::BandCurves c = sim.material().tensile[d].curves(strain);
      st.edge_force[id] = id % 3 == 0 ? 0.0 : (c.upper > 0.0 ? 1.3 * c.upper * unit(rng)
                                                               : 0.02 * sim.material().tensile[d].fm * unit(rng));
    }
    if (mesh.triple_active[id]) {
      const Eigen::Vector3d xc = x(s);
      const double kappa =
          kernels::turning_angle<double>(xc - x(mesh.prev[id]), x(mesh.next[id]) - xc).theta /
          mesh.triple_rest(id);
      const kernels::BandCurves c = sim.material().bending[d].curves(kappa);
      // Below the unloading curve where it is positive (id % 3 == 1), else around the band.
      st.triple_moment[id] = id % 3 == 0                    ? 0.0
                             : id % 3 == 1 && c.lower > 0.0 ? c.lower * unit(rng)
                                                            : 1.3 * c.upper * unit(rng);
    }
  }
}

RegimeCounts edge_regimes(const kernels::Simulation& sim) {
  RegimeCounts r;
  const ClothMesh& mesh = sim.mesh();
  const kernels::ClothState& st = sim.state();
  auto x = [&](std::int64_t k) { return kernels::vec3(st.position, k); };
  for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
    if (!mesh.edge_active[id]) continue;
    const double strain = (x(mesh.next[id]) - x(id / 2)).norm() / mesh.edge_rest[id] - 1.0;
    const kernels::BandCurves c = sim.material().tensile[id % 2].curves(strain);
    const double prev = st.edge_force[id];
    if (!(strain > 0.0)) ++r.zero;
    else if (!(prev < c.upper)) ++r.loading;
    else if (!(prev < c.lower)) ++r.plateau;
    else ++r.unloading;
  }
  return r;
}

RegimeCounts triple_regimes(const kernels::Simulation& sim) {
  RegimeCounts r;
  const ClothMesh& mesh = sim.mesh();
  const kernels::ClothState& st = sim.state();
  auto x = [&](std::int64_t k) { return kernels::vec3(st.position, k); };
  for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
    if (!mesh.triple_active[id]) continue;
    const Eigen::Vector3d xc = x(id / 2);
    const double kappa =
        kernels::turning_angle<double>(xc - x(mesh.prev[id]), x(mesh.next[id]) - xc).theta /
        mesh.triple_rest(id);
    const kernels::BandCurves c = sim.material().bending[id % 2].curves(kappa);
    const double prev = st.triple_moment[id];
    if (!(kappa > 0.0)) ++r.zero;
    else if (!(prev < c.upper)) ++r.loading;
    else if (!(prev < c.lower)) ++r.plateau;
    else ++r.unloading;
  }
  return r;
}

/// |a - b| <= kRelative * max(|b|, scale); returns the ratio |a - b| / max(|b|, scale).
double relative_difference(double a, double b, double scale) {
  const double denominator = std::max(std::abs(b), scale);
  return denominator > 0.0 ? std::abs(a - b) / denominator : std::abs(a - b);
}

/// Gives the minimiser's vectors and the preconditioner random values (the particle loop's
/// sums read them; a fresh simulation holds zeros).
void randomise_solver_vectors(kernels::Simulation& sim, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  kernels::ClothState& st = sim.state();
  for (double& v : st.direction) v = 0.01 * unit(rng);
  for (double& v : st.gradient_old) v = 0.01 * unit(rng);
  for (float& v : st.preconditioner) v = static_cast<float>(1e-3 * unit(rng));
}

/// Every ISA's particle kernel on the scratch of `ref` (after its evaluate()), with random
/// scalar terms `extra`, against the reference's formulas: gradient per particle (zero unless
/// free) and each tile's sums.
void compare_particles(kernels::Simulation& ref, const std::string& what) {
  const ClothMesh& mesh = ref.mesh();
  kernels::ClothState& st = ref.state();
  const double dt = ref.config().time.step, g_ref = ref.config().time.gravity.norm();
  const Eigen::Vector3d gravity = ref.config().time.gravity;
  auto x = [&](std::int64_t k) { return kernels::vec3(st.position, k); };
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<double> extra(4 * static_cast<std::size_t>(mesh.slot_count()));
  for (double& v : extra) v = 1e-3 * unit(rng);
  // The reference gradient of each particle with these terms, and its sums per tile.
  std::vector<double> expected(st.gradient.size(), 0.0);
  std::vector<kernels::vector::ParticleLanesSums> tile_sums;
  double gmax = 0.0;
  for (const auto& slots : tiles_of(mesh, ElementKind::particles)) {
    kernels::vector::ParticleLanesSums sums;
    for (std::size_t q = 0; q < slots.size(); ++q) {
      const std::int64_t s = slots[q];
      const double* e = &extra[4 * q];
      if ((mesh.flags[s] & kernels::kParticlePinned) != 0) continue;
      const double m = mesh.mass[s];
      const Eigen::Vector3d offset = x(s) - kernels::vec3(st.target, s);
      const Eigen::Vector3d own =
          m / (dt * dt) * offset - m * gravity + Eigen::Vector3d(e[0], e[1], e[2]);
      const Eigen::Vector3d g =
          own + kernels::gather_elastic_at(
                    mesh, s, x, [&](std::int64_t id) { return st.edge_scratch[id]; },
                    [&](std::int64_t id) { return Eigen::Vector3d(&st.triple_scratch[3 * id]); });
      kernels::vec3(expected, s) = g;
      gmax = std::max(gmax, g.cwiseAbs().maxCoeff());
      const Eigen::Vector3d z = kernels::apply_symmetric(st.preconditioner, s, g);
      const double ratio = g.norm() / (m * g_ref);
      sums.energy += 0.5 * m / (dt * dt) * offset.squaredNorm() -
                     m * gravity.dot(x(s) - kernels::vec3(st.step_start, s)) + e[3];
      sums.residual_sq += ratio * ratio;
      sums.residual_max = std::max(sums.residual_max, ratio);
      sums.slope += g.dot(kernels::vec3(st.direction, s));
      sums.grad_dot_z += g.dot(z);
      if (!st.gradient_old.empty()) sums.grad_old_dot_z += kernels::vec3(st.gradient_old, s).dot(z);
    }
    tile_sums.push_back(sums);
  }
  ASSERT_GT(gmax, 0.0);
  const auto args = kernels::vector::particle_lanes_args(mesh, st, gravity, g_ref, dt);
  const kernels::vector::ElementLanesKernels* isas[4];
  const int n = kernels::vector::supported_element_lanes_kernels(isas, 4);
  for (int k = 0; k < n; ++k) {
    const std::string isa = what + ", " + isas[k]->isa + ", particles";
    std::fill(st.gradient.begin(), st.gradient.end(), -1.0);
    std::size_t t = 0;
    for (const auto& slots : tiles_of(mesh, ElementKind::particles)) {
      const kernels::vector::ParticleLanesSums& want = tile_sums[t++];
      if (slots.empty()) continue;
      const kernels::vector::ParticleLanesSums got = isas[k]->particles(
          args, slots.data(), extra.data(), static_cast<std::int64_t>(slots.size()));
      const double got_values[6] = {got.energy, got.residual_sq, got.residual_max,
                                    got.slope,  got.grad_dot_z,  got.grad_old_dot_z};
      const double want_values[6] = {want.energy, want.residual_sq, want.residual_max,
                                     want.slope,  want.grad_dot_z,  want.grad_old_dot_z};
      for (int c = 0; c < 6; ++c) {
        EXPECT_LE(relative_difference(got_values[c], want_values[c], 0.0), kRelative)
            << isa << ": tile " << t - 1 << " sum " << c << " vector " << got_values[c]
            << " reference " << want_values[c];
      }
    }
    double worst = 0.0;
    for (std::int64_t s = 0; s < mesh.slot_count(); ++s) {
      if ((mesh.flags[s] & kernels::kParticleActive) == 0) continue;
      for (int c = 0; c < 3; ++c) {
        const double r = relative_difference(st.gradient[3 * s + c], expected[3 * s + c], gmax);
        worst = std::max(worst, r);
        EXPECT_LE(r, kRelative) << isa << ": particle " << s << " component " << c;
      }
    }
    std::printf("%s: worst relative difference %.3g\n", isa.c_str(), worst);
  }
}

/// Compares every ISA's kernels on `ref` (after the reference evaluate()) element by element,
/// and the vector simulation's whole evaluation with the reference's.
void compare(kernels::Simulation& ref, kernels::Simulation& vec, const std::string& what) {
  schedulers::OmpStaticDriver driver;
  const kernels::Evaluation er = ref.evaluate(driver);
  const kernels::Evaluation ev = vec.evaluate(driver);
  const ClothMesh& mesh = ref.mesh();
  kernels::ClothState& st = ref.state();
  const std::vector<double> edge_ref = st.edge_scratch, triple_ref = st.triple_scratch;
  auto x = [&](std::int64_t k) { return kernels::vec3(st.position, k); };

  const kernels::vector::ElementLanesKernels* isas[4];
  const int n = kernels::vector::supported_element_lanes_kernels(isas, 4);
  ASSERT_GE(n, 1);
  for (int k = 0; k < n; ++k) {
    const std::string isa = what + ", " + isas[k]->isa;
    std::fill(st.edge_scratch.begin(), st.edge_scratch.end(), -1.0);
    std::fill(st.triple_scratch.begin(), st.triple_scratch.end(), -1.0);
    const auto edges = kernels::vector::edge_lanes_args(mesh, st, ref.material());
    // The vector simulation's state holds the step's off-loading constants (same moments).
    ASSERT_EQ(vec.state().triple_offloading.size(), st.triple_breakpoints.size());
    st.triple_offloading = vec.state().triple_offloading;
    const auto triples = kernels::vector::triple_lanes_args(mesh, st, ref.material());
    for (const auto& ids : tiles_of(mesh, ElementKind::edges)) {
      if (!ids.empty()) isas[k]->edges(edges, ids.data(), static_cast<std::int64_t>(ids.size()));
    }
    for (const auto& ids : tiles_of(mesh, ElementKind::triples)) {
      if (!ids.empty()) isas[k]->triples(triples, ids.data(), static_cast<std::int64_t>(ids.size()));
    }
    double worst_edge = 0.0, worst_triple = 0.0;
    for (std::int64_t id = 0; id < 2 * mesh.slot_count(); ++id) {
      const int d = kernels::element_direction(id);
      if (mesh.edge_active[id]) {
        const double length = (x(mesh.next[id]) - x(id / 2)).norm();
        const double strain = length / mesh.edge_rest[id] - 1.0;
        const double scale =
            length > 0.0 ? mesh.edge_width[id] * ref.material().tensile[d].curves(strain).upper / length : 0.0;
        const double r = relative_difference(st.edge_scratch[id], edge_ref[id], scale);
        worst_edge = std::max(worst_edge, r);
        EXPECT_LE(r, kRelative) << isa << ": edge " << id << " vector " << st.edge_scratch[id]
                                << " reference " << edge_ref[id];
      }
      if (mesh.triple_active[id]) {
        const Eigen::Vector3d xc = x(id / 2);
        const auto angle =
            kernels::turning_angle<double>(xc - x(mesh.prev[id]), x(mesh.next[id]) - xc);
        const double upper =
            mesh.triple_width(id) * ref.material().bending[d].curves(angle.theta / mesh.triple_rest(id)).upper;
        const double coefficient[3] = {angle.a, angle.bc, angle.c};
        for (int c = 0; c < 3; ++c) {
          const double r = relative_difference(st.triple_scratch[3 * id + c], triple_ref[3 * id + c],
                                               std::abs(upper * coefficient[c]));
          worst_triple = std::max(worst_triple, r);
          EXPECT_LE(r, kRelative) << isa << ": triple " << id << " coefficient " << c;
        }
      }
    }
    ::testing::Test::RecordProperty("worst_relative_" + std::string(isas[k]->isa),
                                    std::max(worst_edge, worst_triple));
    std::printf("%s: worst relative difference edges %.3g triples %.3g\n", isa.c_str(), worst_edge,
                worst_triple);
  }
  std::copy(edge_ref.begin(), edge_ref.end(), st.edge_scratch.begin());
  std::copy(triple_ref.begin(), triple_ref.end(), st.triple_scratch.begin());
  const std::vector<double> gradient_ref = st.gradient;
  compare_particles(ref, what);
  st.gradient = gradient_ref;

  // The whole evaluation (vector element and particle loops, the scalar terms of contact,
  // scripted forces and ghost children): every sum and the gradient.
  EXPECT_LE(std::abs(ev.value - er.value), 1e-12 * std::abs(er.value)) << what << ": energy";
  const double sums_ref[5] = {er.slope, er.grad_dot_z, er.grad_old_dot_z, er.residual_sq,
                              er.residual_max};
  const double sums_vec[5] = {ev.slope, ev.grad_dot_z, ev.grad_old_dot_z, ev.residual_sq,
                              ev.residual_max};
  for (int c = 0; c < 5; ++c) {
    EXPECT_LE(relative_difference(sums_vec[c], sums_ref[c], 0.0), 1e-11) << what << ": sum " << c;
  }
  EXPECT_EQ(ev.free_particles, er.free_particles) << what;
  EXPECT_EQ(ev.contact_tested, er.contact_tested) << what;
  EXPECT_EQ(ev.contact_skipped, er.contact_skipped) << what;
  double gmax = 0.0, dmax = 0.0;
  for (std::size_t i = 0; i < st.gradient.size(); ++i) {
    gmax = std::max(gmax, std::abs(st.gradient[i]));
    dmax = std::max(dmax, std::abs(vec.state().gradient[i] - st.gradient[i]));
  }
  ASSERT_GT(gmax, 0.0);
  EXPECT_LE(dmax, 1e-12 * gmax) << what << ": gradient (max norm)";
}

TEST(VectorElements, MatchTheReferenceOnRandomStatesInEveryRegime) {
  for (unsigned seed : {1u, 2u, 3u}) {
    for (bool obstacles : {false, true}) {
      kernels::SimulationConfig c = testing::small_cloth(obstacles, obstacles);
      // With obstacles under nonlinear CG, whose g_old the particle sums read; without them
      // under Newton, which keeps none.
      c.solver.method = obstacles ? kernels::StepMethod::nonlinear_cg : kernels::StepMethod::newton;
      // A stiffer bending band (B kappa0 > HB: the unloading curve is positive for every
      // curvature), so that the triples' unloading branch is taken too.
      c.fabric.warp.bending_b *= 20.0;
      c.fabric.weft.bending_b *= 20.0;
      kernels::Simulation ref(with_kernel(c, kernels::ElementKernel::reference));
      kernels::Simulation vec(with_kernel(c, kernels::ElementKernel::vector));
      for (kernels::Simulation* sim : {&ref, &vec}) {
        testing::randomise_state(*sim, seed);
        spread_history(*sim, seed + 10);
        randomise_solver_vectors(*sim, seed + 20);
        sim->set_external_force(4, 3, Eigen::Vector3d(0.01, -0.02, 0.03));  // a scripted pull
      }
      const RegimeCounts e = edge_regimes(ref), t = triple_regimes(ref);
      EXPECT_GT(e.loading, 0);
      EXPECT_GT(e.plateau, 0);
      EXPECT_GT(e.unloading, 0);
      EXPECT_GT(e.zero, 0);
      EXPECT_GT(t.loading, 0);
      EXPECT_GT(t.plateau, 0);
      EXPECT_GT(t.unloading, 0);
      compare(ref, vec, "seed " + std::to_string(seed) + (obstacles ? " with obstacles" : ""));
    }
  }
}

TEST(VectorElements, MatchTheReferenceOnAStretchedCloth) {
  // Strains beyond EMT (the linear continuation of the tensile band) on every edge.
  kernels::SimulationConfig c = testing::small_cloth(false, false);
  c.cloth.initial_stretch = 0.6;
  kernels::Simulation ref(with_kernel(c, kernels::ElementKernel::reference));
  kernels::Simulation vec(with_kernel(c, kernels::ElementKernel::vector));
  for (kernels::Simulation* sim : {&ref, &vec}) {
    testing::randomise_state(*sim, 5);
    spread_history(*sim, 6);
    randomise_solver_vectors(*sim, 7);
  }
  int beyond = 0;
  for (std::int64_t id = 0; id < 2 * ref.mesh().slot_count(); ++id) {
    if (!ref.mesh().edge_active[id]) continue;
    const double strain = (kernels::vec3(ref.state().position, ref.mesh().next[id]) -
                           kernels::vec3(ref.state().position, id / 2)).norm() / ref.mesh().edge_rest[id] - 1.0;
    beyond += strain >= ref.material().tensile[id % 2].emt ? 1 : 0;
  }
  ASSERT_GT(beyond, 0) << "the stretch must reach the linear part of the band";
  compare(ref, vec, "stretched");
}

TEST(VectorElements, MatchTheReferenceOnAnAdaptiveMeshWithGhosts) {
  kernels::SimulationConfig c = testing::small_cloth(false, true);
  c.cloth.particles_i = 17;
  c.cloth.particles_j = 13;
  c.cloth.size_i = 0.4;
  c.cloth.size_j = 0.3;
  c.cloth.block_size = 6;
  c.cloth.pinned = {{0, 0}, {16, 12}};
  c.amrc.enabled = true;
  c.amrc.levels = 2;
  kernels::Simulation ref(with_kernel(c, kernels::ElementKernel::reference));
  kernels::Simulation vec(with_kernel(c, kernels::ElementKernel::vector));
  for (kernels::Simulation* sim : {&ref, &vec}) {
    kernels::AdaptiveMesh& tree = sim->begin_tree_edit();
    for (int a = 0; a < (tree.cells_i() >> 1); ++a) {
      for (int b = 0; b < (tree.cells_j() >> 1); ++b) {
        if ((a + b) % 2 == 0) tree.coarsen(kernels::TreeCell{1, a, b}, sim->mesh());
      }
    }
    sim->end_tree_edit();
    testing::randomise_state(*sim, 8);
    spread_history(*sim, 9);
    randomise_solver_vectors(*sim, 10);
  }
  ASSERT_GT(ref.mesh().ghost_count(), 0) << "the mesh must have ghosts";
  compare(ref, vec, "adaptive");
}

TEST(VectorElements, MatchTheReferenceInFullLaneGroupsWithContact) {
  // Tiles of 19 particles (whole groups of 2, 4 and 8 lanes and a remainder), obstacles under
  // part of the cloth, pins and a scripted force.
  kernels::SimulationConfig c = testing::small_cloth(true, true);
  c.cloth.particles_i = 23;
  c.cloth.particles_j = 19;
  c.cloth.block_size = 19;
  c.cloth.pinned = {{0, 0}, {22, 18}};
  kernels::Simulation ref(with_kernel(c, kernels::ElementKernel::reference));
  kernels::Simulation vec(with_kernel(c, kernels::ElementKernel::vector));
  for (kernels::Simulation* sim : {&ref, &vec}) {
    testing::randomise_state(*sim, 11);
    spread_history(*sim, 12);
    randomise_solver_vectors(*sim, 13);
    sim->set_external_force(11, 9, Eigen::Vector3d(-0.02, 0.01, 0.05));
  }
  compare(ref, vec, "full lanes");
}

}  // namespace
}  // namespace clothbench
