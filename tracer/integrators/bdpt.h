// Bidirectional path tracing (Veach 1997, ch. 10; pbrt-v3 ch. 16 is the model): `Estimator::Bdpt`.
//
// Per camera sample, one camera subpath and one light subpath (a light chosen ∝ power, a point and a direction
// from lights/light_emission.h), then every connection strategy (s light vertices, t camera vertices):
// - s = 0: the camera subpath found a light by itself (through specular vertices only, E S+ L: summed over
//   both lobes of every glass vertex instead, specular_chain_emission in bdpt_kernels.h);
// - s = 1: a light sampled from a camera vertex (next-event estimation, lights/light_sampling.h);
// - t = 1: a light-subpath vertex joined to the eye, or to a point of a thin lens (light tracing): its
//   contribution lands on whatever pixel sees the vertex, a "splat", which the renderer adds after the pass
//   (render/renderer.h);
// - s, t ≥ 2: the two subpaths' end vertices joined by a shadow ray;
// - manifold: at a camera vertex that no connection can serve (seen through or in a smooth sphere or mirror),
//   next-event estimation through a smooth sphere, the specular path to a light point solved for
//   (bdpt_manifold.h; off with RenderSettings::bdpt_manifold).
// Each is weighted by the power heuristic over all strategies that could have produced the same path,
// computed from the per-vertex forward and reverse densities by pbrt-v3's ratio recursion (no second copy of
// the densities per strategy). Strategies through specular vertices are left out of the sum, so caustics seen
// through glass, reachable only by light tracing or by hitting the light, come from those alone.
//
// The estimator sees materials only through the BSDF interface and lights only through the light interfaces,
// like the path tracer. Subpath lengths follow RenderSettings: a strategy (s, t) makes a path of s + t − 2
// scattering events, at most max_bounces, the path tracer's meaning; Russian roulette from
// russian_roulette_depth ends subpaths early (unbiased: survivors are re-weighted; the MIS densities ignore it).
#pragma once
#include <atomic>
#include <vector>

#include "integrators/bdpt_vertex.h"
#include "integrators/integrator.h"
#include "integrators/material_at.h"

namespace pt {

// A light-traced contribution to pixel `pixel` (= y·width + x), to be added to that pixel's sample of the pass.
struct Splat {
  uint32_t pixel;
  Rgb value;
};

// A branch of the eye's pure-specular chains: a vertex reached through specular vertices only, the throughput
// up to it and its scattering event's index (bdpt_kernels.h, specular_chain_emission).
struct SpecularBranch {
  Interaction it;
  Vec3 wo{0.f};
  Rgb beta{1.f};
  uint32_t bounce = 0;
  float cone_width = 0.f;     // the camera's ray cone at it (material_at.h)
  bool textured = false;      // its material is `resolved`, else Scene::materials[it.material]
  MaterialScratch resolved;   // what its textures make the material at it
};

// Per-thread working memory of the estimator, kept between samples (no allocation per sample once grown).
struct BdptScratch {
  std::vector<BdptVertex> camera, light;
  std::vector<SpecularBranch> branches;
  // The textured materials of the subpaths' vertices, one slot per vertex index (BdptVertex::material).
  std::vector<MaterialScratch> camera_materials, light_materials;
};

// Estimates the radiance along camera_ray (t ≥ 2 strategies, returned in L) and appends the light-traced
// contributions of the sample's light subpath to `splats`; `features` (may be null) receives the camera
// subpath's feature buffers (features.h). Returns false if `cancel` was set (polled every kCancelPollBounces
// vertices): L and the splats appended are then to be dropped.
template <class Sampler>
using BdptKernel = bool (*)(const Scene&, const RenderSettings&, const Sampler&, const Ray& camera_ray,
                            BdptScratch&, std::vector<Splat>& splats, Rgb& L, PixelFeatures* features, RayCount&,
                            const std::atomic<bool>* cancel);

template <class Sampler>
BdptKernel<Sampler> select_bdpt_kernel(const Scene& scene, const RenderSettings& settings);

}  // namespace pt
