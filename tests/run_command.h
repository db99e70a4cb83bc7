// Runs the real `pathtracer` executable (PATHTRACER_EXE, set by CMake) as a user would, capturing its exit status,
// stdout and stderr. Shared by the CLI end-to-end tests of both test executables.
#pragma once
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace pt::test {

struct Run {
  int status;
  std::string out, err;
};

inline std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// `prefix` goes before the executable (environment changes, xvfb-run). Output goes to files unique to this
// process and call, since ctest may run test cases in parallel.
inline Run run_pathtracer(const std::string& prefix, const std::string& args) {
  static int counter = 0;
  const std::string stem = "cli_" + std::to_string(getpid()) + "_" + std::to_string(counter++);
  const std::string cmd = prefix + " \"" + PATHTRACER_EXE + "\" " + args + " > " + stem + ".out 2> " + stem + ".err";
  const int raw = std::system(cmd.c_str());
  Run r{WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, slurp(stem + ".out"), slurp(stem + ".err")};
  std::filesystem::remove(stem + ".out");
  std::filesystem::remove(stem + ".err");
  return r;
}

}  // namespace pt::test
