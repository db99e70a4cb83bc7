// `pathtracer stress`: the numerical-stability report. Runs the matrix of docs/accuracy.md (translations,
// scales, huge and tiny spheres, light-tight enclosures, furnaces, NaN-inviting scenes, film accumulation) and
// prints one row per check: scenario, parameter, measured value, expected value, verdict.
#pragma once
#include <cstdint>
#include <string>

namespace CLI {
class App;
}

namespace pt {

struct StressOptions {
  bool quick = false;  // the reduced matrix the test suite runs (well under 30 s)
  std::string csv;     // also write the table here
  std::string only;    // run only scenarios whose name contains this
  int threads = 0;
  double soak_seconds = 0.0;  // > 0: run the soak (cli/stress_soak.h) instead of the matrix
  uint64_t soak_seed = 1;
};

void add_stress_command(CLI::App& app, StressOptions& options);
// Exit status: 0 every required check passed, 1 some check failed, 2 bad options or the CSV cannot be written.
int run_stress(const StressOptions& options);

}  // namespace pt
