// Ray-casting throughput on a scene's own incoherent rays, apart from shading: how many closest-hit and any-hit
// (shadow) queries one thread answers per second. The rays are those of diffuse paths (camera rays, then
// cosine-distributed bounces from each hit), recorded once and replayed, so the figure measures only the
// intersection kernels.
#pragma once
#include <cstdint>
#include <vector>

#include "scene/scene.h"

namespace pt {

struct RayBatch {
  std::vector<Ray> rays;
  std::vector<uint32_t> skip;     // the primitive each ray leaves (~0u for camera rays)
  std::vector<float> shadow_t;    // for any-hit queries: alternately 0.99 × the distance to the closest hit and
                                  // a far bound, so about as many shadow rays pass as are blocked
};

// `count` rays of diffuse paths through the scene, deterministic for a given seed: camera rays through random
// pixels, then up to 8 cosine-weighted bounces per path (the secondary rays dominate, as in rendering).
RayBatch record_path_rays(const Scene& scene, size_t count, uint64_t seed);

struct RayThroughput {
  double closest_mrays_per_s = 0;  // single thread
  double any_mrays_per_s = 0;
  uint64_t hits = 0, occluded = 0;  // results, so the work cannot be optimised away (and as a sanity check)
};

// Replays the batch `repeats` times on the calling thread; reports the median of the repeats.
RayThroughput measure_ray_throughput(const Scene& scene, const RayBatch& batch, int repeats);

}  // namespace pt
