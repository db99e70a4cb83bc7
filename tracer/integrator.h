// The estimators of DESIGN.md: one path per call, returning the radiance estimate along a camera ray.
#pragma once
#include "sampler.h"
#include "scene.h"

namespace pt {

struct RayCount {
  uint64_t rays = 0;  // every ray cast: camera, bounce (closest hit) and shadow (any hit)
};

// Radiance arriving at the camera along `ray`, estimated with the scene's render settings and the given
// estimator, drawing random numbers from `sampler` (IndependentSampler or SobolSampler). Never allocates.
template <class Sampler>
Rgb estimate_radiance(const Scene& scene, Estimator estimator, const Ray& ray, Sampler& sampler, RayCount& count);

// A radiance estimator compiled for one estimator and one feature set (KernelFeature in scene.h).
template <class Sampler>
using RadianceKernel = Rgb (*)(const Scene&, const Ray&, Sampler&, RayCount&);

// The kernel compiled for exactly the scene's features, or with `generic` the one compiled for all features
// (same image, more work: for instruction-count comparisons). Resolve once per tile, call per sample.
template <class Sampler>
RadianceKernel<Sampler> select_kernel(const Scene& scene, Estimator estimator, bool generic);

}  // namespace pt
