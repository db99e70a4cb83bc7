// `pathtracer bench`: run time against error. Not a test: it prints and writes figures, it never gates on time.
#pragma once
#include <string>
#include <vector>

namespace CLI {
class App;
}

namespace pt {

struct BenchOptions {
  bool quick = false;
  std::string out_dir = "bench-out";
  std::string cache_dir = "bench-cache";
  std::string reference_dir = "../shared/reference";
  std::vector<std::string> scenes{"cornell", "cornell-spheres", "shadertoy", "materials", "sky"};
  std::vector<std::string> estimators{"uniform", "cosine", "nee", "mis", "bdpt"};
  std::vector<std::string> samplers{"independent", "sobol", "sobol+adaptive"};
  double max_seconds = 64.0;
  int threads = 0;
  long long reference_spp = 4096;
  bool instructions = false;         // add instructions per sample (callgrind) to the summary
  std::string instructions_binary;  // the pathtracer valgrind runs for them (default: this one); implies the above
};

void add_bench_command(CLI::App& app, BenchOptions& options);
// Exit status: 0 done, 1 output could not be written, 2 bad options or scenes.
int run_bench(const BenchOptions& options);

}  // namespace pt
