// The scheduler registry: spec grammar, presets, construction and self-test.
#include "schedulers/registry.hpp"

#include <array>
#include <charconv>
#include <climits>
#include <optional>

#include "schedulers/active_lists_partitioner.hpp"
#include "schedulers/partitioner.hpp"
#include "schedulers/self_scheduling_partitioners.hpp"
#include "schedulers/self_test.hpp"
#include "schedulers/taskloop_partitioner.hpp"
#include "schedulers/text.hpp"

namespace clothbench::schedulers {
namespace {

// What a kind accepts. `default_chunk` 0 = a missing k means "no chunk clause".
struct KindTraits {
  std::string_view name;
  bool takes_chunk;
  std::int64_t default_chunk;
  bool takes_modifier;
  IterationSpace default_space;
};

constexpr std::array<KindTraits, 9> kinds{{
    {"static", true, 0, true, IterationSpace::blocks},
    {"dynamic", true, 1, true, IterationSpace::blocks},
    {"guided", true, 1, true, IterationSpace::blocks},
    {"runtime", false, 0, true, IterationSpace::blocks},
    {"taskloop", true, 0, false, IterationSpace::blocks},
    {"fac2", true, 1, false, IterationSpace::blocks},
    {"tss", true, 1, false, IterationSpace::blocks},
    {"gss", true, 1, false, IterationSpace::blocks},
    {"active-lists", false, 0, false, IterationSpace::active},
}};

constexpr std::array<std::pair<std::string_view, std::string_view>, 6> presets{{
    {"paper-static", "static@blocks"},
    {"paper-dynamic1", "dynamic:1@blocks"},
    {"paper-dynamic2", "dynamic:2@blocks"},
    {"paper-dynamic3", "dynamic:3@blocks"},
    {"paper-guided", "guided:1@blocks"},
    {"paper-active-lists", "active-lists@active"},
}};

const KindTraits* find_kind(std::string_view name) {
  for (const KindTraits& kind : kinds) {
    if (kind.name == name) return &kind;
  }
  return nullptr;
}

[[noreturn]] void reject(std::string_view spec, const std::string& reason) {
  throw std::invalid_argument(
      concat("invalid scheduler '", spec, "': ", reason, "\n", scheduler_grammar()));
}

std::optional<OmpScheduleKind> omp_kind(std::string_view kind) {
  if (kind == "static") return OmpScheduleKind::static_schedule;
  if (kind == "dynamic") return OmpScheduleKind::dynamic_schedule;
  if (kind == "guided") return OmpScheduleKind::guided_schedule;
  if (kind == "runtime") return OmpScheduleKind::runtime_schedule;
  return std::nullopt;
}

// Builds the driver; `effective_modifier` replaces the spec's modifier in the compiled
// clause (the workaround), `note` says so.
std::unique_ptr<LoopDriver> build(const SchedulerSpec& spec, OmpScheduleModifier effective_modifier,
                                  std::string note) {
  if (const std::optional<OmpScheduleKind> kind = omp_kind(spec.kind)) {
    return std::make_unique<PartitionerDriver<OmpSchedulePartitioner>>(
        spec.space, std::move(note), *kind, spec.modifier, static_cast<int>(spec.chunk),
        effective_modifier);
  }
  if (spec.kind == "taskloop") {
    return std::make_unique<PartitionerDriver<TaskloopPartitioner>>(spec.space, std::move(note),
                                                                    spec.chunk);
  }
  if (spec.kind == "fac2") {
    return std::make_unique<PartitionerDriver<Factoring2Partitioner>>(spec.space, std::move(note),
                                                                      spec.chunk);
  }
  if (spec.kind == "tss") {
    return std::make_unique<PartitionerDriver<TrapezoidPartitioner>>(spec.space, std::move(note),
                                                                     spec.chunk);
  }
  if (spec.kind == "gss") {
    return std::make_unique<PartitionerDriver<GuidedSelfSchedulingPartitioner>>(
        spec.space, std::move(note), spec.chunk);
  }
  return std::make_unique<PartitionerDriver<ActiveListsPartitioner>>(spec.space, std::move(note));
}

}  // namespace

std::string SchedulerSpec::canonical() const {
  std::string text = concat(modifier_prefix(modifier), kind);
  if (chunk > 0) text += concat(":", chunk);
  return text + "@" + space_name(space);
}

SchedulerSpec parse_scheduler_spec(std::string_view spec) {
  for (const auto& [preset, canonical] : presets) {
    if (spec == preset) return parse_scheduler_spec(canonical);
  }
  SchedulerSpec parsed;
  std::string_view rest = spec;
  std::optional<IterationSpace> space;
  if (const std::size_t at = rest.find('@'); at != std::string_view::npos) {
    const std::string_view suffix = rest.substr(at + 1);
    if (suffix == "blocks") {
      space = IterationSpace::blocks;
    } else if (suffix == "active") {
      space = IterationSpace::active;
    } else {
      reject(spec, concat("unknown iteration space '@", suffix, "' (use @blocks or @active)"));
    }
    rest = rest.substr(0, at);
  }
  for (const auto& [prefix, modifier] :
       {std::pair{std::string_view("monotonic:"), OmpScheduleModifier::monotonic},
        std::pair{std::string_view("nonmonotonic:"), OmpScheduleModifier::nonmonotonic}}) {
    if (rest.starts_with(prefix)) {
      parsed.modifier = modifier;
      rest.remove_prefix(prefix.size());
      break;
    }
  }
  std::string_view kind_name = rest;
  std::optional<std::string_view> chunk_text;
  if (const std::size_t colon = rest.find(':'); colon != std::string_view::npos) {
    kind_name = rest.substr(0, colon);
    chunk_text = rest.substr(colon + 1);
  }
  const KindTraits* kind = find_kind(kind_name);
  if (kind == nullptr) reject(spec, concat("unknown kind '", kind_name, "'"));
  parsed.kind = std::string(kind->name);
  if (parsed.modifier != OmpScheduleModifier::none && !kind->takes_modifier) {
    reject(spec, "'" + parsed.kind + "' takes no monotonic:/nonmonotonic: modifier");
  }
  parsed.chunk = kind->default_chunk;
  if (chunk_text) {
    if (!kind->takes_chunk) reject(spec, "'" + parsed.kind + "' takes no chunk size");
    std::int64_t value = 0;
    const char* first = chunk_text->data();
    const char* last = first + chunk_text->size();
    const auto [end, error] = std::from_chars(first, last, value);
    if (chunk_text->empty() || error != std::errc() || end != last || value < 1 ||
        value > INT_MAX) {
      reject(spec,
             concat("chunk size '", *chunk_text, "' is not an integer in [1, ", INT_MAX, "]"));
    }
    parsed.chunk = value;
  }
  parsed.space = space.value_or(kind->default_space);
  return parsed;
}

std::unique_ptr<LoopDriver> make_driver_without_self_test(std::string_view spec) {
  const SchedulerSpec parsed = parse_scheduler_spec(spec);
  return build(parsed, parsed.modifier, {});
}

std::unique_ptr<LoopDriver> make_driver(std::string_view spec) {
  const SchedulerSpec parsed = parse_scheduler_spec(spec);
  std::unique_ptr<LoopDriver> driver = build(parsed, parsed.modifier, {});
  const ProbeReport report = probe_exactly_once(*driver);
  if (report.exactly_once) return driver;
  // Workaround: OpenMP 5.0 (2.9.2) defines static schedules as monotonic, and a monotonic
  // schedule is a valid nonmonotonic one, so plain `schedule(static[,k])` is exactly
  // what `monotonic:static` / `nonmonotonic:static` promise.
  if (parsed.kind == "static" && parsed.modifier != OmpScheduleModifier::none) {
    const std::string clause =
        parsed.chunk > 0 ? concat("static,", parsed.chunk) : std::string("static");
    std::string note = concat("runtime defect: schedule(", modifier_prefix(parsed.modifier), clause,
                              ") ", report.describe(), "; using schedule(", clause,
                              "), which OpenMP defines as monotonic");
    std::unique_ptr<LoopDriver> workaround =
        build(parsed, OmpScheduleModifier::none, std::move(note));
    if (probe_exactly_once(*workaround).exactly_once) return workaround;
  }
  throw SchedulerDefectError(
      concat("scheduler '", parsed.canonical(),
             "' fails its self-test on this OpenMP runtime: ", report.describe()));
}

std::vector<std::string> available_schedulers() {
  return {"static@blocks",
          "static:4@blocks",
          "dynamic:1@blocks",
          "dynamic:2@blocks",
          "dynamic:3@blocks",
          "guided:1@blocks",
          "guided:4@blocks",
          "runtime@blocks",
          "monotonic:static@blocks",
          "monotonic:static:4@blocks",
          "nonmonotonic:static@blocks",
          "monotonic:dynamic:2@blocks",
          "nonmonotonic:dynamic:2@blocks",
          "monotonic:guided:1@blocks",
          "nonmonotonic:guided:1@blocks",
          "monotonic:runtime@blocks",
          "nonmonotonic:runtime@blocks",
          "taskloop@blocks",
          "taskloop:4@blocks",
          "fac2:1@blocks",
          "tss:1@blocks",
          "gss:1@blocks",
          "active-lists@active",
          "static@active",
          "dynamic:64@active",
          "guided:1@active"};
}

std::vector<std::pair<std::string, std::string>> scheduler_presets() {
  std::vector<std::pair<std::string, std::string>> result;
  for (const auto& [preset, canonical] : presets) result.emplace_back(preset, canonical);
  return result;
}

std::string scheduler_grammar() {
  std::string text =
      "scheduler spec: [monotonic:|nonmonotonic:]<kind>[:<k>][@blocks|@active]\n"
      "  kinds: static[:k] dynamic[:k] guided[:k] runtime  (OpenMP schedule clauses; modifiers "
      "allowed)\n"
      "         taskloop[:grainsize] fac2[:k] tss[:k] gss[:k] active-lists\n"
      "  k: integer >= 1 (default 1; static and taskloop without k use no chunk clause)\n"
      "  presets:";
  for (const auto& [preset, canonical] : presets) {
    text += concat(" ", preset, "=", canonical);
  }
  return text;
}

}  // namespace clothbench::schedulers
