// A wide bounding volume hierarchy over the scene's polygons, for scenes with more polygons than brute force
// handles well (meshes). Scenes below kBvhMinPolygons keep the brute-force SIMD loop of simd_polygons.h, which
// for a handful of polygons beats any hierarchy (measured crossover: docs/performance.md, "Meshes").
//
// Build: a binary tree by binned SAH (Wald, "On fast construction of SAH-based bounding volume hierarchies",
// 2007: 32 bins on the centroids along each axis, the split of least Σ area·count of the three) with spatial
// splits where children would overlap (Stich et al., "Spatial splits in bounding volume hierarchies", 2009: a
// polygon across the plane goes to both sides, each bounding only its part), then collapsed into 8-wide nodes by
// repeatedly opening the child with the largest surface area (as in Embree's BVH8 and Ylitie et al. 2017). A node
// of at most 8 polygons is a leaf, stored in one piece (leaf_data) and padded to 4 or 8 lanes, so a leaf is one
// 4- or 8-lane block of the same watertight test as the brute-force loop: a polygon gives bit-identical results
// in both, and one in several leaves the same result in each.
//
// Traversal: one ray, the 8 children's slab tests in one 8-lane step, nearest child first (closest hit) or leaves
// first, then slot order (any hit: a leaf may end it at once; nearest first was measured slower,
// docs/performance.md, session 30). The slab distances
// are widened by 1 + 2γ3 (Ize, "Robust BVH ray traversal", JCGT 2013), so rounding can never cull a box the
// ray enters: the hierarchy changes which polygons are tested, never the answer.
#pragma once
#include <bit>
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

// A child reference: an inner child is its node index times 4 (bit 0 clear). A leaf has bit 0 set (kLeafRef),
// bit 1 when it holds 8 lanes rather than 4 (kWideLeafRef), bit 2 when every polygon in it is a triangle
// (kTriangleLeafRef: the test skips the fourth corner), and its first lane, a multiple of 4, times 2 above them.
// One 32-bit word says all that traversal needs, so a stack entry is written and read as one word (a reference
// and a lane count in separate fields were written by two stores and read back by one load, which cannot be
// forwarded from them: 13 % of shadow-ray time stalled there, perf annotate, session 30).
inline constexpr uint32_t kLeafRef = 1u, kWideLeafRef = 2u, kTriangleLeafRef = 4u;
inline constexpr uint32_t kBvhMaxNodes = 1u << 30, kBvhMaxLanes = 1u << 31;
constexpr uint32_t inner_ref(uint32_t node) { return node << 2; }
constexpr uint32_t leaf_ref(uint32_t first_lane, int lanes, bool triangles) {
  return first_lane << 1 | kLeafRef | (lanes == 8 ? kWideLeafRef : 0u) | (triangles ? kTriangleLeafRef : 0u);
}
constexpr bool is_leaf_ref(uint32_t ref) { return (ref & kLeafRef) != 0; }
constexpr uint32_t ref_node(uint32_t ref) { return ref >> 2; }
constexpr uint32_t ref_first_lane(uint32_t ref) { return (ref & ~7u) >> 1; }
constexpr int ref_lanes(uint32_t ref) { return (ref & kWideLeafRef) != 0 ? 8 : 4; }
constexpr bool ref_triangles(uint32_t ref) { return (ref & kTriangleLeafRef) != 0; }

struct BvhNode {
  // Child k's box; an unused slot holds lo = hi = +inf, which no ray enters (child_entry).
  float lo[3][kBvhWidth], hi[3][kBvhWidth];
  uint32_t child[kBvhWidth];  // child references (above); an unused slot's is never read
};

// A leaf's polygons are stored together, so that testing a leaf reads a few consecutive cache lines (13 arrays
// of the whole tree, one line each, before): the leaf whose first lane is f, of W = 4 or 8 lanes, occupies
// leaf_data[kLeafFloatsPerLane·f, kLeafFloatsPerLane·(f + W)): for corner k = 0…3 and axis a = 0…2 the W
// lanes' coordinates at offset (3k + a)·W, then the W lanes' triangle flags (1 triangle, 0 quad) at 12·W.
// A triangle repeats its corner a as its fourth; padding lanes hold NaN, which never hits.
inline constexpr uint32_t kLeafFloatsPerLane = 13;

struct PolygonBvh {
  std::vector<BvhNode> nodes;  // nodes[0] is the root
  std::vector<float> leaf_data;        // the leaves' polygons, each leaf padded to 4 or 8 lanes (above)
  std::vector<uint32_t> lane_polygon;  // polygon id of each lane (kNoLanePolygon for padding); a polygon that
                                       // spatial splits placed in several leaves has several lanes
  bool empty() const { return nodes.empty(); }
};
inline constexpr uint32_t kNoLanePolygon = ~0u;

// Whether the build may place a polygon in several leaves (spatial splits), or keeps each in one (Objects: for
// boxes stored as "polygons", such as the instances' top-level tree, which a polygon's clipping would not bound).
enum class BvhSplits { Objects, Spatial };

// Builds the hierarchy over polygons with vertices v[k][i] (a triangle repeats its vertex a as v[3]).
PolygonBvh build_polygon_bvh(const std::vector<Vec3> (&v)[4], const std::vector<uint8_t>& is_triangle,
                             BvhSplits splits = BvhSplits::Spatial);
// The same over an indexed mesh's triangles (instances.h), read in place.
PolygonBvh build_mesh_bvh(const TriangleMesh& mesh);

namespace bvh_detail {

using simd_detail::BlockResult;
using simd_detail::ShearedRay;

// The leaf of `bvh` starting at lane `first` (kLeafFloatsPerLane floats a lane, V::size() lanes) against the
// sheared ray; kTriangles when every lane is a triangle or padding. The same arithmetic as test_block() on the
// same floats, so a polygon gives bit-identical results in a leaf and in the brute-force loop.
template <class V, bool kTriangles>
[[gnu::always_inline]] inline BlockResult<V> test_leaf(const PolygonBvh& bvh, uint32_t first, const ShearedRay& R,
                                                       const RayShear& s, float t_max) {
  constexpr size_t W = V::size();
  const float* block = bvh.leaf_data.data() + static_cast<size_t>(first) * kLeafFloatsPerLane;
  const auto corner = [&](int k) {
    const float* c = block + 3 * k * W;
    return simd_detail::shear_lanes(V(c + s.kx * W, stdx::element_aligned), V(c + s.ky * W, stdx::element_aligned),
                                    V(c + s.kz * W, stdx::element_aligned), R);
  };
  if constexpr (kTriangles)
    return simd_detail::test_sheared_triangles(corner(0), corner(1), corner(2), t_max);
  else
    return simd_detail::test_sheared(corner(0), corner(1), corner(2), corner(3),
                                     V(block + 12 * W, stdx::element_aligned) > 0.f, t_max);
}

// Calls f(V{}, std::bool_constant<kTriangles>{}) for the leaf kind that `ref` names.
template <class F>
[[gnu::always_inline]] inline auto with_leaf_kind(uint32_t ref, const F& f) {
  using simd_detail::vfloat4;
  using simd_detail::vfloat8;
  if (ref_triangles(ref))
    return ref_lanes(ref) == 4 ? f(vfloat4{}, std::true_type{}) : f(vfloat8{}, std::true_type{});
  return ref_lanes(ref) == 4 ? f(vfloat4{}, std::false_type{}) : f(vfloat8{}, std::false_type{});
}

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

// A stack entry of the closest-hit traversal: the child reference in the low word, the distance at which the ray
// enters its box (a float's bits) in the high word, written and read as one 64-bit word.
using StackEntry = uint64_t;
[[gnu::always_inline]] inline StackEntry stack_entry(uint32_t ref, float entry) {
  return static_cast<uint64_t>(std::bit_cast<uint32_t>(entry)) << 32 | ref;
}
[[gnu::always_inline]] inline uint32_t entry_ref(StackEntry e) { return static_cast<uint32_t>(e); }
[[gnu::always_inline]] inline float entry_distance(StackEntry e) {
  return std::bit_cast<float>(static_cast<uint32_t>(e >> 32));
}

// Bit k set where lane k of the mask is (libstdc++'s simd_mask::__to_bitset, one kmov or movmsk).
template <class Mask>
[[gnu::always_inline]] inline unsigned mask_bits(const Mask& m) {
  return static_cast<unsigned>(m.__to_bitset().to_ulong());
}

// Pushes the children in `hits` (bits of `entry` < inf) farthest first, so that the nearest is on top; among
// equal distances the higher slot is nearer the top.
template <size_t N>
[[gnu::always_inline]] inline void push_children(const BvhNode& n, const simd_detail::vfloat8& entry, unsigned hits,
                                                 StackEntry (&stack)[N], int& top) {
  alignas(32) float e[kBvhWidth];
  entry.copy_to(e, stdx::vector_aligned);
  const int first = top;
  do {
    const int k = std::countr_zero(hits);
    hits &= hits - 1;
    // Insertion into the descending run stack[first..top).
    int j = top++;
    while (j > first && entry_distance(stack[j - 1]) < e[k]) {
      stack[j] = stack[j - 1];
      --j;
    }
    stack[j] = stack_entry(n.child[k], e[k]);
  } while (hits != 0);
}

// Each level down leaves at most width − 1 siblings pending; the wide tree is no deeper than the binary one.
inline constexpr int kStackSize = kBvhMaxDepth * (kBvhWidth - 1) + 1;

// The closest-hit traversal: visits the leaves whose boxes the ray enters before t_max (which `leaf` may lower
// as it finds hits), nearest box first; leaf(ref) returns true to stop (the leaf's reference: ref_first_lane,
// ref_lanes, ref_triangles). Returns whether it stopped. A node with one hit child goes straight down to it;
// with several, the nearest is taken at once and the others wait on the stack, nearest on top (the order of
// pushing them all and popping the nearest, without its round trip through memory).
template <class Leaf>
[[gnu::always_inline]] inline bool visit_leaves_nearest(const PolygonBvh& bvh, const SlabRay& ray, const float& t_max,
                                                        const Leaf& leaf) {
  StackEntry stack[kStackSize];
  int top = 0;
  uint32_t ref = inner_ref(0);
  for (;;) {
    if (!is_leaf_ref(ref)) {
      const BvhNode& n = bvh.nodes[ref_node(ref)];
      const simd_detail::vfloat8 entry = child_entry(n, ray, t_max * kHitSlack);
      const unsigned hits = mask_bits(entry < kInfinity);
      if (hits != 0) {
        if ((hits & (hits - 1)) == 0) {
          ref = n.child[std::countr_zero(hits)];
        } else {
          push_children(n, entry, hits, stack, top);
          ref = entry_ref(stack[--top]);
        }
        continue;
      }
    } else if (leaf(ref)) {
      return true;
    }
    // The nearest waiting box that the ray still enters before t_max.
    for (;;) {
      if (top == 0) return false;
      const StackEntry e = stack[--top];
      if (entry_distance(e) > t_max * kHitSlack) continue;
      ref = entry_ref(e);
      break;
    }
  }
}

// The any-hit traversal: visits the leaves whose boxes the ray enters before t_limit, in no particular order
// but a node's hit leaves first (one may end the query at once); leaf(ref) returns true to stop. Returns whether
// it stopped. (Nearest first was measured slower for shadow rays, docs/performance.md, session 30.)
template <class Leaf>
[[gnu::always_inline]] inline bool visit_leaves_any(const PolygonBvh& bvh, const SlabRay& ray, float t_limit,
                                                    const Leaf& leaf) {
  uint32_t stack[kStackSize];  // child references, in no particular order: any hit will do
  int top = 0;
  uint32_t ref = inner_ref(0);
  for (;;) {
    if (!is_leaf_ref(ref)) {
      // Down to a hit leaf if there is one, else the first hit child; the others wait.
      const BvhNode& n = bvh.nodes[ref_node(ref)];
      unsigned hits = mask_bits(child_entry(n, ray, t_limit) < kInfinity);
      if (hits != 0) {
        using vuint8 = stdx::simd<uint32_t, stdx::simd_abi::deduce_t<uint32_t, kBvhWidth>>;
        const unsigned leaves = hits & mask_bits((vuint8(n.child, stdx::element_aligned) & kLeafRef) != 0u);
        const int k = std::countr_zero(leaves != 0 ? leaves : hits);
        ref = n.child[k];
        for (hits &= ~(1u << k); hits != 0; hits &= hits - 1) stack[top++] = n.child[std::countr_zero(hits)];
        continue;
      }
    } else if (leaf(ref)) {
      return true;
    }
    if (top == 0) return false;
    ref = stack[--top];
  }
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
  const ShearedRay R(o, s);
  const SlabRay ray(o, d);
  const float t_in = t_max;
  visit_leaves_nearest(bvh, ray, t_max, [&](uint32_t ref) {
    const uint32_t first = ref_first_lane(ref);
    with_leaf_kind(ref, [&](auto tag, auto triangles) {
      using V = decltype(tag);
      BlockResult<V> r = test_leaf<V, decltype(triangles)::value>(bvh, first, R, s, t_max);
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
      // The nearest lane's polygon, passing over `skip` (told by its id: spatial splits may have placed it in
      // several leaves, so it has no one lane).
      int lane;
      for (float t = block_min(r.t, lane); t < t_max; t = block_min(r.t, lane)) {
        const uint32_t p = bvh.lane_polygon[first + lane];
        if (p != skip) {
          t_max = t;
          id = p;
          break;
        }
        r.t[lane] = kInfinity;
      }
    });
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
  const ShearedRay R(o, s);
  const SlabRay ray(o, d);
  // Inlined, as the loop it replaced was (GCC kept it out of line: shadow rays 2–3 % slower); GNU's spelling,
  // since clang reads [[gnu::always_inline]] in that place as an attribute of the lambda's type and ignores it.
  return visit_leaves_any(bvh, ray, t_max * kHitSlack, [&](uint32_t ref) __attribute__((always_inline)) {
    const uint32_t first = ref_first_lane(ref);
    return with_leaf_kind(ref, [&](auto tag, auto triangles) {
      using V = decltype(tag);
      BlockResult<V> r = test_leaf<V, decltype(triangles)::value>(bvh, first, R, s, t_max);
      filter_hits(r.t, bvh, first, t_max, keep);
      if (stdx::any_of(r.zero_edge)) [[unlikely]] {
        for (size_t lane = 0; lane < V::size(); ++lane) {
          const uint32_t p = bvh.lane_polygon[first + lane];
          if (!r.zero_edge[lane] || p == kNoLanePolygon || p == skip_a || p == skip_b) continue;
          r.t[lane] = kInfinity;
          PolygonHit h{};
          if (scalar_test(p, t_max, h) && keep(p)) return true;
        }
      }
      // A hit that is not skip_a's or skip_b's (told by their ids, as in closest_polygon_bvh).
      unsigned hits = mask_bits(r.t < t_max);
      if (hits == 0 || (skip_a == kNoLanePolygon && skip_b == kNoLanePolygon)) return hits != 0;
      for (; hits != 0; hits &= hits - 1) {
        const uint32_t p = bvh.lane_polygon[first + static_cast<uint32_t>(std::countr_zero(hits))];
        if (p != skip_a && p != skip_b) return true;
      }
      return false;
    });
  });
}

}  // namespace pt
