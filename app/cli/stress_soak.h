// `pathtracer stress --soak SECONDS`: the long-running check of the interactive path. It drives a RenderSession
// the way the viewer does -- random scenes, random typed edits (materials, camera, environment), render-setting
// changes, restarts, pauses, thread-count changes -- for the given time, takes every published frame and checks
// it, and watches the process's memory. See docs/reliability.md ("Soak").
#pragma once
#include <cstdint>

namespace pt {

struct SoakOptions {
  double seconds = 0.0;  // how long to run
  uint64_t seed = 1;     // of the random actions (the run is random, not reproducible to the frame: threads race)
  int threads = 0;       // render threads at most; 0 = all hardware threads
};

// Exit status: 0 no problem; 1 a published frame held a non-finite value, the session rejected a non-finite
// sample or refused a valid scene, or memory grew by more than kSoakMaxGrowthBytes after the warm-up.
int run_soak(const SoakOptions& options);

inline constexpr uint64_t kSoakMaxGrowthBytes = 64ull << 20;

}  // namespace pt
