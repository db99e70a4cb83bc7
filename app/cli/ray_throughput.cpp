#include "cli/ray_throughput.h"

#include <algorithm>
#include <chrono>

#include "geometry/interaction.h"
#include "core/rng.h"
#include "sampling/sampling.h"

namespace pt {

RayBatch record_path_rays(const Scene& scene, size_t count, uint64_t seed) {
  RayBatch b;
  Pcg32 rng(seed, 0x2f6b);
  const float far = static_cast<float>(4.0 * scene.bounding_radius + 1.0);
  while (b.rays.size() < count) {
    Ray ray = scene.camera.generate_ray(rng.next_float() * scene.width, rng.next_float() * scene.height);
    uint32_t skip = ~0u;
    for (int depth = 0; depth < 9 && b.rays.size() < count; ++depth) {
      Hit h;
      const bool hit = scene.intersect(ray, kInfinity, skip, h);
      b.rays.push_back(ray);
      b.skip.push_back(skip);
      // Alternately just short of the hit (unblocked: every primitive must be tested) and beyond it (blocked).
      b.shadow_t.push_back(hit && b.rays.size() % 2 == 0 ? 0.99f * h.t : far);
      if (!hit) break;
      const Interaction it = make_interaction(scene, ray, h);
      const Vec3 n = glm::dot(it.ng, ray.d) < 0.f ? it.ng : -it.ng;
      const Vec3 wi = Frame::from_normal(n).to_world(sample_cosine_hemisphere({rng.next_float(), rng.next_float()}));
      ray = {offset_ray_origin(it, wi), wi};
      skip = skip_on_leave(it);
    }
  }
  return b;
}

RayThroughput measure_ray_throughput(const Scene& scene, const RayBatch& batch, int repeats) {
  using Clock = std::chrono::steady_clock;
  std::vector<double> closest, any;
  RayThroughput r;
  const size_t n = batch.rays.size();
  for (int rep = 0; rep < repeats; ++rep) {
    uint64_t hits = 0, blocked = 0;
    auto t0 = Clock::now();
    for (size_t i = 0; i < n; ++i) {
      Hit h;
      hits += scene.intersect(batch.rays[i], kInfinity, batch.skip[i], h);
    }
    auto t1 = Clock::now();
    for (size_t i = 0; i < n; ++i) blocked += scene.occluded(batch.rays[i], batch.shadow_t[i], batch.skip[i], ~0u);
    auto t2 = Clock::now();
    closest.push_back(n / std::chrono::duration<double>(t1 - t0).count() * 1e-6);
    any.push_back(n / std::chrono::duration<double>(t2 - t1).count() * 1e-6);
    r.hits = hits;
    r.occluded = blocked;
  }
  std::sort(closest.begin(), closest.end());
  std::sort(any.begin(), any.end());
  r.closest_mrays_per_s = closest[closest.size() / 2];
  r.any_mrays_per_s = any[any.size() / 2];
  return r;
}

}  // namespace pt
