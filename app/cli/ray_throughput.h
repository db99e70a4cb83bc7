// Ray-casting throughput apart from shading: how many closest-hit and any-hit (shadow) queries per second the
// scene's intersection kernels answer on a fixed list of incoherent rays. The rays are either the scene's own
// diffuse path rays, recorded once, or a ray file (io/ray_file.h) shared with another ray caster.
#pragma once
#include <cstdint>
#include <vector>

#include "io/ray_file.h"
#include "scene/scene.h"

namespace pt {

struct RayBatch {
  std::vector<Ray> rays;          // camera-relative origin, unit direction
  std::vector<uint32_t> skip;     // the planar primitive each ray leaves (~0u: none, as for rays from a file)
  std::vector<float> tfar;        // both queries run over (0, tfar)
};

// `count` rays of diffuse paths through the scene, deterministic for a given seed: camera rays through random
// pixels, then up to 8 cosine-weighted bounces per path about the geometric normal (a path ends after 9 rays or
// when a ray leaves the scene). tfar is 4 × the scene's bounding radius + 1, beyond all geometry.
RayBatch record_path_rays(const Scene& scene, size_t count, uint64_t seed);

// Rays of a file, in world coordinates, as the scene's queries take them: the origin moved to tnear along the
// ray and made camera-relative (in double, then rounded), the direction normalised, tfar rescaled to match.
RayBatch batch_from_recorded(const Scene& scene, const std::vector<RecordedRay>& rays);
// The other way, for writing a ray file: world coordinates, tnear 0.
std::vector<RecordedRay> recorded_from_batch(const Scene& scene, const RayBatch& batch);

struct RayThroughput {
  double closest_mrays_per_s = 0;      // closest hit over (0, tfar)
  double shadow_mrays_per_s = 0;       // any hit over (0, tfar): blocked wherever the closest query hits
  double shadow_half_mrays_per_s = 0;  // any hit, with every odd-indexed ray that hits stopped at 0.99 × its
                                       // hit distance: about half the shadow rays pass and search everything
  uint64_t rays = 0, closest_hits = 0, occluded = 0, occluded_half = 0;
};

// Replays the batch `repeats` times on `threads` threads (rays handed out in chunks); reports the median rate of
// the repeats for each query and the counts, which are the same in every repeat. With `packets`, kLanes
// consecutive rays go to the scene's packet queries at a time (Scene::intersect_packet, occluded_packet).
RayThroughput measure_ray_throughput(const Scene& scene, const RayBatch& batch, int repeats, int threads = 1,
                                     bool packets = false);

}  // namespace pt
