// Ray tests of many polygons at once: the watertight tests of geometry.h, one polygon per SIMD lane.
//
// Width: std::experimental::native_simd<float> (libstdc++'s Parallelism TS v2), i.e. 16 lanes with AVX-512,
// 8 with AVX2, 4 with SSE: the build picks the widest the target CPU has (PT_NATIVE), and any other CPU still
// gets a correct, portable build. A last, partly filled block of at most 4 or 8 polygons runs on 4- or 8-wide
// vectors.
//
// Triangles and quads share the lanes: a triangle lane holds (a, b, c, a), so its edge c→d is the triangle's
// edge c→a exactly, and its degenerate edge d→a (identically 0) is replaced by c→a under the lane's triangle
// mask. Every lane computes exactly the float operations of the scalar tests in geometry.h, in the same order
// (the project builds with -ffp-contract=off), so SIMD and scalar results are bit-identical and watertightness
// carries over. Lanes whose edge function is exactly 0 are re-tested by the scalar routine, which settles them
// in double as Woop et al. prescribe.
//
// Only distances leave the kernels: the winner's barycentrics are recomputed once, by the scalar test, when the
// hit is shaded. The kernels are short dependency chains with few branches, since a single incoherent ray is
// bound by latency, not by arithmetic.
#pragma once
#include <cstring>
#include <vector>

#include "core/lanes.h"  // vfloat, kLanes
#include "geometry/geometry.h"

namespace pt {

// Polygons as padded structure of arrays: coord[k][axis][i] is axis `axis` of vertex k of polygon i, and
// triangle[i] is 1 for triangles (0 for quads). Padding lanes hold NaN, which fails every comparison and so
// never reports a hit.
struct PolygonLanes {
  uint32_t count = 0;
  std::vector<float> coord[4][3];
  std::vector<float> triangle;
  // The distinct corners (bitwise-equal positions merged) and each polygon's corners as indices into them
  // (a triangle's unused fourth: its first), for the packet kernels (packet_polygons.h); the corner table stays
  // empty when there are more than kMaxSharedCorners.
  static constexpr size_t kMaxSharedCorners = 64;
  std::vector<float> corner_xyz[3];
  std::vector<uint16_t> corner_of[4];

  bool shared_corners() const { return !corner_xyz[0].empty(); }

  void assign(const std::vector<Vec3> (&v)[4], const std::vector<uint8_t>& is_triangle) {
    const size_t n = is_triangle.size();
    count = static_cast<uint32_t>(n);
    const size_t padded = (n + kLanes - 1) / kLanes * kLanes;
    for (int k = 0; k < 4; ++k)
      for (int a = 0; a < 3; ++a) {
        coord[k][a].assign(padded, std::numeric_limits<float>::quiet_NaN());
        for (size_t i = 0; i < n; ++i) coord[k][a][i] = v[k][i][a];
      }
    triangle.assign(padded, 0.f);
    for (size_t i = 0; i < n; ++i) triangle[i] = is_triangle[i] ? 1.f : 0.f;
    assign_corners(v, is_triangle);
  }

 private:
  void assign_corners(const std::vector<Vec3> (&v)[4], const std::vector<uint8_t>& is_triangle) {
    for (auto& c : corner_xyz) c.clear();
    for (auto& c : corner_of) c.clear();
    const size_t n = is_triangle.size();
    std::vector<Vec3> distinct;
    const auto index_of = [&](const Vec3& p) {
      for (size_t j = 0; j < distinct.size(); ++j)
        if (std::memcmp(&distinct[j], &p, sizeof(Vec3)) == 0) return j;
      distinct.push_back(p);
      return distinct.size() - 1;
    };
    std::vector<uint16_t> of[4];
    for (size_t i = 0; i < n && distinct.size() <= kMaxSharedCorners; ++i)
      for (int k = 0; k < 4; ++k) of[k].push_back(static_cast<uint16_t>(index_of(v[is_triangle[i] && k == 3 ? 0 : k][i])));
    if (distinct.size() > kMaxSharedCorners) return;
    for (int k = 0; k < 4; ++k) corner_of[k] = std::move(of[k]);
    for (const Vec3& p : distinct)
      for (int a = 0; a < 3; ++a) corner_xyz[a].push_back(p[a]);
  }
};

namespace simd_detail {

// The ray as the sheared test sees it: the origin permuted into (kx, ky, kz) order, and the shear.
struct ShearedRay {
  float ox, oy, oz, sx, sy, sz;
  ShearedRay(Vec3 o, const RayShear& s) : ox(o[s.kx]), oy(o[s.ky]), oz(o[s.kz]), sx(s.sx), sy(s.sy), sz(s.sz) {}
};

// Everything a block test needs, resolved once per ray: the sheared ray and the base pointers of the permuted
// coordinate arrays (so the loop does no per-iteration index arithmetic on glm vectors).
struct RayLanes : ShearedRay {
  const float *x[4], *y[4], *z[4];
  const float* triangle;
  RayLanes(const PolygonLanes& L, Vec3 o, const RayShear& s) : ShearedRay(o, s), triangle(L.triangle.data()) {
    for (int k = 0; k < 4; ++k) {
      x[k] = L.coord[k][s.kx].data();
      y[k] = L.coord[k][s.ky].data();
      z[k] = L.coord[k][s.kz].data();
    }
  }
};

template <class V>
struct LaneVertex {
  V x, y, z;
};

// shear_vertex() of geometry.h, lane-wise, on coordinates already permuted into the ray's (kx, ky, kz) order.
template <class V>
[[gnu::always_inline]] inline LaneVertex<V> shear_lanes(const V& x, const V& y, const V& z, const ShearedRay& R) {
  const V px = x - R.ox, py = y - R.oy, pz = z - R.oz;
  return {px - R.sx * pz, py - R.sy * pz, R.sz * pz};
}
template <class V>
[[gnu::always_inline]] inline LaneVertex<V> load_sheared(const RayLanes& R, int k, size_t i) {
  return shear_lanes(V(R.x[k] + i, stdx::element_aligned), V(R.y[k] + i, stdx::element_aligned),
                     V(R.z[k] + i, stdx::element_aligned), R);
}

// The edge function q.x·p.y − q.y·p.x of geometry.h (exactly antisymmetric: no FMA).
template <class V>
[[gnu::always_inline]] inline V edge(const LaneVertex<V>& p, const LaneVertex<V>& q) {
  return q.x * p.y - q.y * p.x;
}

template <class V>
struct BlockResult {
  V t;                              // hit distance, +inf where the lane has no hit in (0, t_max)
  typename V::mask_type zero_edge;  // lanes to settle with the scalar test
};

// The end of intersect_triangle()/intersect_quad()'s arithmetic from the edge functions: the two-sided inside
// test over edges e0…e3 and the distance from the first three.
template <class V>
[[gnu::always_inline]] inline BlockResult<V> finish_block(const LaneVertex<V>& A, const LaneVertex<V>& B,
                                                          const LaneVertex<V>& C, const V& eab, const V& ebc,
                                                          const V& eca, const V& lo, const V& hi, float t_max) {
  using M = typename V::mask_type;
  // Inside when no edge function is negative or none is positive (two-sided). A lane that is inside only
  // because some edge function is exactly 0 goes to the scalar test for the double-precision settlement
  // (a quad's diagonal c→a only locates the hit within the quad and is not checked).
  BlockResult<V> r;
  r.zero_edge = lo == 0.f || hi == 0.f;
  const M inside = lo > 0.f || hi < 0.f;
  // det = U + V + W and t = (U·a.z + V·b.z + W·c.z)/det with U = e(b→c), V = e(c→a), W = e(a→b).
  const V det = ebc + eca + eab;
  r.t = (ebc * A.z + eca * B.z + eab * C.z) / det;
  // det = 0 gives ±inf or NaN, which fail the comparisons.
  stdx::where(!(inside && r.t > 0.f && r.t < t_max), r.t) = kInfinity;
  return r;
}

// Polygons with sheared corners A…D (a triangle lane: D = A) against the ray, with intersect_triangle()/
// intersect_quad()'s arithmetic; `triangle` masks the triangle lanes.
template <class V>
[[gnu::always_inline]] inline BlockResult<V> test_sheared(const LaneVertex<V>& A, const LaneVertex<V>& B,
                                                          const LaneVertex<V>& C, const LaneVertex<V>& D,
                                                          const typename V::mask_type& triangle, float t_max) {
  const V eab = edge(A, B), ebc = edge(B, C), eca = edge(C, A), ecd = edge(C, D);
  V eda = edge(D, A);
  stdx::where(triangle, eda) = eca;
  return finish_block(A, B, C, eab, ebc, eca, stdx::min(stdx::min(eab, ebc), stdx::min(ecd, eda)),
                      stdx::max(stdx::max(eab, ebc), stdx::max(ecd, eda)), t_max);
}

// The same when every lane is a triangle (or padding): with D = A the quad's edge c→d is c→a and d→a is
// replaced by c→a, so the minimum and maximum over the four edges equal those over the three, bit for bit
// (min(x, x) = x), and D need not be loaded.
template <class V>
[[gnu::always_inline]] inline BlockResult<V> test_sheared_triangles(const LaneVertex<V>& A, const LaneVertex<V>& B,
                                                                    const LaneVertex<V>& C, float t_max) {
  const V eab = edge(A, B), ebc = edge(B, C), eca = edge(C, A);
  return finish_block(A, B, C, eab, ebc, eca, stdx::min(stdx::min(eab, ebc), eca),
                      stdx::max(stdx::max(eab, ebc), eca), t_max);
}

// Lanes i … i + |V| − 1 against the ray, with intersect_triangle()/intersect_quad()'s arithmetic.
template <class V>
[[gnu::always_inline]] inline BlockResult<V> test_block(const RayLanes& R, size_t i, float t_max) {
  return test_sheared(load_sheared<V>(R, 0, i), load_sheared<V>(R, 1, i), load_sheared<V>(R, 2, i),
                      load_sheared<V>(R, 3, i), V(R.triangle + i, stdx::element_aligned) > 0.f, t_max);
}

template <class V>
[[gnu::always_inline]] inline V lane_indices() {
  return V([](auto k) { return static_cast<float>(k); });
}

// Masks out lane `skip − i` (no-op when polygon `skip` is not in this block: the difference, as an unsigned
// number converted to float, then equals no lane index).
template <class V>
[[gnu::always_inline]] inline void mask_lane(V& t, uint32_t skip, size_t i) {
  stdx::where(lane_indices<V>() == static_cast<float>(static_cast<uint32_t>(skip - i)), t) = kInfinity;
}

using vfloat4 = stdx::simd<float, stdx::simd_abi::deduce_t<float, 4>>;
using vfloat8 = stdx::simd<float, stdx::simd_abi::deduce_t<float, 8>>;

// Calls f(i, V{}) for the last, partly filled block of polygons starting at i, with V the narrowest vector
// type that holds it.
template <class F>
[[gnu::always_inline]] inline auto tail_block(size_t i, size_t rest, const F& f) {
  if constexpr (kLanes > 4)
    if (rest <= 4) return f(i, vfloat4{});
  if constexpr (kLanes > 8)
    if (rest <= 8) return f(i, vfloat8{});
  return f(i, vfloat{});
}

// The first lane holding the minimum of t, and that minimum.
template <class V>
[[gnu::always_inline]] inline float block_min(const V& t, int& lane) {
  const float m = stdx::hmin(t);
  lane = stdx::find_first_set(t == m);
  return m;
}

}  // namespace simd_detail

// Closest hit in (0, t_max) among the polygons, never reporting polygon `skip`. On a hit, lowers t_max to its
// distance, sets id and returns true. `scalar_test(i, t_max, hit)` re-tests polygon i with the scalar routine
// (lanes with a zero edge function).
template <class ScalarTest>
inline bool closest_polygon(const PolygonLanes& L, Vec3 o, const RayShear& s, uint32_t skip, float& t_max,
                            uint32_t& id, const ScalarTest& scalar_test) {
  using namespace simd_detail;
  const RayLanes R(L, o, s);
  const float t_in = t_max;
  // Lanes settled by the scalar test are rare: they update t_max and id directly.
  auto settle = [&](const auto& r, size_t i, size_t width) {
    for (size_t lane = 0; lane < width; ++lane) {
      if (!r.zero_edge[lane] || i + lane >= L.count || i + lane == skip) continue;
      PolygonHit h{};
      if (scalar_test(static_cast<uint32_t>(i + lane), t_max, h) && h.t < t_max) {
        t_max = h.t;
        id = static_cast<uint32_t>(i + lane);
      }
    }
  };
  // Full blocks: a running per-lane minimum and the block it came from, one horizontal reduction at the end.
  const size_t full = L.count / kLanes * kLanes;
  if (full > 0) {
    vfloat best(kInfinity), best_block(0.f);
    for (size_t i = 0; i < full; i += kLanes) {
      BlockResult<vfloat> r = test_block<vfloat>(R, i, t_in);
      mask_lane(r.t, skip, i);
      if (stdx::any_of(r.zero_edge)) [[unlikely]] {
        stdx::where(r.zero_edge, r.t) = kInfinity;
        settle(r, i, kLanes);
      }
      const auto closer = r.t < best;
      stdx::where(closer, best) = r.t;
      stdx::where(closer, best_block) = static_cast<float>(i);
    }
    int lane;
    const float t = block_min(best, lane);
    if (t < t_max) {
      t_max = t;
      id = static_cast<uint32_t>(best_block[lane]) + lane;
    }
  }
  if (full < L.count) {
    tail_block(full, L.count - full, [&](size_t i, auto tag) {
      using V = decltype(tag);
      BlockResult<V> r = test_block<V>(R, i, t_in);
      mask_lane(r.t, skip, i);
      if (stdx::any_of(r.zero_edge)) [[unlikely]] {
        stdx::where(r.zero_edge, r.t) = kInfinity;
        settle(r, i, V::size());
      }
      int lane;
      const float t = block_min(r.t, lane);
      if (t < t_max) {
        t_max = t;
        id = static_cast<uint32_t>(i) + lane;
      }
    });
  }
  return t_max < t_in;
}

// Any hit in (0, t_max) among the polygons, ignoring polygons skip_a and skip_b.
template <class ScalarTest>
inline bool any_polygon(const PolygonLanes& L, Vec3 o, const RayShear& s, uint32_t skip_a, uint32_t skip_b,
                        float t_max, const ScalarTest& scalar_test) {
  using namespace simd_detail;
  const RayLanes R(L, o, s);
  auto block = [&](size_t i, auto tag) {
    using V = decltype(tag);
    BlockResult<V> r = test_block<V>(R, i, t_max);
    mask_lane(r.t, skip_a, i);
    mask_lane(r.t, skip_b, i);
    if (stdx::any_of(r.zero_edge)) [[unlikely]] {
      for (size_t lane = 0; lane < V::size(); ++lane) {
        if (!r.zero_edge[lane] || i + lane >= L.count || i + lane == skip_a || i + lane == skip_b) continue;
        r.t[lane] = kInfinity;
        PolygonHit h{};
        if (scalar_test(static_cast<uint32_t>(i + lane), t_max, h)) return true;
      }
    }
    return stdx::any_of(r.t < t_max);
  };
  const size_t full = L.count / kLanes * kLanes;
  for (size_t i = 0; i < full; i += kLanes)
    if (block(i, vfloat{})) return true;
  return full < L.count && tail_block(full, L.count - full, block);
}

}  // namespace pt
