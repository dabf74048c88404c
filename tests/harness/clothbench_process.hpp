// The built `clothbench` binary run as a child process, for the integration tests of the
// command line (tests/harness/integration_*.cpp).
#pragma once

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

namespace clothbench_test {

namespace fs = std::filesystem;

/// The clothbench binary of this build (tests/CMakeLists.txt defines its path), or
/// $CLOTHBENCH_BINARY when set.
inline fs::path binary() {
  if (const char* b = std::getenv("CLOTHBENCH_BINARY"); b != nullptr && *b != '\0') return b;
  return CLOTHBENCH_BINARY;
}

struct Outcome {
  int exit_code = -1;  ///< -1 when the child did not exit normally
  std::string output;  ///< stdout and stderr
};

/// `s` in single quotes for the shell (no single quotes inside, as in every test path).
inline std::string quote(const std::string& s) { return "'" + s + "'"; }

/// Runs a shell command line: its exit code and what it wrote to stdout (redirect stderr in
/// the command to keep it).
inline Outcome run_command(const std::string& command) {
  Outcome outcome;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return outcome;
  char buffer[4096];
  while (std::fgets(buffer, sizeof buffer, pipe) != nullptr) outcome.output += buffer;
  const int status = pclose(pipe);
  outcome.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return outcome;
}

/// Runs clothbench with `arguments` (already shell-quoted where needed); `environment` is
/// put in front of the command, e.g. "OMP_NUM_THREADS=3".
inline Outcome run(const std::string& arguments, const std::string& environment = {}) {
  // A hung child (a kernel deadlock) fails the test instead of blocking it.
  return run_command((environment.empty() ? "" : "env " + environment + " ") +
                     "timeout -s KILL 300 " + quote(binary().string()) + " " + arguments +
                     " 2>&1");
}

/// Starts clothbench with `arguments` (no shell) in the background, its stdout and stderr
/// going to `log`; returns the child's pid (0 on failure).
inline pid_t spawn(const std::vector<std::string>& arguments, const fs::path& log) {
  std::vector<std::string> words = {binary().string()};
  words.insert(words.end(), arguments.begin(), arguments.end());
  std::vector<char*> argv;
  for (auto& w : words) argv.push_back(w.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t files;
  posix_spawn_file_actions_init(&files);
  posix_spawn_file_actions_addopen(&files, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0644);
  posix_spawn_file_actions_adddup2(&files, STDOUT_FILENO, STDERR_FILENO);
  pid_t child = 0;
  const int error = posix_spawn(&child, argv[0], &files, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&files);
  return error == 0 ? child : 0;
}

inline std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

inline nlohmann::json read_json(const fs::path& file) {
  std::ifstream in(file);
  return nlohmann::json::parse(in);
}

/// An empty temporary directory name unique to this process.
inline fs::path fresh_dir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("clothbench-test-" + name + "-" + std::to_string(getpid()));
  fs::remove_all(dir);
  return dir;
}

/// Hardware threads as `clothbench info --json` reports them (cpu.pus).
inline int hardware_threads() {
  const Outcome info = run("info --json");
  return nlohmann::json::parse(info.output)["cpu"]["pus"].get<int>();
}

}  // namespace clothbench_test
