#include "cli/ray_throughput.h"

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>

#include "core/rng.h"
#include "core/thread_pool.h"
#include "geometry/interaction.h"
#include "geometry/simd_polygons.h"
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
      b.tfar.push_back(far);
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

RayBatch batch_from_recorded(const Scene& scene, const std::vector<RecordedRay>& rays) {
  RayBatch b;
  b.rays.reserve(rays.size());
  b.skip.assign(rays.size(), ~0u);
  b.tfar.reserve(rays.size());
  for (const RecordedRay& r : rays) {
    const DVec3 d(r.direction[0], r.direction[1], r.direction[2]);
    const double len = glm::length(d);
    const DVec3 o = DVec3(r.origin[0], r.origin[1], r.origin[2]) + double(r.tnear) * d - scene.world_origin;
    b.rays.push_back({Vec3(o), Vec3(d / len)});
    b.tfar.push_back(static_cast<float>((double(r.tfar) - r.tnear) * len));
  }
  return b;
}

std::vector<RecordedRay> recorded_from_batch(const Scene& scene, const RayBatch& batch) {
  std::vector<RecordedRay> out(batch.rays.size());
  for (size_t i = 0; i < out.size(); ++i) {
    const DVec3 o = DVec3(batch.rays[i].o) + scene.world_origin;
    for (int k = 0; k < 3; ++k) {
      out[i].origin[k] = static_cast<float>(o[k]);
      out[i].direction[k] = batch.rays[i].d[k];
    }
    out[i].tnear = 0.f;
    out[i].tfar = batch.tfar[i];
  }
  return out;
}

namespace {

constexpr size_t kChunk = 4096;  // rays per task: handing out tasks costs nothing measurable

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

RayThroughput measure_ray_throughput(const Scene& scene, const RayBatch& batch, int repeats, int threads,
                                     bool packets) {
  using Clock = std::chrono::steady_clock;
  ThreadPool pool(threads);
  const size_t n = batch.rays.size();
  const int tasks = static_cast<int>((n + kChunk - 1) / kChunk);
  std::vector<float> hit_t(n), half_t(n);
  // Runs `query(begin, end)` (returns how many of rays [begin, end) count) over all rays in parallel, in chunks;
  // returns Mrays/s and the count.
  const auto timed = [&](auto&& query, uint64_t& count) {
    std::atomic<uint64_t> total{0};
    const auto t0 = Clock::now();
    pool.parallel_for(tasks, [&](int task, int) { total += query(task * kChunk, std::min(n, (task + 1) * kChunk)); });
    const double s = std::chrono::duration<double>(Clock::now() - t0).count();
    count = total;
    return n / s * 1e-6;
  };
  // Closest hits, one ray at a time or kLanes at a time; records each ray's hit distance (−1 for none).
  const auto closest_query = [&](size_t begin, size_t end) {
    uint64_t hits = 0;
    for (size_t i = begin; i < end; i += packets ? kLanes : 1) {
      const int m = packets ? static_cast<int>(std::min<size_t>(kLanes, end - i)) : 1;
      Hit h[kLanes];
      bool found[kLanes];
      if (packets) scene.intersect_packet(&batch.rays[i], &batch.tfar[i], &batch.skip[i], m, h, found);
      else found[0] = scene.intersect(batch.rays[i], batch.tfar[i], batch.skip[i], h[0]);
      for (int l = 0; l < m; ++l) {
        hit_t[i + l] = found[l] ? h[l].t : -1.f;
        hits += found[l];
      }
    }
    return hits;
  };
  const auto shadow_query = [&](const std::vector<float>& t_max) {
    return [&](size_t begin, size_t end) {
      uint64_t blocked = 0;
      if (!packets) {
        for (size_t i = begin; i < end; ++i) blocked += scene.occluded(batch.rays[i], t_max[i], batch.skip[i], ~0u);
      } else {
        for (size_t i = begin; i < end; i += kLanes)
          blocked += std::popcount(scene.occluded_packet(&batch.rays[i], &t_max[i], &batch.skip[i], nullptr,
                                                         static_cast<int>(std::min<size_t>(kLanes, end - i))));
      }
      return blocked;
    };
  };
  RayThroughput r;
  r.rays = n;
  std::vector<double> closest, shadow, half;
  for (int rep = 0; rep < repeats; ++rep) {
    closest.push_back(timed(closest_query, r.closest_hits));
    if (rep == 0)
      for (size_t i = 0; i < n; ++i) half_t[i] = i % 2 == 1 && hit_t[i] >= 0.f ? 0.99f * hit_t[i] : batch.tfar[i];
    shadow.push_back(timed(shadow_query(batch.tfar), r.occluded));
    half.push_back(timed(shadow_query(half_t), r.occluded_half));
  }
  r.closest_mrays_per_s = median(closest);
  r.shadow_mrays_per_s = median(shadow);
  r.shadow_half_mrays_per_s = median(half);
  return r;
}

}  // namespace pt
