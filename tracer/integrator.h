// The estimators of DESIGN.md: one path per call, returning the radiance estimate along a camera ray.
#pragma once
#include "rng.h"
#include "scene.h"

namespace pt {

struct RayCount {
  uint64_t rays = 0;  // every ray cast: camera, bounce (closest hit) and shadow (any hit)
};

// Radiance arriving at the camera along `ray`, estimated with the scene's render settings and the given
// estimator. Never allocates.
Rgb estimate_radiance(const Scene& scene, Estimator estimator, const Ray& ray, Pcg32& rng, RayCount& count);

}  // namespace pt
