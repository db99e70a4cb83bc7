// The wavefront batch kernel template (wavefront.h); integrator_independent.cpp and integrator_sobol.cpp
// instantiate it per feature set, beside the scalar kernels whose vertex code it shares.
#pragma once
#include "integrators/path_tracer.h"
#include "integrators/shading_lanes.h"
#include "integrators/wavefront.h"
#include "sampling/sobol_batch.h"

namespace pt {

namespace integrator_detail {

template <class Sampler, uint32_t F>
bool trace_batch(const Scene& s, const RenderSettings& settings, const Sampler* samplers, const Ray* camera_rays,
                 int n, Rgb* L, PixelFeatures* features, RayCount& count, const std::atomic<bool>* cancel) {
  const PathOptions o(settings, s.camera);
  // The batch's state (~64 KB of stack): paths by index, the queue of live paths for this bounce and the next,
  // and the shadow rays this bounce's vertices asked for.
  PathState paths[kWavefrontBatch];
  uint16_t live[kWavefrontBatch], next[kWavefrontBatch], shadow_owner[kWavefrontBatch];
  ShadowRay shadows[kWavefrontBatch];
  for (int i = 0; i < n; ++i) {
    paths[i].ray = camera_rays[i];
    paths[i].cone_spread = o.cone_spread_for(samplers[i].sample_index());
    if (features) paths[i].features.out = &features[i];
    live[i] = static_cast<uint16_t>(i);
  }
  int live_count = n;
  // Every live path is at the same bounce, so it asks for the same 2D dimensions: Sobol points are computed for
  // the whole queue at once (bit-identical to the path's own get_2d; sampling/sobol_batch.h).
  constexpr bool kBatchPoints = std::is_same_v<Sampler, SobolSampler>;
  using VertexSampler = std::conditional_t<kBatchPoints, SamplerWithPoints<Sampler>, const Sampler&>;
  // Zeroed: GCC cannot see that a queue position read through the sorted order was written.
  Vec2 light_points[kBatchPoints ? kWavefrontBatch : 1]{}, bsdf_points[kBatchPoints ? kWavefrontBatch : 1]{};
  // Polygons and spheres of the lanes' materials shade in lanes in every kernel with polygons or spheres
  // (shading_lanes.h), where shading_lanes_apply (wavefront.h) says so.
  constexpr bool kShadingLanes = (F & (kFeaturePolygons | kFeatureSpheres)) != 0;
  constexpr MaterialSet kM = (F & kFeatureGeneralMaterials) != 0 ? MaterialSet::Any : MaterialSet::Lambert;
  LaneShading lane_shading;
  const bool lanes_apply = kShadingLanes && shading_lanes_apply(s, F);
  // The kernels for any material shade a bounce's hits in lane_sort_key's order (wavefront.h): the hits by queue
  // position, and the keys of the scene's first kKeyedMaterials materials, looked up once per batch.
  constexpr bool kSortHits = kShadingLanes && kM == MaterialSet::Any;
  constexpr int kSortBatch = kSortHits ? kWavefrontBatch : kLanes;
  Hit hit_at[kSortBatch];
  bool found_at[kSortBatch];
  MaterialKeys material_keys;
  if (kSortHits && lanes_apply) material_keys.look_up(s);
  for (uint32_t bounce = 0; live_count > 0; ++bounce) {
    if (cancel && cancel->load(std::memory_order_relaxed)) return false;
    int next_count = 0, shadow_count = 0;
    // Polygons and spheres of the lanes' materials lit by next-event estimation are shaded kLanes at a time
    // (shading_lanes.h); every other vertex, and every lane that code hands back, by shade_vertex.
    const bool lanes = lanes_apply && o.light_sampling && static_cast<int>(bounce) < o.max_bounces;
    uint32_t light_dim = SamplerWithPoints<Sampler>::kNone, bsdf_dim = SamplerWithPoints<Sampler>::kNone;
    if constexpr (kBatchPoints) {
      if (o.light_sampling && SobolBatch::batched(o.dims.light_point(bounce))) {
        light_dim = o.dims.light_point(bounce);
        SobolBatch::get_2d(samplers, live, live_count, light_dim, light_points);
      }
      if (SobolBatch::batched(o.dims.bsdf_direction(bounce))) {
        bsdf_dim = o.dims.bsdf_direction(bounce);
        SobolBatch::get_2d(samplers, live, live_count, bsdf_dim, bsdf_points);
      }
    }
    // Path i's sampler at queue position j.
    const auto rng_at = [&](int j) -> VertexSampler {
      const uint16_t i = live[j];
      if constexpr (kBatchPoints) {
        return {samplers[i], light_dim, light_points[j], bsdf_dim, bsdf_points[j]};
      } else {
        (void)light_dim, (void)bsdf_dim;
        return samplers[i];
      }
    };
    // The vertices of k ≤ kLanes paths: lane l is queue position position(l), path ids[l], its hit hits[l]
    // (found[l]).
    const auto shade_packet = [&](int k, const auto& position, const uint16_t* ids, const Hit* hits,
                                  const bool* found) __attribute__((always_inline)) {
      // The queues' lengths in locals, which no store through a pointer can change (shade_packet_outlined).
      int n_next = next_count, n_shadow = shadow_count;
      if constexpr (kShadingLanes)
        if (lanes)
          shade_lanes<kM, F>(s, o, [&](int l) { return rng_at(position(l)); }, ids, k, hits, found, paths, bounce,
                              lane_shading, count);
      for (int l = 0; l < k; ++l) {
        const uint16_t i = ids[l];
        PathState& p = paths[i];
        if (!found[l]) {
          add_escaped_radiance(s, o, p);
          continue;
        }
        if (lanes && lane_shading.handled[l]) {
          if (lane_shading.shadow[l]) {
            shadows[n_shadow] = lane_shading.shadow_ray[l];
            shadow_owner[n_shadow++] = i;
          }
          if (lane_shading.continues[l]) next[n_next++] = i;
          continue;
        }
        const VertexSampler rng = rng_at(position(l));
        const VertexResult v = shade_vertex<std::decay_t<VertexSampler>, F>(s, o, rng, hits[l], p,
                                                                           shadows[n_shadow], count);
        if (v.shadow_ray) shadow_owner[n_shadow++] = i;
        if (v.continues) next[n_next++] = i;
      }
      next_count = n_next, shadow_count = n_shadow;
    };
    // The same as a call: in the kernels with spheres or sorted hits, the loops around it then compile to about 3 %
    // fewer instructions per sample (`materials`, `sky`, `shadertoy`, `cornell-spheres`); in the others, inlined, it
    // saves 0.7 % on `cornell` (docs/performance.md, session 45).
    const auto shade_packet_outlined = [&](int k, const auto& position, const uint16_t* ids, const Hit* hits,
                                           const bool* found) __attribute__((noinline)) {
      shade_packet(k, position, ids, hits, found);
    };
    constexpr bool kInlinePacket = !kSortHits && (F & kFeatureSpheres) == 0;
    // Closest hits kLanes at a time; then the vertices of those paths: at once, in the queue's order, or in the
    // kernels for any material after all the hits, in lane_sort_key's order (wavefront.h) where the lanes shade.
    for (int first = 0; first < live_count; first += kLanes) {
      const int k = std::min(kLanes, live_count - first);
      Ray rays[kLanes];
      float t_max[kLanes];
      uint32_t skip[kLanes];
      for (int l = 0; l < k; ++l) {
        const PathState& p = paths[live[first + l]];
        rays[l] = p.ray;
        t_max[l] = kInfinity;
        skip[l] = p.skip;
      }
      Hit* hits = hit_at + (kSortHits ? first : 0);
      bool* found = found_at + (kSortHits ? first : 0);
      intersect_scene_packet<F>(s, rays, t_max, skip, k, hits, found);
      count.rays += static_cast<uint64_t>(k);
      const auto in_queue = [first](int l) { return first + l; };
      if constexpr (kInlinePacket) shade_packet(k, in_queue, live + first, hits, found);
      else if constexpr (!kSortHits) shade_packet_outlined(k, in_queue, live + first, hits, found);
    }
    if constexpr (kSortHits) {
      uint16_t order[kWavefrontBatch];  // the queue positions in shading order
      if (lanes && material_keys.mixed) {  // a counting sort by key
        constexpr int kSortKeys = static_cast<int>(LaneSortKey::Count);
        uint8_t key_at[kWavefrontBatch];
        int start[kSortKeys + 1] = {};
        for (int j = 0; j < live_count; ++j) {
          key_at[j] = static_cast<uint8_t>(lane_sort_key(s, hit_at[j], found_at[j], material_keys));
          ++start[key_at[j] + 1];
        }
        for (int key = 0; key < kSortKeys; ++key) start[key + 1] += start[key];
        for (int j = 0; j < live_count; ++j) order[start[key_at[j]]++] = static_cast<uint16_t>(j);
      } else {
        for (int j = 0; j < live_count; ++j) order[j] = static_cast<uint16_t>(j);
      }
      for (int first = 0; first < live_count; first += kLanes) {
        const int k = std::min(kLanes, live_count - first);
        uint16_t ids[kLanes];
        Hit hits[kLanes];
        bool found[kLanes];
        for (int l = 0; l < k; ++l) {
          const int j = order[first + l];
          ids[l] = live[j];
          hits[l] = hit_at[j];
          found[l] = found_at[j];
        }
        shade_packet_outlined(k, [&order, first](int l) { return static_cast<int>(order[first + l]); }, ids, hits,
                              found);
      }
    }
    // Shadow rays kLanes at a time; an unblocked one adds its contribution (before the path's next vertex, as in
    // the scalar loop, so the sums round alike).
    for (int first = 0; first < shadow_count; first += kLanes) {
      const int k = std::min(kLanes, shadow_count - first);
      Ray rays[kLanes];
      float t_max[kLanes];
      uint32_t skip_a[kLanes], skip_b[kLanes];
      for (int l = 0; l < k; ++l) {
        const ShadowRay& sr = shadows[first + l];
        rays[l] = sr.ray;
        t_max[l] = sr.t_max;
        skip_a[l] = sr.skip_a;
        skip_b[l] = sr.skip_b;
      }
      const uint32_t blocked = occluded_scene_packet<F>(s, rays, t_max, skip_a, skip_b, k);
      for (int l = 0; l < k; ++l)
        if (!(blocked >> l & 1u)) paths[shadow_owner[first + l]].L += shadows[first + l].contribution;
    }
    std::copy(next, next + next_count, live);
    live_count = next_count;
  }
  for (int i = 0; i < n; ++i) L[i] = paths[i].L;
  return true;
}

template <class Sampler, size_t... F>
constexpr std::array<BatchKernel<Sampler>, sizeof...(F)> batch_kernels_for(std::index_sequence<F...>) {
  return {&trace_batch<Sampler, static_cast<uint32_t>(F)>...};
}

// As kKernels (path_tracer.h), generic only in instrumented builds (but for the lanes' kernel).
template <class Sampler>
constexpr std::array<BatchKernel<Sampler>, kAllFeatures + 1> make_batch_kernels() {
  if constexpr (kGenericKernelsOnly) {
    std::array<BatchKernel<Sampler>, kAllFeatures + 1> all{};
    all.fill(&trace_batch<Sampler, kAllFeatures>);
    // Except the kernel for Lambertian polygons: its shading lanes evaluate the Lambert-only lobe
    // (shading_lanes.h), which the sanitizers must see too (the generic kernel runs them with MaterialSet::Any).
    all[kFeaturePolygons] = &trace_batch<Sampler, kFeaturePolygons>;
    return all;
  } else {
    return batch_kernels_for<Sampler>(std::make_index_sequence<kAllFeatures + 1>{});
  }
}
template <class Sampler>
constexpr std::array<BatchKernel<Sampler>, kAllFeatures + 1> kBatchKernels = make_batch_kernels<Sampler>();

}  // namespace integrator_detail

template <class Sampler>
BatchKernel<Sampler> select_batch_kernel(const Scene& scene, const RenderSettings& settings) {
  if (!runs_wavefront(settings)) return nullptr;
  return integrator_detail::kBatchKernels<Sampler>[selected_kernel_features(scene, settings.generic_kernel)];
}

}  // namespace pt
