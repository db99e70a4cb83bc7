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

struct alignas(64) Instance {
  // What a ray entering the instance reads, in one cache line: its way into the mesh, the ids, the mesh itself.
  Affine to_mesh;
  uint32_t first_prim = 0;                 // global id of the mesh's triangle 0
  uint32_t triangles = 0;                  // the mesh's triangle count
  const MeshGeometry* geometry = nullptr;  // meshes[mesh] of its InstanceSet (which keeps it alive)
  uint32_t mesh = 0;                       // index into InstanceSet::meshes
  // Mesh → camera-relative world, in double (the hit's vertices are placed with it; to_mesh above is its
  // inverse in float); the normals' map, the inverse transpose of the linear part.
  glm::dmat3 to_world_linear{1.0};
  DVec3 to_world_offset{0.0};
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
  // The boxes of each top leaf's instances, in the layout of a node's child boxes, so that one 8-lane slab test
  // (child_entry) tests a whole leaf: the leaf whose first lane is f uses top_leaf_boxes[f / 4], its slot k the
  // instance of lane f + k (child[k] the instance's index); slots past the leaf's instances hold the unused
  // slot's box, lo = hi = +inf.
  std::vector<BvhNode> top_leaf_boxes;
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

// Builds the top-level hierarchy over the instances' boxes, and its leaves' boxes.
inline void build_instance_hierarchy(InstanceSet& set) {
  std::vector<Vec3> v[4];
  std::vector<uint8_t> quad(set.instances.size(), 0);
  for (const Instance& in : set.instances) {
    v[0].push_back(in.lo), v[1].push_back(in.hi), v[2].push_back(in.lo), v[3].push_back(in.hi);
  }
  set.top = build_polygon_bvh(v, quad, BvhSplits::Objects);
  BvhNode unused{};
  for (int a = 0; a < 3; ++a) {
    std::fill_n(unused.lo[a], kBvhWidth, kInfinity);
    std::fill_n(unused.hi[a], kBvhWidth, kInfinity);
  }
  std::fill_n(unused.child, kBvhWidth, kNoLanePolygon);
  set.top_leaf_boxes.assign((set.top.lane_polygon.size() + 3) / 4, unused);
  // A leaf's lanes start at a multiple of 4 and number 4 or 8: its boxes go to the block of its first lane (a
  // wide leaf's second block stays unused).
  for (const BvhNode& n : set.top.nodes) {
    for (int c = 0; c < kBvhWidth; ++c) {
      const uint32_t ref = n.child[c];
      if (n.lo[0][c] == kInfinity || !is_leaf_ref(ref)) continue;
      BvhNode& b = set.top_leaf_boxes[ref_first_lane(ref) / 4];
      for (int k = 0; k < ref_lanes(ref); ++k) {
        const uint32_t i = set.top.lane_polygon[ref_first_lane(ref) + static_cast<uint32_t>(k)];
        if (i == kNoLanePolygon) continue;
        for (int a = 0; a < 3; ++a) b.lo[a][k] = set.instances[i].lo[a], b.hi[a][k] = set.instances[i].hi[a];
        b.child[k] = i;
      }
    }
  }
}

// Visits every instance whose box the ray enters before t_max (which `visit(instance)` may lower as it finds
// hits); `visit` returns true to stop (a shadow ray's first hit). kNearest (closest hit): nearest box first;
// otherwise (any hit) in the order of the any-hit traversal. A top leaf's instance boxes (up to 8, often
// overlapping: an engine's parts) are tested in one 8-lane step and the entered ones visited nearest first or
// in slot order: closest hit +8-16 % on 2CylinderEngine.glb against one scalar box test per instance,
// visited in slot order (docs/performance.md, session 32).
template <bool kNearest, class Visit>
inline bool visit_instances(const InstanceSet& set, Vec3 o, Vec3 d, const float& t_max, const Visit& visit) {
  using namespace bvh_detail;
  const SlabRay ray(o, d);
  const auto leaf = [&](uint32_t ref) __attribute__((always_inline)) {
    const BvhNode& boxes = set.top_leaf_boxes[ref_first_lane(ref) / 4];
    const simd_detail::vfloat8 entry_lanes = child_entry(boxes, ray, t_max * kHitSlack);
    unsigned entered = mask_bits(entry_lanes < kInfinity);
    if (entered == 0) return false;
    alignas(32) float entry[kBvhWidth];
    entry_lanes.copy_to(entry, stdx::vector_aligned);
    do {
      int k = std::countr_zero(entered);
      if constexpr (kNearest) {
        for (unsigned rest = entered & (entered - 1); rest != 0; rest &= rest - 1) {
          const int j = std::countr_zero(rest);
          if (entry[j] < entry[k]) k = j;
        }
      }
      entered &= ~(1u << k);
      // t_max may have fallen since the leaf's test (as for the nodes waiting on the traversal's stack).
      if (entry[k] <= t_max * kHitSlack && visit(set.instances[boxes.child[k]])) return true;
    } while (entered != 0);
    return false;
  };
  if constexpr (kNearest) return visit_leaves_nearest(set.top, ray, t_max, leaf);
  else return visit_leaves_any(set.top, ray, t_max * kHitSlack, leaf);
}

}  // namespace pt
