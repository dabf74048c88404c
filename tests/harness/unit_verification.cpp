// The verifiers seen failing: real states, simulated for a few steps and then tampered with
// (a mass off by 1e-11, a particle pushed into the obstacle, a ghost moved off its coarse
// edge's midpoint, a non-finite position, one flipped byte of the 1-thread reference), must
// make `run` (simulate), a sweep run (measure_run) and a sweep row report FAILED with the
// check that failed named, and a failed row never shows a speed-up. Each tampered state is
// checked to pass before it is tampered with, so the verdict comes from the tampering.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "harness/report/sweep_table.hpp"
#include "harness/run/run_summary.hpp"
#include "harness/run/verify.hpp"
#include "harness/scene/scene.hpp"
#include "harness/stress/stress_cell.hpp"
#include "harness/sweep/measured_run.hpp"
#include "harness/sweep/sweep_document.hpp"
#include "kernels/amrc.hpp"
#include "kernels/simulation.hpp"
#include "schedulers/registry.hpp"
#include "schedulers/static_driver.hpp"

namespace clothbench {
namespace {

using ::testing::HasSubstr;
using nlohmann::json;

/// A 9 x 9 sheet lying on a box (its top at z = 0), 2.5 cm spacing.
kernels::SimulationConfig sheet_on_box() {
  kernels::SimulationConfig c;
  c.cloth.particles_i = 9;
  c.cloth.particles_j = 9;
  c.cloth.block_size = 4;
  c.cloth.size_i = c.cloth.size_j = 0.2;
  c.cloth.origin = {-0.1, -0.1, 2.0 * c.contact.distance};
  kernels::ObstacleConfig box;
  box.kind = kernels::ObstacleKind::box;
  box.center = {0.0, 0.0, -0.1};
  box.half_extents = {0.05, 0.05, 0.1};
  c.obstacles.push_back(box);
  return c;
}

/// The same sheet with AMRC (two levels) and no obstacle.
kernels::SimulationConfig adaptive_sheet() {
  kernels::SimulationConfig c = sheet_on_box();
  c.obstacles.clear();
  c.cloth.initial_crumple = 0.004;
  c.amrc.enabled = true;
  c.amrc.levels = 2;
  c.amrc.check_every = 1000;  // the mesh changes only where the test says
  return c;
}

/// Verifies the current state of `sim` as `clothbench run` does after its last step.
harness::Verification verify_now(kernels::Simulation& sim) {
  schedulers::OmpStaticDriver driver;
  return harness::simulate(sim, driver, 0, true).verification;
}

/// Simulates `steps` steps and expects the state to pass.
void simulate_passing(kernels::Simulation& sim, int steps) {
  schedulers::OmpStaticDriver driver;
  const harness::RunSummary summary = harness::simulate(sim, driver, steps, true);
  ASSERT_TRUE(summary.verification.passed) << ::testing::PrintToString(summary.verification.failures);
  ASSERT_EQ(static_cast<int>(summary.steps.size()), steps);
}

/// The mesh of `sim`, writable: the tests change a particle's mass behind the kernel's back
/// (the Simulation object itself is not const, so this is well defined).
kernels::ClothMesh& writable_mesh(kernels::Simulation& sim) {
  return const_cast<kernels::ClothMesh&>(sim.mesh());  // NOLINT(cppcoreguidelines-pro-type-const-cast)
}

/// Adds `relative` x the sheet's mass to particle (4, 4).
void add_mass(kernels::Simulation& sim, double relative) {
  kernels::ClothMesh& mesh = writable_mesh(sim);
  mesh.mass[mesh.slot(4, 4)] += relative * mesh.total_mass();
}

TEST(RunVerification, AMassOffBy1e11Fails) {
  kernels::Simulation sim(sheet_on_box());
  simulate_passing(sim, 2);
  add_mass(sim, 1e-13);
  EXPECT_TRUE(verify_now(sim).passed) << "1e-13 is inside the 1e-12 bound";
  add_mass(sim, 1e-11);
  const harness::Verification v = verify_now(sim);
  EXPECT_FALSE(v.passed);
  ASSERT_EQ(v.failures.size(), 1u) << ::testing::PrintToString(v.failures);
  EXPECT_THAT(v.failures[0], HasSubstr("step 2: mass"));
}

TEST(RunVerification, AParticleInsideTheObstacleFails) {
  kernels::Simulation sim(sheet_on_box());
  simulate_passing(sim, 2);
  const std::int64_t s = sim.mesh().slot(4, 4);  // above the box's top face
  sim.state().position[3 * s + 2] = -0.001;       // 1 mm below it
  const harness::Verification v = verify_now(sim);
  EXPECT_FALSE(v.passed);
  ASSERT_EQ(v.failures.size(), 1u) << ::testing::PrintToString(v.failures);
  EXPECT_THAT(v.failures[0], HasSubstr("a particle is 0.001 m inside an obstacle"));
}

TEST(RunVerification, AGhostOffItsMidpointIsACrack) {
  kernels::Simulation sim(adaptive_sheet());
  // Coarsen everything to level 1, then split one cell: ghosts hang on its sides.
  kernels::AdaptiveMesh& tree = sim.begin_tree_edit();
  for (int a = 0; a < 4; ++a) {
    for (int b = 0; b < 4; ++b) tree.coarsen(kernels::TreeCell{1, a, b}, sim.mesh());
  }
  tree.refine(kernels::TreeCell{1, 1, 1});
  sim.end_tree_edit();
  ASSERT_GT(sim.mesh().ghost_count(), 0);
  simulate_passing(sim, 2);
  std::int64_t ghost = -1;
  for (std::int64_t s = 0; s < sim.mesh().slot_count() && ghost < 0; ++s) {
    if (sim.mesh().flags[s] & kernels::kParticleGhost) ghost = s;
  }
  ASSERT_GE(ghost, 0);
  sim.state().position[3 * ghost + 2] += 1e-6;
  const harness::Verification v = verify_now(sim);
  EXPECT_FALSE(v.passed);
  ASSERT_EQ(v.failures.size(), 1u) << ::testing::PrintToString(v.failures);
  EXPECT_THAT(v.failures[0], HasSubstr("crack: a ghost is 1e-06 m off the midpoint"));
}

TEST(RunVerification, ANonFiniteStateFails) {
  kernels::Simulation sim(sheet_on_box());
  simulate_passing(sim, 1);
  sim.state().edge_force[kernels::element_id(sim.mesh().slot(2, 3), 0)] =
      std::numeric_limits<double>::infinity();
  const harness::Verification v = verify_now(sim);
  EXPECT_FALSE(v.passed);
  EXPECT_THAT(::testing::PrintToString(v.failures),
              HasSubstr("step 1: non-finite value: tension of edge (2, 3)"));
}

/// The sheet on the box with a contact penalty a hundredth of what holds a particle's weight
/// within the contact layer: the cloth sinks into the box under its own weight.
kernels::SimulationConfig sheet_sinking_into_box() {
  kernels::SimulationConfig c = sheet_on_box();
  c.contact.stiffness = 0.01;
  return c;
}

TEST(RunVerification, AClothThatSinksIntoTheBoxFails) {
  kernels::Simulation sim(sheet_sinking_into_box());
  schedulers::OmpStaticDriver driver;
  const harness::RunSummary summary = harness::simulate(sim, driver, 10, true);
  EXPECT_FALSE(summary.verification.passed);
  EXPECT_THAT(::testing::PrintToString(summary.verification.failures),
              HasSubstr("step 10: a particle is"));
  // The same scene with the shipped stiffness passes: the verdict is the sinking's.
  kernels::Simulation held(sheet_on_box());
  EXPECT_TRUE(harness::simulate(held, driver, 10, true).verification.passed);
}

TEST(StressVerification, ACellThatSinksIntoTheBoxFailsOnBothPenetrations) {
  harness::StressCell cell;
  cell.name = "soft-contact";
  cell.axis = "contact";
  cell.change = "penalty stiffness 0.01";
  cell.scene.name = "sinking sheet";
  cell.scene.file = "sinking.toml";
  cell.scene.steps = 10;
  cell.scene.simulation = sheet_sinking_into_box();
  schedulers::OmpStaticDriver driver;
  const auto result = harness::run_stress_cell(cell, driver, [] { return true; });
  ASSERT_TRUE(result.has_value());
  EXPECT_FALSE(result->passed);
  EXPECT_GT(result->max_particle_penetration, result->contact_distance);
  const std::string failures = ::testing::PrintToString(result->failures);
  EXPECT_THAT(failures, HasSubstr("a particle is"));
  EXPECT_THAT(failures, HasSubstr("the interpolated surface went"));
  EXPECT_THAT(failures, ::testing::Not(HasSubstr("mass")));
  EXPECT_THAT(failures, ::testing::Not(HasSubstr("crack")));

  // Held: the sheet lies wholly on a wider box. (Over an edge of the narrow box, the 2.5 cm
  // chords of this coarse sheet cut the corner by more than the contact distance once the
  // sheet has folded over it, 10-20 steps in, whichever solver: a true finding.)
  cell.scene.simulation = sheet_on_box();
  cell.scene.simulation.obstacles[0].half_extents = {0.15, 0.15, 0.1};
  const auto held = harness::run_stress_cell(cell, driver, [] { return true; });
  ASSERT_TRUE(held.has_value());
  EXPECT_TRUE(held->passed) << ::testing::PrintToString(held->failures);
}

/// A reference: `steps` steps of the sheet on one thread, and its state bytes.
std::string reference_bytes(int steps) {
  omp_set_num_threads(1);
  kernels::Simulation sim(sheet_on_box());
  schedulers::OmpStaticDriver driver;
  const harness::MeasuredRun run =
      harness::measure_run(sim, driver, steps, kernels::Instrumentation::off, nullptr);
  EXPECT_TRUE(run.verification.passed);
  return harness::state_bytes(sim);
}

/// A measured run of the sheet with `threads` threads against the reference state
/// `reference_bytes`.
harness::MeasuredRun measured(const std::string& scheduler, int threads, int steps,
                              const std::string& reference_bytes) {
  const harness::StateReference reference = harness::StateReference::of_bytes(reference_bytes);
  omp_set_num_threads(threads);
  kernels::Simulation sim(sheet_on_box());
  const auto driver = schedulers::make_driver(scheduler);
  harness::MeasuredRun run =
      harness::measure_run(sim, *driver, steps, kernels::Instrumentation::loops, &reference);
  omp_set_num_threads(1);
  return run;
}

/// `runs` with their disturbance cleared: these tests are about verification, and whether
/// other work on the machine disturbed the runs (it would null the speed-ups) is not theirs
/// to decide (integration_sweep_disturbance and unit_disturbance test that).
std::vector<harness::MeasuredRun> undisturbed(std::vector<harness::MeasuredRun> runs) {
  for (harness::MeasuredRun& r : runs) r.disturbance = harness::Disturbance{};
  return runs;
}

/// The first byte where `a` and `b` differ (their common length if one is a prefix).
std::size_t naive_first_difference(const std::string& a, const std::string& b) {
  std::size_t i = 0;
  while (i < a.size() && i < b.size() && a[i] == b[i]) ++i;
  return i;
}

TEST(StateDigest, IsTheHashOfTheStateBytesAndComparesInPlace) {
  omp_set_num_threads(1);
  kernels::Simulation sim(sheet_on_box());
  simulate_passing(sim, 2);
  const std::string bytes = harness::state_bytes(sim);
  const kernels::ClothState& state = sim.state();
  const std::size_t positions = state.position.size() * sizeof(double);
  const std::size_t forces = state.edge_force.size() * sizeof(double);
  ASSERT_EQ(bytes.size(), positions + forces + state.triple_moment.size() * sizeof(double));
  EXPECT_EQ(harness::state_digest(sim), harness::fnv1a64_hex(bytes));

  const harness::ReferenceComparison same =
      harness::compare_state(sim, harness::StateReference::of_bytes(bytes));
  EXPECT_TRUE(same.identical);
  EXPECT_EQ(same.size, bytes.size());
  EXPECT_EQ(same.first_difference, bytes.size());
  EXPECT_EQ(same.reference_digest, harness::fnv1a64_hex(bytes));

  // One flipped bit in each array, on both sides of the boundaries between them.
  for (const std::size_t at : {std::size_t{0}, positions - 1, positions, positions + forces - 1,
                               positions + forces, bytes.size() - 1}) {
    std::string reference = bytes;
    reference[at] = static_cast<char>(reference[at] ^ 0x10);
    const harness::ReferenceComparison c =
        harness::compare_state(sim, harness::StateReference::of_bytes(reference));
    EXPECT_FALSE(c.identical) << at;
    EXPECT_EQ(c.first_difference, at);
    EXPECT_EQ(c.size, bytes.size());
  }
  // References of another length: a prefix of the state, and the state with bytes appended,
  // the shorter one ending inside each array.
  for (const std::size_t length : {std::size_t{0}, positions / 2, positions, positions + 8,
                                   positions + forces + 3, bytes.size() + 8}) {
    std::string reference = bytes.substr(0, std::min(length, bytes.size()));
    reference.resize(length, '\0');
    const harness::ReferenceComparison c =
        harness::compare_state(sim, harness::StateReference::of_bytes(reference));
    EXPECT_FALSE(c.identical) << length;
    EXPECT_EQ(c.first_difference, naive_first_difference(bytes, reference)) << length;
  }
}

TEST(SweepVerification, OneFlippedByteOfTheReferenceFails) {
  const std::string reference = reference_bytes(2);
  const harness::MeasuredRun same = measured("dynamic:1", 2, 2, reference);
  ASSERT_TRUE(same.verification.passed) << ::testing::PrintToString(same.verification.failures);
  EXPECT_TRUE(same.bit_identical);

  // One bit of one byte in the middle of the positions.
  std::string flipped = reference;
  const std::size_t at = flipped.size() / 5 + 3;
  flipped[at] = static_cast<char>(flipped[at] ^ 0x01);
  const harness::MeasuredRun run = measured("dynamic:1", 2, 2, flipped);
  EXPECT_FALSE(run.verification.passed);
  EXPECT_FALSE(run.bit_identical);
  ASSERT_EQ(run.verification.failures.size(), 1u);
  EXPECT_THAT(run.verification.failures[0],
              HasSubstr("differs from the 1-thread reference (digest " + same.state_digest));
  EXPECT_THAT(run.verification.failures[0],
              HasSubstr("first differing byte " + std::to_string(at) + " of " +
                        std::to_string(reference.size())));

  // A reference of another length (e.g. another mesh) fails too.
  const std::string shorter = reference.substr(0, reference.size() - 8);
  EXPECT_FALSE(measured("static", 1, 2, shorter).verification.passed);
}

TEST(SweepVerification, AReferenceKnownOnlyByItsDigestFindsADifferenceButNotWhere) {
  const std::string bytes = reference_bytes(2);
  std::string flipped = bytes;
  flipped[flipped.size() / 3] = static_cast<char>(flipped[flipped.size() / 3] ^ 0x04);
  const std::string right = harness::fnv1a64_hex(bytes);
  const std::string wrong = harness::fnv1a64_hex(flipped);

  omp_set_num_threads(1);
  kernels::Simulation sim(sheet_on_box());
  simulate_passing(sim, 2);
  const harness::ReferenceComparison same =
      harness::compare_state(sim, harness::StateReference::of_digest(right));
  EXPECT_TRUE(same.identical);
  EXPECT_TRUE(same.by_digest);
  EXPECT_EQ(same.size, bytes.size());
  const harness::ReferenceComparison other =
      harness::compare_state(sim, harness::StateReference::of_digest(wrong));
  EXPECT_FALSE(other.identical);
  EXPECT_TRUE(other.by_digest);
  EXPECT_EQ(other.reference_digest, wrong);
  // A digest the caller has already computed is taken as the state's own, not computed again
  // (shown by handing over a wrong one on purpose: it is believed).
  const harness::StateReference digest_right = harness::StateReference::of_digest(right);
  const harness::StateReference digest_wrong = harness::StateReference::of_digest(wrong);
  EXPECT_TRUE(harness::compare_state(sim, digest_wrong, wrong).identical);
  EXPECT_FALSE(harness::compare_state(sim, digest_right, wrong).identical);
  EXPECT_TRUE(harness::compare_state(sim, digest_right, right).identical);
  // With the bytes the comparison is made byte by byte, whatever the digest says.
  EXPECT_FALSE(harness::compare_state(sim, harness::StateReference::of_bytes(flipped)).by_digest);

  // measure_run through the one verifier: passes with the right digest, fails with a wrong
  // one, and the failure says the digests were compared.
  schedulers::OmpStaticDriver driver;
  const harness::StateReference by_right = harness::StateReference::of_digest(right);
  const harness::StateReference by_wrong = harness::StateReference::of_digest(wrong);
  const harness::MeasuredRun pass =
      harness::measure_run(sim, driver, 0, kernels::Instrumentation::off, &by_right);
  EXPECT_TRUE(pass.verification.passed) << ::testing::PrintToString(pass.verification.failures);
  EXPECT_TRUE(pass.bit_identical);
  const harness::MeasuredRun fail =
      harness::measure_run(sim, driver, 0, kernels::Instrumentation::off, &by_wrong);
  EXPECT_FALSE(fail.verification.passed);
  EXPECT_FALSE(fail.bit_identical);
  ASSERT_EQ(fail.verification.failures.size(), 1u);
  EXPECT_THAT(fail.verification.failures[0],
              HasSubstr("step 2: final state differs from the 1-thread reference (digest " + right +
                        " vs " + wrong + ", compared by digest"));
  EXPECT_THAT(fail.verification.failures[0], ::testing::Not(HasSubstr("first differing byte")));
}

TEST(SweepVerification, AMassOffBy1e11Fails) {
  omp_set_num_threads(1);
  kernels::Simulation sim(sheet_on_box());
  schedulers::OmpStaticDriver driver;
  ASSERT_TRUE(harness::measure_run(sim, driver, 2, kernels::Instrumentation::off, nullptr)
                  .verification.passed);
  add_mass(sim, 1e-11);
  // measure_run verifies the state it leaves; zero more steps verify the tampered one.
  const harness::MeasuredRun run =
      harness::measure_run(sim, driver, 0, kernels::Instrumentation::off, nullptr);
  EXPECT_FALSE(run.verification.passed);
  EXPECT_NEAR(run.mass_error, 1e-11, 1e-13);
  ASSERT_EQ(run.verification.failures.size(), 1u);
  EXPECT_THAT(run.verification.failures[0], HasSubstr("step 2: mass drift 1e-11"));
}

TEST(SweepVerification, ANonFiniteStateFails) {
  omp_set_num_threads(1);
  kernels::Simulation sim(sheet_on_box());
  schedulers::OmpStaticDriver driver;
  ASSERT_TRUE(harness::measure_run(sim, driver, 1, kernels::Instrumentation::off, nullptr)
                  .verification.passed);
  sim.state().position[3 * sim.mesh().slot(1, 1)] = std::numeric_limits<double>::quiet_NaN();
  const harness::MeasuredRun run =
      harness::measure_run(sim, driver, 0, kernels::Instrumentation::off, nullptr);
  EXPECT_FALSE(run.verification.passed);
  EXPECT_FALSE(run.finite);
  EXPECT_THAT(::testing::PrintToString(run.verification.failures),
              HasSubstr("step 1: non-finite value: position"));
}

TEST(SweepVerification, AFailedRowShowsNoSpeedup) {
  // Rows made by the sweep's own code from real runs: static on 1 thread (the reference
  // itself) and on 2 threads, the latter measured against a reference with one flipped byte.
  const std::string reference = reference_bytes(2);
  std::string flipped = reference;
  flipped[flipped.size() / 2] = static_cast<char>(flipped[flipped.size() / 2] ^ 0x10);
  const json binding = {{"mode", "none"}, {"bound", false}, {"threads", json::array()}};
  const auto one = undisturbed({measured("static", 1, 2, reference)});
  const auto two = undisturbed({measured("static", 2, 2, flipped)});
  const auto two_good = undisturbed({measured("dynamic:1", 2, 2, reference)});
  const auto one_good = undisturbed({measured("dynamic:1", 1, 2, reference)});
  const auto level = kernels::Instrumentation::loops;
  json document = {
      {"schema", "clothbench.sweep"},
      {"schema_version", harness::kSweepSchemaVersion},
      {"created_utc", "2024-01-01T00:00:00Z"},
      {"updated_utc", "2024-01-01T00:00:00Z"},
      {"complete", true},
      {"command", {"clothbench", "sweep"}},
      {"settings", {{"schedulers", {"static", "dynamic:1"}}, {"threads", {1, 2}}, {"repeat", 1},
                    {"warmup_steps", 0}, {"steps", 2}, {"instrument", "loops"}, {"bind", "none"},
                    {"oversubscribe", false}}},
      {"scene", {{"name", "tampered"}, {"file", "t.toml"}, {"hash", "0"}, {"source", ""}}},
      {"machine", json::object()},
      {"openmp_environment", json::object()},
      {"reference", {{"scheduler", "static@blocks"}, {"threads", 1}, {"state_digest", "0"}}},
      {"rows",
       {harness::make_row("static", "static@blocks", "", 1, false, one, one, level, 2, binding),
        harness::make_row("static", "static@blocks", "", 2, false, two, two, level, 2, binding),
        harness::make_row("dynamic:1", "dynamic:1@blocks", "", 1, false, one_good, one_good,
                          level, 2, binding),
        harness::make_row("dynamic:1", "dynamic:1@blocks", "", 2, false, two_good, two_good,
                          level, 2, binding)}}};
  harness::add_derived(document);
  EXPECT_THAT(harness::validate_sweep_document(document), ::testing::IsEmpty());
  const json& failed = document["rows"][1];
  EXPECT_FALSE(failed["verification"]["passed"].get<bool>());
  EXPECT_FALSE(failed["verification"]["bit_identical"].get<bool>());
  ASSERT_EQ(failed["verification"]["failures"].size(), 2u) << "both runs of the row";
  EXPECT_THAT(failed["verification"]["failures"][0].get<std::string>(),
              HasSubstr("differs from the 1-thread reference"));
  for (const char* k : {"speedup", "efficiency", "speedup_vs_best_1thread", "efficiency_vs_best_1thread"}) {
    EXPECT_TRUE(failed["derived"][k].is_null()) << k;
    EXPECT_TRUE(document["rows"][3]["derived"][k].is_number()) << "the passed 2-thread row: " << k;
  }
  // In the table the failed row says FAILED and has no speed-up; the passed row has one.
  const std::string markdown = harness::format_markdown(document);
  std::string failed_line, passed_line;
  std::size_t from = 0;
  for (std::size_t at = markdown.find('\n'); at != std::string::npos; from = at + 1, at = markdown.find('\n', from)) {
    const std::string line = markdown.substr(from, at - from);
    // Table 2's rows carry the verdict; the accounting table under it has none.
    const bool verdict = line.find("PASSED") != std::string::npos || line.find("FAILED") != std::string::npos;
    if (line.rfind("| 2 |", 0) != 0 || !verdict) continue;
    (line.find("FAILED") != std::string::npos ? failed_line : passed_line) = line;
  }
  ASSERT_FALSE(failed_line.empty()) << markdown;
  ASSERT_FALSE(passed_line.empty()) << markdown;
  EXPECT_THAT(failed_line, HasSubstr("| - | - | - | FAILED (2 checks) |"));
  EXPECT_THAT(passed_line, ::testing::Not(HasSubstr("| - | - | - |")));
  EXPECT_THAT(passed_line, HasSubstr("PASSED"));
  const std::string csv = harness::format_csv(document);
  EXPECT_THAT(csv, HasSubstr(",,,,FAILED,clean\n"));
}

// The one verifier (verify.hpp) itself: each injected fault is caught by its own check, and
// the untampered state passes first, so the verdict is the fault's.

/// The sheet on the box after two steps, verified passing.
void settle(kernels::Simulation& sim) {
  simulate_passing(sim, 2);
  harness::Verification v;
  harness::verify_state(sim, sim.steps_done(), v);
  ASSERT_TRUE(v.passed) << ::testing::PrintToString(v.failures);
}

TEST(Verifier, CatchesAMassChangeInjectedIntoTheState) {
  kernels::Simulation sim(sheet_on_box());
  settle(sim);
  add_mass(sim, 5e-12);
  harness::Verification v;
  const harness::StateFigures f = harness::verify_state(sim, sim.steps_done(), v);
  EXPECT_NEAR(f.mass_error, 5e-12, 1e-13);
  ASSERT_EQ(v.failures.size(), 1u) << ::testing::PrintToString(v.failures);
  EXPECT_THAT(v.failures[0], HasSubstr("step 2: mass drift 5e-12"));
}

TEST(Verifier, CatchesAParticleInjectedIntoTheObstacle) {
  kernels::Simulation sim(sheet_on_box());
  settle(sim);
  sim.state().position[3 * sim.mesh().slot(4, 4) + 2] = -2e-4;  // 0.2 mm below the box's top
  harness::Verification v;
  const harness::StateFigures f = harness::verify_state(sim, sim.steps_done(), v);
  EXPECT_NEAR(f.particle_penetration, 2e-4, 1e-12);
  ASSERT_EQ(v.failures.size(), 1u) << ::testing::PrintToString(v.failures);
  EXPECT_THAT(v.failures[0], HasSubstr("step 2: a particle is 0.0002 m inside an obstacle"));
}

TEST(Verifier, CatchesABlownUpStateWhileEveryValueIsFinite) {
  kernels::Simulation sim(sheet_on_box());
  settle(sim);
  sim.state().position[3 * sim.mesh().slot(0, 0) + 2] += 1.0;  // a corner 1 m above the sheet
  harness::Verification v;
  const harness::StateFigures f = harness::verify_state(sim, sim.steps_done(), v);
  EXPECT_TRUE(f.finite);
  EXPECT_GT(f.max_strain, harness::kMaxStrain);
  ASSERT_EQ(v.failures.size(), 1u) << ::testing::PrintToString(v.failures);
  EXPECT_THAT(v.failures[0], HasSubstr("step 2: an edge is stretched to strain"));
  EXPECT_THAT(v.failures[0], HasSubstr("the state has blown up"));
}

/// The adaptive sheet with ghosts on the sides of one split cell, after two passing steps;
/// returns a ghost's slot.
std::int64_t sheet_with_ghosts(kernels::Simulation& sim) {
  kernels::AdaptiveMesh& tree = sim.begin_tree_edit();
  for (int a = 0; a < 4; ++a) {
    for (int b = 0; b < 4; ++b) tree.coarsen(kernels::TreeCell{1, a, b}, sim.mesh());
  }
  tree.refine(kernels::TreeCell{1, 1, 1});
  sim.end_tree_edit();
  simulate_passing(sim, 2);
  for (std::int64_t s = 0; s < sim.mesh().slot_count(); ++s) {
    if (sim.mesh().flags[s] & kernels::kParticleGhost) return s;
  }
  return -1;
}

TEST(Verifier, CatchesACrackInjectedBetweenMeshLevels) {
  kernels::Simulation sim(adaptive_sheet());
  const std::int64_t ghost = sheet_with_ghosts(sim);
  ASSERT_GE(ghost, 0);
  harness::Verification before;
  harness::verify_state(sim, sim.steps_done(), before);
  ASSERT_TRUE(before.passed) << ::testing::PrintToString(before.failures);
  sim.state().position[3 * ghost] += 3e-6;
  harness::Verification v;
  const harness::StateFigures f = harness::verify_state(sim, sim.steps_done(), v);
  EXPECT_NEAR(f.ghost_offset, 3e-6, 1e-12);
  ASSERT_EQ(v.failures.size(), 1u) << ::testing::PrintToString(v.failures);
  EXPECT_THAT(v.failures[0], HasSubstr("step 2: crack: a ghost is 3e-06 m off the midpoint"));
}

TEST(SweepVerification, ACrackFailsTheRun) {
  omp_set_num_threads(1);
  kernels::Simulation sim(adaptive_sheet());
  const std::int64_t ghost = sheet_with_ghosts(sim);
  ASSERT_GE(ghost, 0);
  schedulers::OmpStaticDriver driver;
  sim.state().position[3 * ghost + 1] -= 1e-6;
  const harness::MeasuredRun run =
      harness::measure_run(sim, driver, 0, kernels::Instrumentation::off, nullptr);
  EXPECT_FALSE(run.verification.passed);
  EXPECT_THAT(::testing::PrintToString(run.verification.failures), HasSubstr("crack: a ghost is"));
}

TEST(SweepVerification, ARowWithAParticleInsideTheObstacleIsFailed) {
  // Two runs of the same sweep cell against the same 1-thread reference: one as simulated,
  // one with a particle pushed into the box after its steps (its bytes then differ too, so
  // the reference comparison is left out: the penetration alone must fail the row).
  const auto level = kernels::Instrumentation::loops;
  const json binding = {{"mode", "none"}, {"bound", false}, {"threads", json::array()}};
  omp_set_num_threads(1);
  schedulers::OmpStaticDriver driver;
  kernels::Simulation good(sheet_on_box());
  const auto passing = undisturbed({harness::measure_run(good, driver, 2, level, nullptr)});
  ASSERT_TRUE(passing[0].verification.passed);
  kernels::Simulation bad(sheet_on_box());
  const harness::MeasuredRun timed = harness::measure_run(bad, driver, 2, level, nullptr);
  ASSERT_TRUE(timed.verification.passed);
  bad.state().position[3 * bad.mesh().slot(4, 4) + 2] = -0.001;
  harness::MeasuredRun run = harness::measure_run(bad, driver, 0, level, nullptr);
  EXPECT_FALSE(run.verification.passed);
  run.accounting = timed.accounting;  // the row keeps the 2 steps' times
  const auto penetrating = undisturbed({run});

  json document = {
      {"schema", "clothbench.sweep"},
      {"schema_version", harness::kSweepSchemaVersion},
      {"created_utc", "2024-01-01T00:00:00Z"},
      {"updated_utc", "2024-01-01T00:00:00Z"},
      {"complete", true},
      {"command", {"clothbench", "sweep"}},
      {"settings", {{"schedulers", {"static", "dynamic:1"}}, {"threads", {1}}, {"repeat", 1},
                    {"warmup_steps", 0}, {"steps", 2}, {"instrument", "loops"}, {"bind", "none"},
                    {"oversubscribe", false}}},
      {"scene", {{"name", "penetrating"}, {"file", "t.toml"}, {"hash", "0"}, {"source", ""}}},
      {"machine", json::object()},
      {"openmp_environment", json::object()},
      {"reference", {{"scheduler", "static@blocks"}, {"threads", 1}, {"state_digest", "0"}}},
      {"rows",
       {harness::make_row("static", "static@blocks", "", 1, false, passing, passing, level, 2,
                          binding),
        harness::make_row("dynamic:1", "dynamic:1@blocks", "", 1, false, penetrating,
                          penetrating, level, 2, binding)}}};
  harness::add_derived(document);
  EXPECT_THAT(harness::validate_sweep_document(document), ::testing::IsEmpty());
  const json& failed = document["rows"][1];
  EXPECT_FALSE(failed["verification"]["passed"].get<bool>());
  ASSERT_FALSE(failed["verification"]["failures"].empty());
  EXPECT_THAT(failed["verification"]["failures"][0].get<std::string>(),
              HasSubstr("a particle is 0.001 m inside an obstacle"));
  EXPECT_TRUE(failed["derived"]["speedup"].is_null());
  EXPECT_TRUE(document["rows"][0]["verification"]["passed"].get<bool>());
  const std::string markdown = harness::format_markdown(document);
  // The run counts as the row's uninstrumented and its instrumented run: two failed checks.
  EXPECT_THAT(markdown, HasSubstr("| - | - | - | FAILED (2 checks) |")) << markdown;
  EXPECT_THAT(harness::format_csv(document), HasSubstr(",,,,FAILED,clean\n"));
}

}  // namespace
}  // namespace clothbench
