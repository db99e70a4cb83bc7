// Ray queries specialised on a kernel feature set F (see KernelFeature): primitive kinds outside F are not
// tested, not even by a branch. With F = kAllFeatures each kind is tested when the scene has some.
#pragma once
#include "geometry/packet_polygons.h"
#include "geometry/primitives.h"

namespace pt {

namespace query_detail {
// The traversal's hit filter for a scene with cut-outs (alpha_mask.h): a hit counts unless its polygon's mask
// cuts the surface away there (the barycentrics recomputed by the scalar test, which does the SIMD test's
// arithmetic).
inline auto uncut(const SceneGeometry& s, const Ray& ray, const RayShear& shear) {
  return [&s, &ray, &shear](uint32_t p) {
    PolygonHit h{};
    if (!intersect_polygon(s.polygons, p, ray.o, shear, kInfinity, h)) return true;
    return !s.cut_away(p, h, ray_uniform(ray.o, ray.d, p));
  };
}

// The mesh of instance `in` as a ray sees it: the ray taken into the mesh's coordinates, the scalar test of its
// triangles, and the hit filter for cut-outs.
struct InstanceRay {
  const SceneGeometry& s;
  const Instance& in;
  const MeshGeometry& mesh;
  const Ray& world;
  Vec3 o, d;
  RayShear shear;
  InstanceRay(const SceneGeometry& scene, const Instance& instance, const Ray& ray)
      : s(scene), in(instance), mesh(*instance.geometry), world(ray),
        o(instance.to_mesh.point(ray.o)), d(instance.to_mesh.vector(ray.d)), shear(d) {}
  // A global id as the mesh's own (~0u for none of its triangles).
  uint32_t local(uint32_t prim) const { return prim - in.first_prim < in.triangles ? prim - in.first_prim : ~0u; }
  bool test(uint32_t i, float t_max, PolygonHit& h) const {
    return intersect_triangle(mesh.vertex(i, 0), mesh.vertex(i, 1), mesh.vertex(i, 2), o, shear, t_max, h);
  }
  bool uncut(uint32_t i) const {
    PolygonHit h{};
    return !test(i, kInfinity, h) || !s.cut_away(in, i, h, ray_uniform(world.o, world.d, in.first_prim + i));
  }
};

// Closest hit among the instances' triangles in (0, t_max) (lowered to it), never reporting `skip`.
inline bool closest_instance(const SceneGeometry& s, const Ray& ray, uint32_t skip, float& t_max, uint32_t& id) {
  bool found = false;
  visit_instances<true>(s.instances, ray.o, ray.d, t_max, [&](const Instance& in) {
    const InstanceRay r(s, in, ray);
    const auto test = [&r](uint32_t i, float tm, PolygonHit& h) { return r.test(i, tm, h); };
    uint32_t local = 0;
    const bool hit = s.has_cutouts()
                         ? closest_polygon_bvh(r.mesh.bvh, r.o, r.d, r.shear, r.local(skip), t_max, local, test,
                                               [&r](uint32_t i) { return r.uncut(i); })
                         : closest_polygon_bvh(r.mesh.bvh, r.o, r.d, r.shear, r.local(skip), t_max, local, test);
    if (hit) {
      id = in.first_prim + local;
      found = true;
    }
    return false;
  });
  return found;
}

// Any hit among the instances' triangles in (0, t_max), ignoring skip_a and skip_b.
inline bool occluded_instance(const SceneGeometry& s, const Ray& ray, float t_max, uint32_t skip_a, uint32_t skip_b) {
  return visit_instances<false>(s.instances, ray.o, ray.d, t_max, [&](const Instance& in) {
    const InstanceRay r(s, in, ray);
    const auto test = [&r](uint32_t i, float tm, PolygonHit& h) { return r.test(i, tm, h); };
    return s.has_cutouts() ? any_polygon_bvh(r.mesh.bvh, r.o, r.d, r.shear, r.local(skip_a), r.local(skip_b), t_max,
                                             test, [&r](uint32_t i) { return r.uncut(i); })
                           : any_polygon_bvh(r.mesh.bvh, r.o, r.d, r.shear, r.local(skip_a), r.local(skip_b), t_max, test);
  });
}

// Closest hit among the scene's own polygons (brute force or their hierarchy), as closest_instance.
inline bool closest_own_polygon(const SceneGeometry& s, const Ray& ray, uint32_t skip, float& t_max, uint32_t& id) {
  const RayShear shear(ray.d);
  const auto scalar_test = [&](uint32_t i, float tm, PolygonHit& h) {
    return intersect_polygon(s.polygons, i, ray.o, shear, tm, h);
  };
  return s.polygon_bvh.empty() ? closest_polygon(s.polygon_lanes, ray.o, shear, skip, t_max, id, scalar_test)
         : s.has_cutouts()     ? closest_polygon_bvh(s.polygon_bvh, ray.o, ray.d, shear, skip, t_max, id, scalar_test,
                                                     uncut(s, ray, shear))
                               : closest_polygon_bvh(s.polygon_bvh, ray.o, ray.d, shear, skip, t_max, id, scalar_test);
}

// Any hit among the scene's own polygons, as occluded_instance.
inline bool any_own_polygon(const SceneGeometry& s, const Ray& ray, float t_max, uint32_t skip_a, uint32_t skip_b) {
  const RayShear shear(ray.d);
  const auto scalar_test = [&](uint32_t i, float tm, PolygonHit& h) {
    return intersect_polygon(s.polygons, i, ray.o, shear, tm, h);
  };
  return s.polygon_bvh.empty() ? any_polygon(s.polygon_lanes, ray.o, shear, skip_a, skip_b, t_max, scalar_test)
         : s.has_cutouts()     ? any_polygon_bvh(s.polygon_bvh, ray.o, ray.d, shear, skip_a, skip_b, t_max, scalar_test,
                                                 uncut(s, ray, shear))
                               : any_polygon_bvh(s.polygon_bvh, ray.o, ray.d, shear, skip_a, skip_b, t_max, scalar_test);
}

}  // namespace query_detail

// Closest hit in (0, t_max), never reporting `skip` (the planar primitive a spawned ray leaves; ~0u for none).
template <uint32_t F>
inline bool intersect_scene(const SceneGeometry& s, const Ray& ray, float t_max, uint32_t skip, Hit& hit) {
  bool found = false;
  if constexpr ((F & kFeaturePolygons) != 0) {
    uint32_t id = 0;
    // A scene of instanced meshes alone has no polygons of its own: not even the shear is set up.
    if (s.polygons.size() != 0 && query_detail::closest_own_polygon(s, ray, skip, t_max, id)) {
      hit = {t_max, id};
      found = true;
    }
    if (!s.instances.empty() && query_detail::closest_instance(s, ray, skip, t_max, id)) {
      hit = {t_max, id};
      found = true;
    }
  }
  if constexpr ((F & kFeatureSpheres) != 0) {
    const uint32_t sb = s.sphere_begin();
    // The spheres the ray may hit (sphere_lanes.h), nearest hit kept: intersect_sphere's answers, in index order.
    visit_sphere_candidates(s.spheres.lanes, ray.o, ray.d, [&](uint32_t i) {
      float t;
      if (intersect_sphere(s.spheres.center[i], s.spheres.radius[i], ray.o, ray.d, t_max, t)) {
        t_max = t;
        hit = {t, sb + i};
        found = true;
      }
      return false;
    });
  }
  return found;
}

// Any hit in (0, t_max) ignoring primitives skip_a and skip_b: for shadow rays. The spheres are asked first: any
// order gives the same answer (each test is exact), and in a room that holds spheres (cornell-spheres, materials)
// they are what blocks bdpt's connections: a convex room's walls never block a segment between two points inside
// it (instructions per sample under bdpt 0.6-0.9 % fewer, docs/performance.md, session 48).
template <uint32_t F>
inline bool occluded_scene(const SceneGeometry& s, const Ray& ray, float t_max, uint32_t skip_a, uint32_t skip_b) {
  if constexpr ((F & kFeatureSpheres) != 0) {
    const uint32_t sb = s.sphere_begin();
    if (visit_sphere_candidates(s.spheres.lanes, ray.o, ray.d, [&](uint32_t i) {
          const uint32_t id = sb + i;
          float t;
          return id != skip_a && id != skip_b &&
                 intersect_sphere(s.spheres.center[i], s.spheres.radius[i], ray.o, ray.d, t_max, t);
        }))
      return true;
  }
  if constexpr ((F & kFeaturePolygons) != 0) {
    if (s.polygons.size() != 0 && query_detail::any_own_polygon(s, ray, t_max, skip_a, skip_b)) return true;
    if (!s.instances.empty() && query_detail::occluded_instance(s, ray, t_max, skip_a, skip_b))
      return true;
  }
  return false;
}

// Closest hits of n ≤ kLanes rays at once (found[l] and hits[l] per ray), with the same results as n calls of
// intersect_scene: polygons kept in brute-force lanes go through the packet kernel (packet_polygons.h); polygons
// in a BVH and spheres are searched ray by ray.
template <uint32_t F>
inline void intersect_scene_packet(const SceneGeometry& s, const Ray* rays, const float* t_max, const uint32_t* skip, int n,
                                   Hit* hits, bool* found) {
  if constexpr ((F & kFeaturePolygons) != 0) {
    if (s.polygon_bvh.empty()) {
      RayPacket P;
      P.load(rays, t_max, skip, nullptr, n);
      float t[kLanes];
      uint32_t id[kLanes];
      closest_polygon_packet(s.polygon_lanes, P, t, id, [&](int l, uint32_t i, float tm, PolygonHit& h) {
        return intersect_polygon(s.polygons, i, rays[l].o, RayShear(rays[l].d), tm, h);
      });
      for (int l = 0; l < n; ++l) {
        found[l] = t[l] < t_max[l];
        if (found[l]) hits[l] = {t[l], id[l]};
        float tl = found[l] ? t[l] : t_max[l];
        uint32_t il = 0;
        if (!s.instances.empty() && query_detail::closest_instance(s, rays[l], skip[l], tl, il)) [[unlikely]] {
          hits[l] = {tl, il};
          found[l] = true;
        }
      }
      if constexpr ((F & kFeatureSpheres) != 0) {
        for (int l = 0; l < n; ++l) {
          Hit h;
          if (intersect_scene<F & ~uint32_t{kFeaturePolygons}>(s, rays[l], found[l] ? hits[l].t : t_max[l], skip[l], h)) {
            hits[l] = h;
            found[l] = true;
          }
        }
      }
      return;
    }
  }
  for (int l = 0; l < n; ++l) found[l] = intersect_scene<F>(s, rays[l], t_max[l], skip[l], hits[l]);
}

// Any hits of n ≤ kLanes shadow rays at once: bit l of the result is occluded_scene's answer for ray l. skip_b
// may be null (no second primitive to ignore).
template <uint32_t F>
inline uint32_t occluded_scene_packet(const SceneGeometry& s, const Ray* rays, const float* t_max, const uint32_t* skip_a,
                                      const uint32_t* skip_b, int n) {
  uint32_t bits = 0;
  if constexpr ((F & kFeaturePolygons) != 0) {
    if (s.polygon_bvh.empty()) {
      RayPacket P;
      P.load(rays, t_max, skip_a, skip_b, n);
      bits = any_polygon_packet(s.polygon_lanes, P, [&](int l, uint32_t i, float tm, PolygonHit& h) {
        return intersect_polygon(s.polygons, i, rays[l].o, RayShear(rays[l].d), tm, h);
      });
      if (!s.instances.empty()) [[unlikely]]
        for (int l = 0; l < n; ++l)
          if (!(bits >> l & 1u) && query_detail::occluded_instance(s, rays[l], t_max[l], skip_a[l], skip_b ? skip_b[l] : ~0u))
            bits |= 1u << l;
      if constexpr ((F & kFeatureSpheres) != 0)
        for (int l = 0; l < n; ++l)
          if (!(bits >> l & 1u) && occluded_scene<F & ~uint32_t{kFeaturePolygons}>(s, rays[l], t_max[l], skip_a[l], skip_b ? skip_b[l] : ~0u))
            bits |= 1u << l;
      return bits;
    }
  }
  for (int l = 0; l < n; ++l)
    if (occluded_scene<F>(s, rays[l], t_max[l], skip_a[l], skip_b ? skip_b[l] : ~0u)) bits |= 1u << l;
  return bits;
}

}  // namespace pt
