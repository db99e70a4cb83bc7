// Instancing: a triangle mesh stored once, in its own coordinates and with its own hierarchy, placed in the scene
// by any number of instances (affine transforms), which a top-level hierarchy over the instances' boxes finds:
// the two-level BVH of Embree's and pbrt-v4's instances. 1,000 copies of a mesh cost 1,000 transforms, not
// 1,000 meshes (docs/performance.md, "Instances").
//
// A ray reaches a mesh through its instance's inverse transform, o' = M⁻¹(o), d' = M⁻¹·d without normalising
// d', so the distance t along d' is the distance along d: hits from every instance compare directly. Primitive
// ids: instance k's triangle i has the global id first_prim(k) + i, after the scene's own polygons and spheres
// (primitives.h), so the rest of the tracer tells a hit on an instance by its id alone.
#pragma once
#include <algorithm>
#include <cstdint>
#include <memory>
#include <vector>

#include "geometry/polygon_bvh.h"

namespace pt {

// One mesh as the tracer reads it: the shared indexed mesh (triangle_mesh.h, never copied) and its hierarchy,
// whose leaves hold the triangles' vertices in their own lanes.
struct MeshGeometry {
  std::shared_ptr<const TriangleMesh> mesh;
  PolygonBvh bvh;
  size_t size() const { return mesh->size(); }
  Vec3 vertex(uint32_t triangle, int k) const { return mesh->vertex(triangle, k); }
  uint32_t slot(uint32_t triangle) const { return mesh->slot[triangle]; }
};

// An affine map in float, p ↦ L·p + offset.
struct Affine {
  glm::mat3 linear{1.f};
  Vec3 offset{0.f};
  Vec3 point(Vec3 p) const { return linear * p + offset; }
  Vec3 vector(Vec3 d) const { return linear * d; }
};

struct Instance {
  uint32_t mesh = 0;        // index into InstanceSet::meshes
  uint32_t first_prim = 0;  // global id of the mesh's triangle 0
  // Mesh → camera-relative world, in double (the hit's vertices are placed with it) and its inverse in float
  // (the rays' way into the mesh); the normals' map, the inverse transpose of the linear part.
  glm::dmat3 to_world_linear{1.0};
  DVec3 to_world_offset{0.0};
  Affine to_mesh;
  glm::mat3 normal_to_world{1.f};
  bool mirrors = false;               // det < 0: triangles list their vertices the other way round in the world
  std::vector<uint32_t> material;     // per slot of the mesh, the scene's material
  Vec3 lo{0.f}, hi{0.f};              // the placed mesh's box (camera-relative, rounded outwards)
  uint32_t desc = 0;                  // its index in SceneDesc::instances (what a pick reports)
};

struct InstanceSet {
  std::vector<std::shared_ptr<const MeshGeometry>> meshes;
  std::vector<Instance> instances;  // in the order of their first_prim
  PolygonBvh top;                   // over the instances' boxes (a box is a "quad" with corners lo, hi, lo, hi)
  uint32_t prim_begin = 0, prim_end = 0;  // the global ids the instances' triangles take
  bool empty() const { return instances.empty(); }
  bool holds(uint32_t prim) const { return prim >= prim_begin && prim < prim_end; }
  // The instance whose triangles include global id `prim` (holds(prim) must be true).
  const Instance& instance_of(uint32_t prim) const {
    const auto it = std::upper_bound(instances.begin(), instances.end(), prim,
                                     [](uint32_t p, const Instance& in) { return p < in.first_prim; });
    return *(it - 1);
  }
};

// Builds the top-level hierarchy over the instances' boxes.
inline PolygonBvh build_instance_bvh(const std::vector<Instance>& instances) {
  std::vector<Vec3> v[4];
  std::vector<uint8_t> quad(instances.size(), 0);
  for (const Instance& in : instances) {
    v[0].push_back(in.lo), v[1].push_back(in.hi), v[2].push_back(in.lo), v[3].push_back(in.hi);
  }
  return build_polygon_bvh(v, quad, BvhSplits::Objects);
}

namespace instance_detail {

// The ray's entry into an instance's own box, or false (several instances share a leaf of the top tree).
inline bool enters(const Instance& in, const bvh_detail::SlabRay& r, float t_max) {
  float t0 = 0.f, t1 = t_max;
  for (int a = 0; a < 3; ++a) {
    if (r.parallel[a]) {
      if (!(in.lo[a] <= r.o[a] && r.o[a] <= in.hi[a])) return false;
      continue;
    }
    const float n = (in.lo[a] - r.o[a]) * r.inv[a], f = (in.hi[a] - r.o[a]) * r.inv[a];
    t0 = std::max(t0, std::min(n, f));
    t1 = std::min(t1, std::max(n, f));
  }
  return t0 <= t1 * bvh_detail::kSlabWiden;
}

}  // namespace instance_detail

// Visits, nearest box first, every instance whose box the ray enters before t_max (which `visit(instance)` may
// lower as it finds hits); `visit` returns true to stop (a shadow ray's first hit).
template <class Visit>
inline bool visit_instances(const InstanceSet& set, Vec3 o, Vec3 d, const float& t_max, const Visit& visit) {
  using namespace bvh_detail;
  const SlabRay ray(o, d);
  return visit_leaves_nearest(set.top, ray, t_max, [&](uint32_t ref) {
    const uint32_t first = ref_first_lane(ref), end = first + static_cast<uint32_t>(ref_lanes(ref));
    for (uint32_t lane = first; lane < end; ++lane) {
      const uint32_t k = set.top.lane_polygon[lane];
      if (k == kNoLanePolygon || !instance_detail::enters(set.instances[k], ray, t_max * kHitSlack)) continue;
      if (visit(set.instances[k])) return true;
    }
    return false;
  });
}

}  // namespace pt
