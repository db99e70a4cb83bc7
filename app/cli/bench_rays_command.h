// `pathtracer bench rays`: ray-casting throughput on a ray file (replay) or writing the scene's own path rays to
// one (record), so the project and another ray caster (Intel Embree: ../shared/peers/embree_rays) time exactly
// the same queries. Not a test: it prints figures. Format and method: docs/performance.md, "Ray files".
#pragma once
#include <string>

namespace CLI {
class App;
}

namespace pt {

struct BenchRaysOptions {
  std::string scene = "cornell";
  std::string rays_file;    // replay this file
  std::string record_file;  // or write the scene's own path rays here
  std::string tris_file;    // also write the scene's polygons as the peers' triangle file (PTTRIS01)
  long long count = 1 << 20;
  long long seed = 1;
  int threads = 1;
  int repeats = 5;
  bool packets = false;  // kLanes rays per query call (the packet kernels)
  std::string instancing = "auto";  // Instancing name
  bool json = false;
};

void add_bench_rays_command(CLI::App& bench, BenchRaysOptions& options);
// Exit status: 0 done, 1 the ray file could not be written, 2 bad options, scene or ray file.
int run_bench_rays(const BenchRaysOptions& options);

}  // namespace pt
