// Tests that need a tool the machine may lack (xvfb-run, xdotool, mpirun, gnuplot). Where it is missing such a
// test must not pass as if it had checked something: under CI=true (CI installs every tool the tests use,
// tools/bootstrap.sh) it fails; elsewhere it prints "SKIPPED: ..." and ctest reports it as skipped
// (SKIP_REGULAR_EXPRESSION in tests/CMakeLists.txt).
#pragma once
#include <doctest/doctest.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

namespace pt::test {

inline bool running_in_ci() {
  const char* ci = std::getenv("CI");
  return ci && std::string_view(ci) == "true";
}

// Reports the missing tool as above; the caller returns (or leaves out the checks that need it) after it.
inline void skip_for_missing(const std::string& tool, const std::string& what) {
  if (running_in_ci()) {
    FAIL_CHECK(tool << " not found under CI=true (CI installs it): " << what << " did not run");
    return;
  }
  std::printf("SKIPPED: %s not found: %s did not run\n", tool.c_str(), what.c_str());
  std::fflush(stdout);
}

}  // namespace pt::test
