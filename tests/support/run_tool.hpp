// Running the project's programs from tests: the exit status and everything they printed.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <string>

namespace arlight::test {

struct RunResult {
  int status;
  std::string output;  // stdout and stderr
};

// Runs `exe args` through the shell, capturing stdout and stderr together.
inline RunResult run_tool(const std::string& exe, const std::string& args) {
  const std::string cmd = exe + " " + args + " 2>&1";
  RunResult r{-1, {}};
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  while (std::size_t n = std::fread(buf, 1, sizeof buf, p)) r.output.append(buf, n);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

// A fresh, empty folder under the system's temporary directory.
inline std::filesystem::path fresh_temp_dir(const std::string& name) {
  const std::filesystem::path d = std::filesystem::temp_directory_path() / ("arlight_test_" + name);
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

}  // namespace arlight::test
