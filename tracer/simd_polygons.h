// Ray tests of many polygons at once: the watertight test of geometry.h, one polygon per SIMD lane.
//
// Width: std::experimental::native_simd<float> (libstdc++'s Parallelism TS v2), i.e. 16 lanes with AVX-512,
// 8 with AVX2, 4 with SSE: the build picks the widest the target CPU has (PT_NATIVE), and any other CPU still
// gets a correct, portable build. Every lane computes exactly the float operations of the scalar test in
// geometry.h, in the same order (the project builds with -ffp-contract=off), so SIMD and scalar results are
// bit-identical and watertightness carries over. Lanes whose edge function is exactly 0 are re-tested by the
// scalar routine, which settles them in double as Woop et al. prescribe.
#pragma once
#include <experimental/simd>
#include <vector>

#include "geometry.h"

namespace pt {

namespace stdx = std::experimental;
using vfloat = stdx::native_simd<float>;
using vmask = vfloat::mask_type;
inline constexpr int kLanes = static_cast<int>(vfloat::size());

// Polygon vertices as padded structure of arrays: coord[k][axis][i] is axis `axis` of vertex k of polygon i.
// Padding lanes hold NaN, which fails every comparison and so never reports a hit.
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

struct LaneVertex {
  vfloat x, y, z;
};

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

template <int N>
[[gnu::always_inline]] inline LaneVertex load_sheared(const RayLanes<N>& R, int k, size_t i) {
  const vfloat px = vfloat(R.x[k] + i, stdx::element_aligned) - R.ox;
  const vfloat py = vfloat(R.y[k] + i, stdx::element_aligned) - R.oy;
  const vfloat pz = vfloat(R.z[k] + i, stdx::element_aligned) - R.oz;
  return {px - R.sx * pz, py - R.sy * pz, R.sz * pz};
}

inline vfloat edge(const LaneVertex& p, const LaneVertex& q) { return q.x * p.y - q.y * p.x; }

// Results of one block of lanes: t (or +inf where there is no hit) and barycentric numerators.
struct BlockResult {
  vfloat t, U, V, W, inv_det;
  vmask zero_edge;  // lanes to settle with the scalar test
};

template <int N>
[[gnu::always_inline]] inline BlockResult test_block(const RayLanes<N>& R, size_t i, float t_max) {
  const LaneVertex A = load_sheared(R, 0, i), B = load_sheared(R, 1, i), C = load_sheared(R, 2, i);
  BlockResult r;
  vmask inside_pos, inside_neg;
  if constexpr (N == 3) {
    r.U = edge(B, C);
    r.V = edge(C, A);
    r.W = edge(A, B);
    inside_pos = (r.U >= 0.f) && (r.V >= 0.f) && (r.W >= 0.f);
    inside_neg = (r.U <= 0.f) && (r.V <= 0.f) && (r.W <= 0.f);
    r.zero_edge = (r.U == 0.f) || (r.V == 0.f) || (r.W == 0.f);
  } else {
    const LaneVertex D = load_sheared(R, 3, i);
    const vfloat eab = edge(A, B), ebc = edge(B, C), ecd = edge(C, D), eda = edge(D, A);
    inside_pos = (eab >= 0.f) && (ebc >= 0.f) && (ecd >= 0.f) && (eda >= 0.f);
    inside_neg = (eab <= 0.f) && (ebc <= 0.f) && (ecd <= 0.f) && (eda <= 0.f);
    r.zero_edge = (eab == 0.f) || (ebc == 0.f) || (ecd == 0.f) || (eda == 0.f);
    r.U = ebc;
    r.V = edge(C, A);
    r.W = eab;
    r.zero_edge = r.zero_edge || (r.V == 0.f);
  }
  const vfloat det = r.U + r.V + r.W;
  const vfloat T = r.U * A.z + r.V * B.z + r.W * C.z;
  // Same acceptance as the scalar test: 0 < T/det < t_max, compared without dividing.
  const vmask pos = det > 0.f, neg = det < 0.f;
  vmask hit = (inside_pos || inside_neg) && (pos || neg);
  hit = hit && ((pos && T > 0.f && T < t_max * det) || (neg && T < 0.f && T > t_max * det));
  r.inv_det = 1.f / det;
  r.t = T * r.inv_det;
  stdx::where(!hit, r.t) = kInfinity;
  return r;
}

}  // namespace simd_detail

// Closest hit; `scalar_test(i, t_max, hit)` re-tests polygon i with the scalar routine for lanes with a zero
// edge function.
template <int N, class ScalarTest>
inline bool closest_polygon(const PolygonLanes<N>& L, Vec3 o, const RayShear& s, uint32_t skip, float& t_max,
                            uint32_t& id, PolygonHit& out, const ScalarTest& scalar_test) {
  bool found = false;
  const size_t n = L.coord[0][0].size();
  const vfloat lane_index([](auto k) { return static_cast<float>(k); });
  const simd_detail::RayLanes<N> R(L, o, s);
  for (size_t i = 0; i < n; i += kLanes) {
    simd_detail::BlockResult r = simd_detail::test_block(R, i, t_max);
    if (i <= skip && skip < i + kLanes) stdx::where(lane_index == static_cast<float>(skip - i), r.t) = kInfinity;
    if (stdx::any_of(r.zero_edge)) [[unlikely]] {
      for (int lane = 0; lane < kLanes; ++lane) {
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
    if (stdx::none_of(r.t < t_max)) continue;
    const float t_min = stdx::hmin(r.t);
    const int lane = stdx::find_first_set(r.t == t_min);
    t_max = t_min;
    id = static_cast<uint32_t>(i + lane);
    const float inv = r.inv_det[lane];
    out = {t_min, r.U[lane] * inv, r.V[lane] * inv, r.W[lane] * inv};
    found = true;
  }
  return found;
}

// Any hit in (0, t_max) among polygons of L, ignoring local ids skip_a and skip_b.
template <int N, class ScalarTest>
inline bool any_polygon(const PolygonLanes<N>& L, Vec3 o, const RayShear& s, uint32_t skip_a, uint32_t skip_b,
                        float t_max, const ScalarTest& scalar_test) {
  const size_t n = L.coord[0][0].size();
  const vfloat lane_index([](auto k) { return static_cast<float>(k); });
  const simd_detail::RayLanes<N> R(L, o, s);
  for (size_t i = 0; i < n; i += kLanes) {
    simd_detail::BlockResult r = simd_detail::test_block(R, i, t_max);
    if (i <= skip_a && skip_a < i + kLanes) stdx::where(lane_index == static_cast<float>(skip_a - i), r.t) = kInfinity;
    if (i <= skip_b && skip_b < i + kLanes) stdx::where(lane_index == static_cast<float>(skip_b - i), r.t) = kInfinity;
    if (stdx::any_of(r.zero_edge)) [[unlikely]] {
      for (int lane = 0; lane < kLanes; ++lane) {
        if (!r.zero_edge[lane] || i + lane >= L.count || i + lane == skip_a || i + lane == skip_b) continue;
        r.t[lane] = kInfinity;
        PolygonHit h{};
        if (scalar_test(static_cast<uint32_t>(i + lane), t_max, h)) return true;
      }
    }
    if (stdx::any_of(r.t < t_max)) return true;
  }
  return false;
}

}  // namespace pt
