// The estimators of docs/estimators.md: one path per call, returning the radiance estimate along a camera ray.
#pragma once
#include <atomic>

#include "integrators/features.h"
#include "integrators/russian_roulette.h"
#include "sampling/sample_dimensions.h"
#include "sampling/sampler.h"
#include "scene/scene.h"

namespace pt {

// Shadow rays stop just short of the light point: the light's own primitive is skipped too, so this factor
// only has to guard against geometry coplanar with the light (relative, so scale-independent). Shared by the
// path tracer's light samples and the bidirectional estimator's connections.
inline constexpr float kShadowRayShorten = 1.f - 0x1p-12f;

struct RayCount {
  uint64_t rays = 0;  // every ray cast: camera, bounce (closest hit) and shadow (any hit)
};

// Radiance arriving at the camera along `ray`, estimated with the scene's render settings and the given
// estimator, drawing random numbers from `sampler` (IndependentSampler or SobolSampler). Never allocates.
template <class Sampler>
Rgb estimate_radiance(const Scene& scene, const RenderSettings& settings, const Ray& ray, Sampler& sampler,
                      RayCount& count);

// A radiance estimator compiled for one geometry set (KernelFeature in scene.h). `features` (may be null: then
// none are gathered, at the cost of one test per vertex) receives the sample's feature buffers (features.h); the
// caller initialises it. `cancel` (may be null) is polled every kCancelPollBounces bounces, so that even a path
// that never ends (albedo 1, no roulette, no bounce limit) returns once it is set; the caller must then drop the
// sample.
template <class Sampler>
using RadianceKernel = Rgb (*)(const Scene&, const RenderSettings&, const Ray&, Sampler&, RayCount&,
                               PixelFeatures* features, const std::atomic<bool>* cancel);
inline constexpr int kCancelPollBounces = 256;

// The kernel compiled for exactly the scene's geometry, or with `generic` the one compiled for all features
// (same image, more work: for instruction-count comparisons). Resolve once per tile, call per sample.
template <class Sampler>
RadianceKernel<Sampler> select_kernel(const Scene& scene, bool generic);
// The feature set (KernelFeature) of the kernel select_kernel and select_batch_kernel pick.
inline uint32_t selected_kernel_features(const Scene& scene, bool generic) {
  return generic ? kAllFeatures : scene.kernel_features();
}

}  // namespace pt
