// A wide bounding volume hierarchy over the scene's polygons, for scenes with more polygons than brute force
// handles well (meshes). Scenes below kBvhMinPolygons keep the brute-force SIMD loop of simd_polygons.h, which
// for a handful of polygons beats any hierarchy (measured crossover: docs/performance.md, "Meshes").
//
// Build: a binary tree by binned SAH (Wald, "On fast construction of SAH-based bounding volume hierarchies",
// 2007: 32 bins per axis on centroids, cost = traversal + Σ area·count), then collapsed into 8-wide nodes by
// repeatedly opening the child with the largest surface area (as in Embree's BVH8 and Ylitie et al. 2017).
// Leaves hold at most 8 polygons, stored contiguously in their own padded lanes, so a leaf is one 4- or 8-lane
// block of the same watertight test as the brute-force loop: a polygon gives bit-identical results in both.
//
// Traversal: one ray, the 8 children's slab tests in one 8-lane step, nearest child first. The slab distances
// are widened by 1 + 2γ3 (Ize, "Robust BVH ray traversal", JCGT 2013), so rounding can never cull a box the
// ray enters: the hierarchy changes which polygons are tested, never the answer.
#pragma once
#include <cmath>
#include <cstdint>
#include <type_traits>
#include <vector>

#include "geometry/simd_polygons.h"
#include "geometry/triangle_mesh.h"

namespace pt {

inline constexpr uint32_t kBvhMinPolygons = 128;  // below this, brute force (docs/performance.md, "Meshes")
inline constexpr int kBvhWidth = 8;
inline constexpr int kBvhMaxLeaf = 8;
// Below this depth the build splits by SAH; deeper (pathological layouts) it halves by index, which adds at most
// 32 levels for up to 2^32 polygons. So no path through the tree is longer than kBvhMaxDepth levels.
inline constexpr int kBvhSahMaxDepth = 48;
inline constexpr int kBvhMaxDepth = kBvhSahMaxDepth + 1 + 32;

struct BvhNode {
  // Child k's box; an unused slot holds lo = hi = +inf, which no ray enters (child_entry).
  float lo[3][kBvhWidth], hi[3][kBvhWidth];
  // Inner child: a node index. Leaf child: its first lane in PolygonBvh::lanes (a multiple of 4).
  uint32_t child[kBvhWidth];
  // 0 for an inner child; for a leaf, its lane count: 4 or 8 (padding lanes hold NaN and never hit).
  uint8_t leaf_lanes[kBvhWidth];
};

struct PolygonBvh {
  std::vector<BvhNode> nodes;  // nodes[0] is the root
  PolygonLanes lanes;          // the polygons in leaf order, each leaf padded to 4 or 8 lanes
  std::vector<uint32_t> lane_polygon;  // polygon id of each lane (kNoLanePolygon for padding)
  std::vector<uint32_t> polygon_lane;  // lane of each polygon id
  bool empty() const { return nodes.empty(); }
};
inline constexpr uint32_t kNoLanePolygon = ~0u;

// Builds the hierarchy over polygons with vertices v[k][i] (a triangle repeats its vertex a as v[3]).
PolygonBvh build_polygon_bvh(const std::vector<Vec3> (&v)[4], const std::vector<uint8_t>& is_triangle);
// The same over an indexed mesh's triangles (instances.h), read in place.
PolygonBvh build_mesh_bvh(const TriangleMesh& mesh);

namespace bvh_detail {

using simd_detail::RayLanes;

// Per ray: origin and reciprocal direction for the slab tests. An axis along which the ray does not move (a
// zero component, or one so small that 1/d overflows) has no slab distances: the ray is inside that slab for
// all t or for none, and child_entry() tests just that (an origin exactly on a face plane is inside). A
// reciprocal of ±inf would instead give 0·inf = NaN there.
struct SlabRay {
  float o[3], inv[3];
  bool parallel[3];
  explicit SlabRay(Vec3 origin, Vec3 d) {
    for (int a = 0; a < 3; ++a) {
      o[a] = origin[a];
      inv[a] = 1.f / d[a];
      parallel[a] = std::isinf(inv[a]);
    }
  }
};

// 1 + 2γ3 with γn = nε/(1 − nε), ε = 2^-24 (pbrt-v4's gamma; Ize 2013, section 3).
inline constexpr float kSlabWiden = 1.f + 2.f * (3.f * 0x1p-24f) / (1.f - 3.f * 0x1p-24f);
// A polygon's computed hit distance carries its own rounding error: at a vertex or an edge on a box's face it
// can come out a few ulps below the box's entry distance. Boxes are therefore culled only when they start
// beyond t_max by this relative slack (2^-12, about 2000 ulps; the polygon's error grows as 1/sin of the
// grazing angle), so every polygon the brute-force loop could report is tested.
inline constexpr float kHitSlack = 1.f + 0x1p-12f;

// Entry distances of the ray into the node's 8 child boxes; children the ray misses within (0, t_max) get +inf.
// An unused child's box, lo = hi = +inf, gives the same infinite slab distance twice on every axis (and no
// origin lies inside it): never entered.
[[gnu::always_inline]] inline simd_detail::vfloat8 child_entry(const BvhNode& n, const SlabRay& r, float t_max) {
  using V = simd_detail::vfloat8;
  V tmin(0.f), tmax(t_max);
  typename V::mask_type outside(false);
  for (int a = 0; a < 3; ++a) {
    const V lo(n.lo[a], stdx::element_aligned), hi(n.hi[a], stdx::element_aligned);
    if (r.parallel[a]) [[unlikely]] {
      outside = outside || !(lo <= r.o[a] && r.o[a] <= hi);
      continue;
    }
    const V t0 = (lo - r.o[a]) * r.inv[a], t1 = (hi - r.o[a]) * r.inv[a];
    tmin = stdx::max(tmin, stdx::min(t0, t1));
    tmax = stdx::min(tmax, stdx::max(t0, t1));
  }
  V entry = tmin;
  stdx::where(outside || !(tmin <= tmax * kSlabWiden), entry) = kInfinity;
  return entry;
}

struct StackEntry {
  uint32_t ref;    // node index or first lane of a leaf
  uint8_t lanes;   // 0: node; 4 or 8: a leaf of that many lanes
  float entry;     // distance at which the ray enters its box
};

// Visits the hit children of `n` nearest first by pushing them farthest first. Most nodes have one or two.
template <size_t N>
[[gnu::always_inline]] inline void push_children(const BvhNode& n, const simd_detail::vfloat8& entry,
                                                 StackEntry (&stack)[N], int& top) {
  auto hit = entry < kInfinity;
  if (stdx::none_of(hit)) return;
  alignas(32) float e[kBvhWidth];
  entry.copy_to(e, stdx::vector_aligned);
  const int first = top;
  do {
    const int k = stdx::find_first_set(hit);
    hit[k] = false;
    // Insertion into the descending run stack[first..top).
    int j = top++;
    while (j > first && stack[j - 1].entry < e[k]) {
      stack[j] = stack[j - 1];
      --j;
    }
    stack[j] = {n.child[k], n.leaf_lanes[k], e[k]};
  } while (stdx::any_of(hit));
}

// Each level down leaves at most width − 1 siblings pending; the wide tree is no deeper than the binary one.
inline constexpr int kStackSize = kBvhMaxDepth * (kBvhWidth - 1) + 1;

// The closest-hit traversal: visits the leaves whose boxes the ray enters before t_max (which `leaf` may lower
// as it finds hits), nearest box first; leaf(first_lane, lanes) returns true to stop. Returns whether it stopped.
template <class Leaf>
[[gnu::always_inline]] inline bool visit_leaves_nearest(const PolygonBvh& bvh, const SlabRay& ray, const float& t_max,
                                                        const Leaf& leaf) {
  StackEntry stack[kStackSize];
  int top = 0;
  stack[top++] = {0, 0, 0.f};
  while (top > 0) {
    const StackEntry e = stack[--top];
    if (e.entry > t_max * kHitSlack) continue;
    if (e.lanes == 0) {
      const BvhNode& n = bvh.nodes[e.ref];
      push_children(n, child_entry(n, ray, t_max * kHitSlack), stack, top);
      continue;
    }
    if (leaf(e.ref, e.lanes)) return true;
  }
  return false;
}

}  // namespace bvh_detail

// The hit filter of the traversals below: `keep(p)` says whether a hit on polygon p counts (cut-outs:
// geometry/alpha_mask.h). KeepEveryHit, the default, compiles the filter out.
struct KeepEveryHit {
  constexpr bool operator()(uint32_t) const { return true; }
};

namespace bvh_detail {
// Drops the leaf's hits (closer than t_max) that `keep` refuses.
template <class V, class Keep>
[[gnu::always_inline]] inline void filter_hits(V& t, const PolygonBvh& bvh, uint32_t first, float t_max, const Keep& keep) {
  if constexpr (!std::is_same_v<Keep, KeepEveryHit>) {
    for (size_t lane = 0; lane < V::size(); ++lane) {
      if (!(t[lane] < t_max)) continue;
      const uint32_t p = bvh.lane_polygon[first + lane];
      if (p != kNoLanePolygon && !keep(p)) t[lane] = kInfinity;
    }
  }
}
}  // namespace bvh_detail

// Closest hit in (0, t_max) among the polygons, never reporting polygon `skip` nor one `keep` refuses; as
// closest_polygon().
template <class ScalarTest, class Keep = KeepEveryHit>
inline bool closest_polygon_bvh(const PolygonBvh& bvh, Vec3 o, Vec3 d, const RayShear& s, uint32_t skip,
                                float& t_max, uint32_t& id, const ScalarTest& scalar_test, const Keep& keep = {}) {
  using namespace bvh_detail;
  using namespace simd_detail;
  const RayLanes R(bvh.lanes, o, s);
  const SlabRay ray(o, d);
  const uint32_t skip_lane = skip < bvh.polygon_lane.size() ? bvh.polygon_lane[skip] : kNoLanePolygon;
  const float t_in = t_max;
  visit_leaves_nearest(bvh, ray, t_max, [&](uint32_t first, uint8_t lanes) {
    auto leaf = [&](auto tag) {
      using V = decltype(tag);
      BlockResult<V> r = test_block<V>(R, first, t_max);
      mask_lane(r.t, skip_lane, first);
      filter_hits(r.t, bvh, first, t_max, keep);
      if (stdx::any_of(r.zero_edge)) [[unlikely]] {
        stdx::where(r.zero_edge, r.t) = kInfinity;
        for (size_t lane = 0; lane < V::size(); ++lane) {
          const uint32_t p = bvh.lane_polygon[first + lane];
          if (!r.zero_edge[lane] || p == kNoLanePolygon || p == skip) continue;
          PolygonHit h{};
          if (scalar_test(p, t_max, h) && h.t < t_max && keep(p)) {
            t_max = h.t;
            id = p;
          }
        }
      }
      int lane;
      const float t = block_min(r.t, lane);
      if (t < t_max) {
        t_max = t;
        id = bvh.lane_polygon[first + lane];
      }
    };
    if (lanes == 4)
      leaf(vfloat4{});
    else
      leaf(vfloat8{});
    return false;
  });
  return t_max < t_in;
}

// Any hit in (0, t_max) among the polygons, ignoring polygons skip_a and skip_b and those `keep` refuses; as
// any_polygon().
template <class ScalarTest, class Keep = KeepEveryHit>
inline bool any_polygon_bvh(const PolygonBvh& bvh, Vec3 o, Vec3 d, const RayShear& s, uint32_t skip_a,
                            uint32_t skip_b, float t_max, const ScalarTest& scalar_test, const Keep& keep = {}) {
  using namespace bvh_detail;
  using namespace simd_detail;
  const RayLanes R(bvh.lanes, o, s);
  const SlabRay ray(o, d);
  const auto lane_of = [&](uint32_t p) { return p < bvh.polygon_lane.size() ? bvh.polygon_lane[p] : kNoLanePolygon; };
  const uint32_t skip_lane_a = lane_of(skip_a), skip_lane_b = lane_of(skip_b);
  const float t_limit = t_max * kHitSlack;
  StackEntry stack[kStackSize];
  int top = 0;
  stack[top++] = {0, 0, 0.f};
  while (top > 0) {
    const StackEntry e = stack[--top];
    if (e.lanes == 0) {
      const BvhNode& n = bvh.nodes[e.ref];
      const vfloat8 entry = child_entry(n, ray, t_limit);
      auto hit = entry < kInfinity;
      while (stdx::any_of(hit)) {
        const int k = stdx::find_first_set(hit);
        hit[k] = false;
        stack[top++] = {n.child[k], n.leaf_lanes[k], 0.f};
      }
      continue;
    }
    auto leaf = [&](auto tag) {
      using V = decltype(tag);
      BlockResult<V> r = test_block<V>(R, e.ref, t_max);
      mask_lane(r.t, skip_lane_a, e.ref);
      mask_lane(r.t, skip_lane_b, e.ref);
      filter_hits(r.t, bvh, e.ref, t_max, keep);
      if (stdx::any_of(r.zero_edge)) [[unlikely]] {
        for (size_t lane = 0; lane < V::size(); ++lane) {
          const uint32_t p = bvh.lane_polygon[e.ref + lane];
          if (!r.zero_edge[lane] || p == kNoLanePolygon || p == skip_a || p == skip_b) continue;
          r.t[lane] = kInfinity;
          PolygonHit h{};
          if (scalar_test(p, t_max, h) && keep(p)) return true;
        }
      }
      return stdx::any_of(r.t < t_max);
    };
    if (e.lanes == 4 ? leaf(vfloat4{}) : leaf(vfloat8{})) return true;
  }
  return false;
}

}  // namespace pt
