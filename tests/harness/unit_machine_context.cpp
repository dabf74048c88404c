// Machine context: every documented key is present with a sane type and value.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <omp.h>

#include <sched.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>
#include <string>

#include "harness/machine/git_revision.hpp"
#include "harness/machine/machine_context.hpp"

namespace {

using clothbench::harness::machine_context;
using nlohmann::json;

TEST(MachineContext, TopologyIsSane) {
  const json c = machine_context();
  const json& cpu = c.at("cpu");
  EXPECT_TRUE(cpu.at("model").is_string());
  EXPECT_FALSE(cpu.at("model").get<std::string>().empty());
  EXPECT_GE(cpu.at("packages").get<int>(), 1);
  EXPECT_GE(cpu.at("cores").get<int>(), cpu.at("packages").get<int>());
  EXPECT_GE(cpu.at("pus").get<int>(), cpu.at("cores").get<int>());
  EXPECT_GE(cpu.at("numa_nodes").get<int>(), 1);
  for (const char* level : {"L1d", "L2", "L3"}) {
    const json& cache = cpu.at("caches").at(level);
    EXPECT_TRUE(cache.at("size_bytes").is_number_unsigned()) << level;
    EXPECT_GE(cache.at("count").get<int>(), 0) << level;
    EXPECT_EQ(cache.at("count").get<int>() == 0, cache.at("size_bytes").get<std::uint64_t>() == 0)
        << level;
  }
  EXPECT_TRUE(cpu.at("hwloc_api_version").is_string());
  EXPECT_EQ(cpu.at("pus").get<int>(), clothbench::harness::hardware_threads());
  EXPECT_TRUE(cpu.at("vendor").is_string());
  for (const char* number : {"family", "model_number", "stepping"})
    EXPECT_GE(cpu.at(number).get<int>(), -1) << number;
  const std::string isa = cpu.at("vector_isa").get<std::string>();
  EXPECT_TRUE(isa == "avx512f" || isa == "avx2+fma" || isa == "sse2") << isa;
  EXPECT_GT(c.at("memory").at("total_bytes").get<std::uint64_t>(), 0u);
  EXPECT_EQ(c.at("memory").at("total_bytes").get<std::uint64_t>(),
            clothbench::harness::total_memory_bytes());
}

// The figures against the system's own sources, read here without the code under test.
TEST(MachineContext, ProcessorsAndMemoryAgreeWithTheSystem) {
  const json c = machine_context();
  // hwloc counts the PUs this process may use (or every online one): between the affinity
  // mask and the online processors.
  cpu_set_t mask;
  CPU_ZERO(&mask);
  ASSERT_EQ(sched_getaffinity(0, sizeof mask, &mask), 0);
  const int allowed = CPU_COUNT(&mask);
  const long online = sysconf(_SC_NPROCESSORS_ONLN);
  const int pus = c.at("cpu").at("pus").get<int>();
  EXPECT_GE(pus, allowed) << "sched_getaffinity allows " << allowed;
  EXPECT_LE(pus, online) << "sysconf: " << online << " online";
  // Memory: MemTotal of /proc/meminfo (kB).
  std::ifstream meminfo("/proc/meminfo");
  ASSERT_TRUE(meminfo) << "/proc/meminfo";
  std::string key;
  std::uint64_t kib = 0;
  while (meminfo >> key) {
    if (key == "MemTotal:") {
      meminfo >> kib;
      break;
    }
    meminfo.ignore(256, '\n');
  }
  ASSERT_GT(kib, 0u) << "no MemTotal in /proc/meminfo";
  const double total = static_cast<double>(c.at("memory").at("total_bytes").get<std::uint64_t>());
  EXPECT_NEAR(total, 1024.0 * static_cast<double>(kib), 1e-3 * 1024.0 * static_cast<double>(kib));
}

// The processor's identity against /proc/cpuinfo's first block, parsed here on its own: two
// processors with one model name and one set of cache sizes (a VM's "AMD EPYC") must differ in
// the context, or a resumed sweep could mix their runs.
TEST(MachineContext, ProcessorIdentityAgreesWithProcCpuinfo) {
  std::ifstream cpuinfo("/proc/cpuinfo");
  if (!cpuinfo) GTEST_SKIP() << "no /proc/cpuinfo";
  std::map<std::string, std::string> fields;
  std::string line;
  while (std::getline(cpuinfo, line) && !line.empty()) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string key = line.substr(0, colon);
    key.erase(key.find_last_not_of(" \t") + 1);
    std::string value = colon + 1 < line.size() ? line.substr(colon + 1) : "";
    value.erase(0, value.find_first_not_of(" \t") == std::string::npos
                       ? value.size()
                       : value.find_first_not_of(" \t"));
    fields.emplace(key, value);
  }
  if (!fields.count("cpu family")) GTEST_SKIP() << "/proc/cpuinfo has no x86 identity";
  const json cpu = machine_context().at("cpu");
  EXPECT_EQ(cpu.at("vendor").get<std::string>(), fields["vendor_id"]);
  EXPECT_EQ(cpu.at("family").get<int>(), std::stoi(fields["cpu family"]));
  EXPECT_EQ(cpu.at("model_number").get<int>(), std::stoi(fields["model"]));
  EXPECT_EQ(cpu.at("stepping").get<int>(), std::stoi(fields["stepping"]));
  // The vector kernel's lanes follow the instruction sets the kernel enabled.
  std::istringstream flags(fields["flags"]);
  std::set<std::string> has;
  for (std::string flag; flags >> flag;) has.insert(flag);
  const std::string expected = has.count("avx512f")                    ? "avx512f"
                               : has.count("avx2") && has.count("fma") ? "avx2+fma"
                                                                       : "sse2";
  EXPECT_EQ(cpu.at("vector_isa").get<std::string>(), expected);
  EXPECT_THAT(clothbench::harness::machine_summary(machine_context()),
              ::testing::HasSubstr("family " + std::to_string(cpu.at("family").get<int>()) +
                                   " model " + std::to_string(cpu.at("model_number").get<int>()) +
                                   " stepping " + std::to_string(cpu.at("stepping").get<int>())));
}

TEST(MachineContext, SystemBuildAndDate) {
  const std::time_t before = std::time(nullptr);
  const json c = machine_context();
  const std::time_t after = std::time(nullptr);
  EXPECT_EQ(c.at("schema_version").get<int>(), clothbench::harness::kMachineContextSchemaVersion);
  EXPECT_FALSE(c.at("hostname").get<std::string>().empty());
  for (const char* key : {"sysname", "release", "version", "machine"})
    EXPECT_TRUE(c.at("os").at(key).is_string());
  EXPECT_EQ(c.at("os").at("sysname").get<std::string>(), "Linux");
  EXPECT_TRUE(c.at("load_average").is_array());
  const std::string id = c.at("compiler").at("id").get<std::string>();
  EXPECT_THAT(id, testing::AnyOf("gcc", "clang"));
  EXPECT_THAT(c.at("compiler").at("version").get<std::string>(),
              testing::MatchesRegex("[0-9]+\\.[0-9]+\\.[0-9]+"));
  EXPECT_FALSE(c.at("build").at("type").get<std::string>().empty());
  EXPECT_TRUE(c.at("build").at("flags").is_string());
  EXPECT_FALSE(c.at("build").at("git_revision").get<std::string>().empty());

  const std::string date = c.at("date_utc").get<std::string>();
  EXPECT_THAT(date,
              testing::MatchesRegex("[0-9]{4}-[0-9]{2}-[0-9]{2}T[0-9]{2}:[0-9]{2}:[0-9]{2}Z"));
  std::tm parsed{};
  std::istringstream in(date);
  in >> std::get_time(&parsed, "%Y-%m-%dT%H:%M:%SZ");
  ASSERT_FALSE(in.fail()) << date;
  const std::time_t then = timegm(&parsed);
  // The date is the clock's reading while the context was taken (to the second).
  EXPECT_LE(before, then) << date;
  EXPECT_LE(then, after) << date;
}

TEST(MachineContext, OpenMpRuntimeAndSettings) {
  ASSERT_EQ(setenv("OMP_SCHEDULE", "monotonic:dynamic,7", 1), 0);
  ASSERT_EQ(setenv("GOMP_CLOTHBENCH_TEST", "1", 1), 0);
  omp_set_schedule(static_cast<omp_sched_t>(omp_sched_dynamic | omp_sched_monotonic), 7);
  const json c = machine_context();
  const json& omp = c.at("openmp");
  EXPECT_GE(omp.at("version").get<int>(), 201107);  // OpenMP 3.1 or later
  EXPECT_THAT(omp.at("runtime").at("name").get<std::string>(),
              testing::AnyOf("libgomp", "libomp", "libiomp5"));
  EXPECT_FALSE(omp.at("runtime").at("path").get<std::string>().empty());
  EXPECT_EQ(omp.at("max_threads").get<int>(), omp_get_max_threads());
  EXPECT_EQ(omp.at("num_procs").get<int>(), omp_get_num_procs());
  EXPECT_TRUE(omp.at("dynamic").is_boolean());
  EXPECT_TRUE(omp.at("proc_bind").is_string());
  EXPECT_EQ(omp.at("schedule").at("kind").get<std::string>(), "dynamic");
  EXPECT_EQ(omp.at("schedule").at("chunk").get<int>(), 7);
  EXPECT_TRUE(omp.at("schedule").at("monotonic").get<bool>());
  EXPECT_EQ(omp.at("environment").at("OMP_SCHEDULE").get<std::string>(), "monotonic:dynamic,7");
  EXPECT_EQ(omp.at("environment").at("GOMP_CLOTHBENCH_TEST").get<std::string>(), "1");
  EXPECT_FALSE(omp.at("environment").contains("PATH"));
  unsetenv("GOMP_CLOTHBENCH_TEST");
}

// The revision is taken when the binary is built, so it names the HEAD of the tree the tests
// were built from (one taken at configure time names whatever was checked out then).
TEST(MachineContext, GitRevisionIsTheHeadTheBinaryWasBuiltFrom) {
  const std::string revision = clothbench::harness::git_revision();
  EXPECT_EQ(machine_context().at("build").at("git_revision").get<std::string>(), revision);
  ASSERT_THAT(revision, testing::MatchesRegex("[0-9a-f]{12}(-dirty)?|unknown"));
  std::string head;
  const std::string command =
      std::string("git -C '") + CLOTHBENCH_SOURCE_DIR + "' rev-parse --short=12 HEAD 2>/dev/null";
  if (FILE* pipe = popen(command.c_str(), "r")) {
    char line[64] = {};
    if (std::fgets(line, sizeof line, pipe) != nullptr) head = line;
    pclose(pipe);
  }
  while (!head.empty() && (head.back() == '\n' || head.back() == '\r')) head.pop_back();
  if (head.empty()) {
    EXPECT_EQ(revision, "unknown") << "no git checkout at " << CLOTHBENCH_SOURCE_DIR;
  } else {
    EXPECT_EQ(revision.substr(0, 12), head)
        << "the binary was built from another commit than the checkout's HEAD: rebuild";
  }
}

TEST(MachineContext, SummaryMentionsTheEssentials) {
  const json c = machine_context();
  const std::string text = clothbench::harness::machine_summary(c);
  EXPECT_THAT(text, testing::HasSubstr(c.at("cpu").at("model").get<std::string>()));
  EXPECT_THAT(text, testing::HasSubstr(c.at("openmp").at("runtime").at("name").get<std::string>()));
  EXPECT_THAT(text, testing::HasSubstr("PU(s)"));
  EXPECT_THAT(clothbench::harness::version_string(),
              testing::HasSubstr(c.at("build").at("git_revision").get<std::string>()));
}

}  // namespace
