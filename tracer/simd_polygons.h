// Ray tests of many polygons at once: the watertight test of geometry.h, one polygon per SIMD lane.
//
// Width: std::experimental::native_simd<float> (libstdc++'s Parallelism TS v2), i.e. 16 lanes with AVX-512,
// 8 with AVX2, 4 with SSE: the build picks the widest the target CPU has (PT_NATIVE), and any other CPU still
// gets a correct, portable build. A last, partly filled block of at most 4 or 8 polygons runs on 4- or 8-wide
// vectors (a 16-wide block costs about twice an 8-wide one on CPUs that split 512-bit operations).
//
// Every lane computes exactly the float operations of the scalar tests in geometry.h, in the same order (the
// project builds with -ffp-contract=off; libstdc++'s simd fma is an out-of-line call, so there are no FMAs), so
// SIMD and scalar results are bit-identical and watertightness carries over. Lanes whose edge function is exactly 0 are re-tested by
// the scalar routine, which settles them in double as Woop et al. prescribe.
#pragma once
#include <experimental/simd>
#include <vector>

#include "geometry.h"

namespace pt {

namespace stdx = std::experimental;
using vfloat = stdx::native_simd<float>;
inline constexpr int kLanes = static_cast<int>(vfloat::size());

// Polygons (N = 3: triangles, N = 4: convex planar quads) as padded structure of arrays: coord[k][axis][i] is
// axis `axis` of vertex k of polygon i. Padding lanes hold NaN, which fails every comparison and so never
// reports a hit.
template <int N>
struct PolygonLanes {
  uint32_t count = 0;
  std::vector<float> coord[N][3];

  void assign(const std::vector<Vec3> (&v)[N], size_t n) {
    count = static_cast<uint32_t>(n);
    const size_t padded = (n + kLanes - 1) / kLanes * kLanes;
    for (int k = 0; k < N; ++k)
      for (int a = 0; a < 3; ++a) {
        coord[k][a].assign(padded, std::numeric_limits<float>::quiet_NaN());
        for (size_t i = 0; i < n; ++i) coord[k][a][i] = v[k][i][a];
      }
  }
};

namespace simd_detail {

// Everything a block test needs, resolved once per ray: the permuted origin, the shear, and the base pointers
// of the permuted coordinate arrays (so the loop does no per-iteration index arithmetic on glm vectors).
template <int N>
struct RayLanes {
  float ox, oy, oz, sx, sy, sz;
  const float *x[N], *y[N], *z[N];
  RayLanes(const PolygonLanes<N>& L, Vec3 o, const RayShear& s)
      : ox(o[s.kx]), oy(o[s.ky]), oz(o[s.kz]), sx(s.sx), sy(s.sy), sz(s.sz) {
    for (int k = 0; k < N; ++k) {
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

// shear_vertex() of geometry.h, lane-wise.
template <class V, int N>
[[gnu::always_inline]] inline LaneVertex<V> load_sheared(const RayLanes<N>& R, int k, size_t i) {
  const V px = V(R.x[k] + i, stdx::element_aligned) - R.ox;
  const V py = V(R.y[k] + i, stdx::element_aligned) - R.oy;
  const V pz = V(R.z[k] + i, stdx::element_aligned) - R.oz;
  return {px - R.sx * pz, py - R.sy * pz, R.sz * pz};
}

// The edge function q.x·p.y − q.y·p.x, without FMA: it must stay exactly antisymmetric.
template <class V>
[[gnu::always_inline]] inline V edge(const LaneVertex<V>& p, const LaneVertex<V>& q) {
  return q.x * p.y - q.y * p.x;
}

// Results of one block of lanes: t (or +inf where there is no hit), and what the winning lane's barycentrics
// are computed from.
template <class V>
struct BlockResult {
  V t, U, V_, W;  // U = e(b→c), V_ = e(c→a), W = e(a→b)
  V ecd, eda;     // quads only
  bool any_zero_edge;
  typename V::mask_type zero_edge;  // lanes to settle with the scalar test
};

template <class V, int N>
[[gnu::always_inline]] inline BlockResult<V> test_block(const RayLanes<N>& R, size_t i, float t_max) {
  using M = typename V::mask_type;
  const LaneVertex<V> A = load_sheared<V>(R, 0, i), B = load_sheared<V>(R, 1, i), C = load_sheared<V>(R, 2, i);
  BlockResult<V> r;
  r.U = edge(B, C);
  r.V_ = edge(C, A);
  r.W = edge(A, B);
  // Inside when no edge function is negative or none is positive (two-sided); an exactly zero edge function
  // in a lane that passes this test needs the scalar double-precision settlement.
  V lo, hi;
  if constexpr (N == 3) {
    lo = stdx::min(stdx::min(r.U, r.V_), r.W);
    hi = stdx::max(stdx::max(r.U, r.V_), r.W);
  } else {
    const LaneVertex<V> D = load_sheared<V>(R, 3, i);
    r.ecd = edge(C, D);
    r.eda = edge(D, A);
    lo = stdx::min(stdx::min(r.W, r.U), stdx::min(r.ecd, r.eda));
    hi = stdx::max(stdx::max(r.W, r.U), stdx::max(r.ecd, r.eda));
  }
  const M inside = lo >= 0.f || hi <= 0.f;
  r.zero_edge = lo == 0.f || hi == 0.f;
  r.any_zero_edge = stdx::any_of(r.zero_edge);
  const V det = r.U + r.V_ + r.W;
  const V T = r.U * A.z + r.V_ * B.z + r.W * C.z;
  // t = T/det in (0, t_max); det = 0 gives ±inf or NaN, which fail the comparisons.
  r.t = T / det;
  stdx::where(!(inside && r.t > 0.f && r.t < t_max), r.t) = kInfinity;
  return r;
}

template <class V>
inline V lane_indices() {
  return V([](auto k) { return static_cast<float>(k); });
}

// Calls f(i, V{}) for each block of polygons starting at i, with V the vector type to test it with: full blocks
// at native width, a last block of ≤ 4 or ≤ 8 polygons on narrower vectors. Stops when f returns true.
using vfloat4 = stdx::simd<float, stdx::simd_abi::deduce_t<float, 4>>;
using vfloat8 = stdx::simd<float, stdx::simd_abi::deduce_t<float, 8>>;
template <class F>
[[gnu::always_inline]] inline bool for_each_block(uint32_t count, const F& f) {
  size_t i = 0;
  for (; i + kLanes <= count; i += kLanes)
    if (f(i, vfloat{})) return true;
  const size_t rest = count - i;
  if (rest == 0) return false;
  if constexpr (kLanes > 4)
    if (rest <= 4) return f(i, vfloat4{});
  if constexpr (kLanes > 8)
    if (rest <= 8) return f(i, vfloat8{});
  return f(i, vfloat{});
}

}  // namespace simd_detail

// Closest hit; `scalar_test(i, t_max, hit)` re-tests polygon i with the scalar routine for lanes with a zero
// edge function.
template <int N, class ScalarTest>
inline bool closest_polygon(const PolygonLanes<N>& L, Vec3 o, const RayShear& s, uint32_t skip, float& t_max,
                            uint32_t& id, PolygonHit& out, const ScalarTest& scalar_test) {
  bool found = false;
  const simd_detail::RayLanes<N> R(L, o, s);
  simd_detail::for_each_block(L.count, [&](size_t i, auto tag) {
    using V = decltype(tag);
    constexpr size_t W = V::size();
    simd_detail::BlockResult<V> r = simd_detail::test_block<V>(R, i, t_max);
    if (i <= skip && skip < i + W)
      stdx::where(simd_detail::lane_indices<V>() == static_cast<float>(skip - i), r.t) = kInfinity;
    if (r.any_zero_edge) [[unlikely]] {
      for (size_t lane = 0; lane < W; ++lane) {
        if (!r.zero_edge[lane] || i + lane >= L.count || i + lane == skip) continue;
        r.t[lane] = kInfinity;
        PolygonHit h{};
        if (scalar_test(static_cast<uint32_t>(i + lane), t_max, h) && h.t < t_max) {
          t_max = h.t;
          id = static_cast<uint32_t>(i + lane);
          out = h;
          found = true;
        }
      }
    }
    // Most blocks hold nothing closer than what is known: one mask test, no horizontal reduction.
    if (stdx::none_of(r.t < t_max)) return false;
    const float t_min = stdx::hmin(r.t);
    const int lane = stdx::find_first_set(r.t == t_min);
    t_max = t_min;
    id = static_cast<uint32_t>(i + lane);
    const float U = r.U[lane], V_ = r.V_[lane], W_ = r.W[lane];
    if constexpr (N == 3) {
      const float inv = 1.f / (U + V_ + W_);
      out = {t_min, U * inv, V_ * inv, W_ * inv, 0};
    } else {
      out = quad_barycentrics(t_min, W_, U, r.ecd[lane], r.eda[lane], V_, U + V_ + W_);
    }
    found = true;
    return false;
  });
  return found;
}

// Any hit in (0, t_max) among polygons of L, ignoring local ids skip_a and skip_b.
template <int N, class ScalarTest>
inline bool any_polygon(const PolygonLanes<N>& L, Vec3 o, const RayShear& s, uint32_t skip_a, uint32_t skip_b,
                        float t_max, const ScalarTest& scalar_test) {
  const simd_detail::RayLanes<N> R(L, o, s);
  return simd_detail::for_each_block(L.count, [&](size_t i, auto tag) {
    using V = decltype(tag);
    constexpr size_t W = V::size();
    simd_detail::BlockResult<V> r = simd_detail::test_block<V>(R, i, t_max);
    const V lane_index = simd_detail::lane_indices<V>();
    if (i <= skip_a && skip_a < i + W) stdx::where(lane_index == static_cast<float>(skip_a - i), r.t) = kInfinity;
    if (i <= skip_b && skip_b < i + W) stdx::where(lane_index == static_cast<float>(skip_b - i), r.t) = kInfinity;
    if (r.any_zero_edge) [[unlikely]] {
      for (size_t lane = 0; lane < W; ++lane) {
        if (!r.zero_edge[lane] || i + lane >= L.count || i + lane == skip_a || i + lane == skip_b) continue;
        r.t[lane] = kInfinity;
        PolygonHit h{};
        if (scalar_test(static_cast<uint32_t>(i + lane), t_max, h)) return true;
      }
    }
    return stdx::any_of(r.t < t_max);
  });
}

}  // namespace pt
