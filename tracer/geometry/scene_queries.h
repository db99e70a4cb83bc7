// Ray queries specialised on a kernel feature set F (see KernelFeature): primitive kinds outside F are not
// tested, not even by a branch. With F = kAllFeatures each kind is tested when the scene has some.
#pragma once
#include "scene/scene.h"

namespace pt {

// Closest hit in (0, t_max), never reporting `skip` (the planar primitive a spawned ray leaves; ~0u for none).
template <uint32_t F>
inline bool intersect_scene(const Scene& s, const Ray& ray, float t_max, uint32_t skip, Hit& hit) {
  bool found = false;
  if constexpr ((F & kFeaturePolygons) != 0) {
    const RayShear shear(ray.d);
    uint32_t id = 0;
    const auto scalar_test = [&](uint32_t i, float tm, PolygonHit& h) {
      return intersect_polygon(s.polygons, i, ray.o, shear, tm, h);
    };
    if (s.polygon_bvh.empty() ? closest_polygon(s.polygon_lanes, ray.o, shear, skip, t_max, id, scalar_test)
                              : closest_polygon_bvh(s.polygon_bvh, ray.o, ray.d, shear, skip, t_max, id, scalar_test)) {
      hit = {t_max, id};
      found = true;
    }
  }
  if constexpr ((F & kFeatureSpheres) != 0) {
    const uint32_t sb = s.sphere_begin();
    for (size_t i = 0; i < s.spheres.size(); ++i) {
      float t;
      if (intersect_sphere(s.spheres.center[i], s.spheres.radius[i], ray.o, ray.d, t_max, t)) {
        t_max = t;
        hit = {t, sb + static_cast<uint32_t>(i)};
        found = true;
      }
    }
  }
  return found;
}

// Any hit in (0, t_max) ignoring primitives skip_a and skip_b: for shadow rays.
template <uint32_t F>
inline bool occluded_scene(const Scene& s, const Ray& ray, float t_max, uint32_t skip_a, uint32_t skip_b) {
  if constexpr ((F & kFeaturePolygons) != 0) {
    const RayShear shear(ray.d);
    const auto scalar_test = [&](uint32_t i, float tm, PolygonHit& h) {
      return intersect_polygon(s.polygons, i, ray.o, shear, tm, h);
    };
    if (s.polygon_bvh.empty() ? any_polygon(s.polygon_lanes, ray.o, shear, skip_a, skip_b, t_max, scalar_test)
                              : any_polygon_bvh(s.polygon_bvh, ray.o, ray.d, shear, skip_a, skip_b, t_max, scalar_test))
      return true;
  }
  if constexpr ((F & kFeatureSpheres) != 0) {
    const uint32_t sb = s.sphere_begin();
    for (size_t i = 0; i < s.spheres.size(); ++i) {
      const uint32_t id = sb + static_cast<uint32_t>(i);
      float t;
      if (id != skip_a && id != skip_b &&
          intersect_sphere(s.spheres.center[i], s.spheres.radius[i], ray.o, ray.d, t_max, t))
        return true;
    }
  }
  return false;
}

}  // namespace pt
