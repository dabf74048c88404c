// libFuzzer target over the scene loader (harness/scene): each input is read twice, as a
// scene file (parse_scene, with the shipped fabric presets) and as a presets file (every
// preset it names, validated). Besides crashes, hangs and sanitizer reports it aborts on:
//  - a rejection that is not a SceneError (any other exception escaping the loader);
//  - a SceneError whose message does not start with `FILE:LINE:COLUMN: ` naming this input
//    at a line that exists, followed by `[section]` (and the key) or `TOML syntax error`,
//    or that holds a control character (it would not print whole on one line);
//  - an accepted scene that breaks what the loader promises (scenarios/README.md ranges),
//    since the kernel and the run harness rely on those without checking again.
// With CLOTHBENCH_FUZZ_SIMULATION=1 accepted scenes of up to 4096 particles are also built
// into a kernels::Simulation, and any exception from that is reported as a scene the
// loader should have refused; at exit the target prints how many it built and exits 1 when
// that is none (the check was asked for but never ran), and a value other than 0 or 1 is
// refused at start. scripts/fuzz-check runs this target for a bounded time, once as a loader
// check and once with CLOTHBENCH_FUZZ_SIMULATION=1; the Clang suite replays the seeds both
// ways (tests/fuzz/CMakeLists.txt). Its
// -rss_limit_mb also caps single allocations, so a scene that makes the loader allocate
// in proportion to its particle count is reported too.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>
#include <string_view>

#include "harness/scene/fabric_reader.hpp"
#include "harness/scene/scene.hpp"
#include "kernels/simulation.hpp"

namespace {

namespace harness = clothbench::harness;
namespace kernels = clothbench::kernels;

constexpr std::string_view kSceneName = "fuzz-scene.toml";
constexpr std::string_view kPresetsName = "fuzz-presets.toml";

bool build_simulations = false;
long long simulations_built = 0;  // accepted scenes built into a kernels::Simulation
std::filesystem::path presets_file;

[[noreturn]] void fail(std::string_view what, std::string_view detail) {
  std::fprintf(stderr, "\nfuzz_scene: %.*s\n  %.*s\n", static_cast<int>(what.size()), what.data(),
               static_cast<int>(detail.size()), detail.data());
  std::abort();
}

void require(bool condition, std::string_view what) {
  if (!condition) fail("accepted scene breaks a loader guarantee", what);
}

// Reads the decimal number at `text[at...]`; advances `at`. -1 when there is none.
long long read_number(std::string_view text, std::size_t& at) {
  long long value = -1;
  while (at < text.size() && text[at] >= '0' && text[at] <= '9') {
    value = (value < 0 ? 0 : value * 10) + (text[at] - '0');
    if (value > 1'000'000'000) return -1;
    ++at;
  }
  return value;
}

// Aborts unless `message` reads `NAME:LINE:COLUMN: [section]...` or
// `NAME:LINE:COLUMN: TOML syntax error...` with LINE within `input`'s lines.
void check_message(std::string_view message, std::string_view name, std::string_view input) {
  if (!message.starts_with(name) || message.size() <= name.size() || message[name.size()] != ':') {
    fail("rejection does not start with the file name", message);
  }
  for (const char c : message) {
    if (static_cast<unsigned char>(c) < 0x20) fail("rejection has a control character", message);
  }
  std::size_t at = name.size() + 1;
  const long long line = read_number(message, at);
  if (line < 1 || at >= message.size() || message[at] != ':') {
    fail("rejection has no line number", message);
  }
  ++at;
  const long long column = read_number(message, at);
  if (column < 1 || message.substr(at, 2) != ": ") {
    fail("rejection has no column number", message);
  }
  at += 2;
  long long lines = 1;
  for (const char c : input) lines += c == '\n' ? 1 : 0;
  if (line > lines) fail("rejection points past the last line", message);
  const std::string_view rest = message.substr(at);
  if (rest.starts_with("TOML syntax error: ")) return;
  if (rest.empty() || rest[0] != '[' || rest.find("]") == std::string_view::npos) {
    fail("rejection names no [section] and key", message);
  }
}

bool finite(const Eigen::Vector3d& v) { return v.allFinite(); }
bool unit(const Eigen::Vector3d& v) { return std::abs(v.norm() - 1.0) < 1e-9; }

// What parse_scene guarantees about a scene it accepts (scenarios/README.md).
void check_accepted(const harness::Scene& scene) {
  const kernels::SimulationConfig& s = scene.simulation;
  const kernels::ClothConfig& c = s.cloth;
  require(scene.steps >= 1, "steps >= 1");
  require(c.particles_i >= 2 && c.particles_j >= 2, "particles >= 2");
  require(c.size_i > 0 && c.size_j > 0 && std::isfinite(c.size_i) && std::isfinite(c.size_j),
          "size_m finite and > 0");
  require(finite(c.origin), "origin_m finite");
  require(unit(c.axis_i) && unit(c.axis_j), "axes normalised");
  require(c.axis_i.cross(c.axis_j).norm() >= 1e-6, "axes not parallel");
  require(c.block_size >= 2, "block >= 2");
  require(c.initial_stretch > -1 && std::isfinite(c.initial_stretch), "initial_stretch > -1");
  require(c.initial_crumple >= 0 && std::isfinite(c.initial_crumple), "initial_crumple_m >= 0");
  for (const auto& [i, j] : c.pinned) {
    require(i >= 0 && i < c.particles_i && j >= 0 && j < c.particles_j, "pins inside the grid");
  }
  const kernels::KesParameters& f = s.fabric;
  require(
      f.weight_mg_per_cm2 > 0 && f.thickness_mm > 0 && f.fm_gf_per_cm > 0 && f.kappa0_per_cm > 0,
      "fabric values > 0");
  for (const kernels::KesDirection* d : {&f.warp, &f.weft}) {
    require(d->emt_percent > 0 && d->emt_percent < 100, "emt_percent in (0, 100)");
    require(d->lt > 0 && d->lt < 2, "lt in (0, 2)");
    require(d->rt_percent > 0 && d->rt_percent <= 100, "rt_percent in (0, 100]");
    require(d->bending_b > 0 && d->bending_2hb >= 0, "bending_b > 0, bending_2hb >= 0");
  }
  require(s.time.step > 0 && std::isfinite(s.time.step), "step_s > 0");
  require(s.time.damping >= 0 && s.time.damping < 1, "damping in [0, 1)");
  require(finite(s.time.gravity), "gravity finite");
  require(s.contact.distance > 0 && s.contact.stiffness > 0, "contact values > 0");
  const kernels::SolverConfig& v = s.solver;
  require(v.tolerance > 0 && v.max_iterations >= 1 && v.numeric_step > 0, "solver ranges");
  require(v.weight_newton + v.weight_stretch + v.weight_bend + v.weight_contact > 0,
          "some weight > 0");
  const kernels::AmrcConfig& a = s.amrc;
  require(a.refine_threshold > a.coarsen_threshold && a.coarsen_threshold >= 0,
          "refine_threshold > coarsen_threshold >= 0");
  require(a.check_every >= 1 && a.levels >= 0 && a.levels <= 16, "amrc ranges");
  if (a.enabled) {
    const int stride = 1 << a.levels;
    require(a.levels >= 1, "levels >= 1 when enabled");
    require((c.particles_i - 1) % stride == 0 && (c.particles_j - 1) % stride == 0 &&
                c.particles_i > stride && c.particles_j > stride,
            "AMRC sizes 2^L n + 1");
  }
  for (const kernels::ObstacleConfig& o : s.obstacles) {
    require(finite(o.center) && unit(o.normal) && unit(o.axis), "obstacle vectors");
    require(o.half_extents.minCoeff() > 0 && o.radius > 0 && o.half_length > 0 &&
                finite(o.half_extents) && std::isfinite(o.radius) && std::isfinite(o.half_length),
            "obstacle sizes > 0");
  }
  for (const kernels::SceneEvent& e : s.events) {
    require(e.step >= 1 && e.step <= e.until_step && e.until_step <= scene.steps,
            "event steps: 1 <= step <= until_step <= steps");
    require(finite(e.displacement) && finite(e.velocity) && finite(e.force),
            "event vectors finite");
    if (e.kind == kernels::SceneEventKind::move_obstacle) {
      require(e.obstacle >= 0 && e.obstacle < static_cast<int>(s.obstacles.size()),
              "event obstacle index");
    } else {
      require(e.particle_i >= 0 && e.particle_i < c.particles_i && e.particle_j >= 0 &&
                  e.particle_j < c.particles_j,
              "event particle inside the grid");
    }
  }
  // The run harness estimates the memory before it allocates; the estimate must not wrap.
  const std::size_t bytes = kernels::estimate_memory_bytes(s);
  require(
      bytes >= static_cast<std::size_t>(c.particles_i) * static_cast<std::size_t>(c.particles_j),
      "memory estimate does not overflow");
}

void fuzz_scene(std::string_view text) {
  harness::Scene scene;
  try {
    scene = harness::parse_scene(text, std::string(kSceneName), presets_file);
  } catch (const harness::SceneError& error) {
    check_message(error.what(), kSceneName, text);
    return;
  } catch (const std::exception& error) {
    fail("the scene loader threw something other than SceneError", error.what());
  }
  check_accepted(scene);
  const kernels::ClothConfig& c = scene.simulation.cloth;
  if (build_simulations && static_cast<long long>(c.particles_i) * c.particles_j <= 4096) {
    try {
      const kernels::Simulation simulation(scene.simulation);
      (void)simulation.diagnostics();
      ++simulations_built;
    } catch (const std::exception& error) {
      fail("the kernel refused a scene the loader accepted", error.what());
    }
  }
}

void fuzz_presets(std::string_view text) {
  namespace detail = harness::scene_detail;
  const std::string name(kPresetsName);
  try {
    const detail::PresetsDocument presets{name, detail::parse_toml(text, name)};
    for (const std::string& preset : detail::preset_names(presets)) {
      try {
        (void)detail::find_preset(presets, preset);
      } catch (const harness::SceneError& error) {
        check_message(error.what(), kPresetsName, text);
      }
    }
  } catch (const harness::SceneError& error) {
    check_message(error.what(), kPresetsName, text);
  } catch (const std::exception& error) {
    fail("the presets reader threw something other than SceneError", error.what());
  }
}

// At exit under CLOTHBENCH_FUZZ_SIMULATION=1: how many scenes reached the kernel; none is a
// failure (exit 1), so a run that never exercised the check cannot pass as if it had.
void report_simulations() {
  std::fprintf(stderr,
               "fuzz_scene: CLOTHBENCH_FUZZ_SIMULATION=1: %lld accepted scenes built "
               "into a kernels::Simulation\n",
               simulations_built);
  if (simulations_built == 0) {
    std::fprintf(stderr,
                 "fuzz_scene: FAILED: no accepted scene of at most 4096 particles was "
                 "built, so the loader-versus-kernel check did not run\n");
    std::fflush(stderr);
    std::_Exit(1);
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  const char* build = std::getenv("CLOTHBENCH_FUZZ_SIMULATION");
  const std::string_view value = build == nullptr ? "" : build;
  if (value != "" && value != "0" && value != "1") {
    std::fprintf(stderr, "fuzz_scene: CLOTHBENCH_FUZZ_SIMULATION='%s': expected 0 or 1\n", build);
    std::exit(2);
  }
  build_simulations = value == "1";
  if (build_simulations) std::atexit(report_simulations);
  presets_file =
      std::filesystem::path(CLOTHBENCH_SOURCE_DIR) / "scenarios" / "presets" / "fabrics.toml";
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  fuzz_scene(text);
  fuzz_presets(text);
  return 0;
}
