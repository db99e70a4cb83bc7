// Many rays against one polygon per SIMD step: the transpose of simd_polygons.h. A packet holds up to kLanes
// rays (one per lane, 16 with AVX-512) and the polygons are visited one at a time, each broadcast to all lanes.
//
// Why: a single incoherent ray against 16 polygons per step (simd_polygons.h) is one long dependency chain per
// ray (load, shear, edges, reduce), bound by latency. Sixteen rays against one polygon per step have no chain
// from one polygon to the next except a running minimum, so the loop is bound by arithmetic throughput instead.
// It suits scenes small enough for brute force (fewer than kBvhMinPolygons polygons), where every ray tests
// every polygon anyway; rays need not be coherent.
//
// Every lane computes exactly the float operations of the scalar watertight tests of geometry.h (Woop, Benthin &
// Wald 2013) for its own ray, in the same order (-ffp-contract=off): the ray's axis permutation is applied per lane
// by selecting among the broadcast vertex coordinates, which is exact. So a packet's hit distances are
// bit-identical to the single-ray kernels' (tested: "packet: ..."). Lanes whose edge function is exactly 0 are
// settled by the scalar test in double, as in the single-ray kernels. Where two polygons are hit at exactly the
// same distance, the lowest-numbered one is reported (the single-ray kernel may name the other: the distance,
// and so the image, is the same up to that tie).
#pragma once
#include <cstdint>

#include "core/ray.h"
#include "geometry/simd_polygons.h"

namespace pt {

// Up to kLanes rays in structure-of-arrays form with their per-ray constants of the watertight test. Lanes at
// and beyond `count` are inactive: they never report a hit.
struct RayPacket {
  using M = vfloat::mask_type;
  int count = 0;
  vfloat ox, oy, oz;       // origin components along the ray's permuted axes kx, ky, kz
  vfloat sx, sy, sz;       // shear constants
  M kx0, kx1, ky0, ky1, kz0, kz1;  // the permutation: lane's kx == 0, kx == 1, etc. (2 otherwise)
  vfloat t_max;            // queries search (0, t_max); inactive lanes hold −inf
  vfloat skip_a, skip_b;   // polygon indices to ignore, as floats (exact below 2^24); −1 for none

  // Loads rays [0, n) (n ≤ kLanes). skip_b may be null (closest-hit queries skip one primitive). The per-ray
  // set-up of RayShear runs lane-wise with the same operations (max_dimension's comparisons, 1/d[kz], d·sz).
  void load(const Ray* rays, const float* t_max_in, const uint32_t* skip_a_in, const uint32_t* skip_b_in, int n);
};

namespace packet_detail {

// The lane's component 0 / 1 / 2 of a vector, chosen by the lane's masks (is0, is1; 2 otherwise).
template <class T>
[[gnu::always_inline]] inline vfloat pick(const vfloat::mask_type& is0, const vfloat::mask_type& is1, const T& a,
                                          const T& b, const T& c) {
  vfloat r(c);
  stdx::where(is1, r) = b;
  stdx::where(is0, r) = a;
  return r;
}

}  // namespace packet_detail

inline void RayPacket::load(const Ray* rays, const float* t_max_in, const uint32_t* skip_a_in,
                            const uint32_t* skip_b_in, int n) {
  using packet_detail::pick;
  count = n;
  alignas(64) float v[6][kLanes];
  alignas(64) float tm[kLanes], sa[kLanes], sb[kLanes];
  for (int l = 0; l < kLanes; ++l) {
    const bool on = l < n;
    const Ray& r = rays[on ? l : 0];
    for (int k = 0; k < 3; ++k) {
      v[k][l] = r.o[k];
      v[3 + k][l] = r.d[k];
    }
    tm[l] = on ? t_max_in[l] : -kInfinity;
    sa[l] = on && skip_a_in[l] != ~0u ? static_cast<float>(skip_a_in[l]) : -1.f;
    sb[l] = on && skip_b_in && skip_b_in[l] != ~0u ? static_cast<float>(skip_b_in[l]) : -1.f;
  }
  const vfloat o[3] = {vfloat(v[0], stdx::vector_aligned), vfloat(v[1], stdx::vector_aligned),
                       vfloat(v[2], stdx::vector_aligned)};
  const vfloat d[3] = {vfloat(v[3], stdx::vector_aligned), vfloat(v[4], stdx::vector_aligned),
                       vfloat(v[5], stdx::vector_aligned)};
  const vfloat ax = stdx::abs(d[0]), ay = stdx::abs(d[1]), az = stdx::abs(d[2]);
  // max_dimension: x > y ? (x > z ? 0 : 2) : (y > z ? 1 : 2); then kx = kz + 1, ky = kx + 1 (mod 3).
  const M x_gt_y = ax > ay;
  const M z0 = x_gt_y && ax > az, z1 = !x_gt_y && ay > az;
  vfloat kz(2.f), kx(0.f), ky(1.f);
  stdx::where(z0, kz) = 0.f;
  stdx::where(z0, kx) = 1.f;
  stdx::where(z0, ky) = 2.f;
  stdx::where(z1, kz) = 1.f;
  stdx::where(z1, kx) = 2.f;
  stdx::where(z1, ky) = 0.f;
  const vfloat dz = pick(z0, z1, d[0], d[1], d[2]);
  const M flip = dz < 0.f;  // keep the winding: swap kx and ky
  const vfloat kx_old = kx;
  stdx::where(flip, kx) = ky;
  stdx::where(flip, ky) = kx_old;
  kx0 = kx == 0.f, kx1 = kx == 1.f, ky0 = ky == 0.f, ky1 = ky == 1.f, kz0 = z0, kz1 = z1;
  sz = 1.f / dz;
  sx = pick(kx0, kx1, d[0], d[1], d[2]) * sz;
  sy = pick(ky0, ky1, d[0], d[1], d[2]) * sz;
  ox = pick(kx0, kx1, o[0], o[1], o[2]);
  oy = pick(ky0, ky1, o[0], o[1], o[2]);
  oz = pick(kz0, kz1, o[0], o[1], o[2]);
  t_max = vfloat(tm, stdx::vector_aligned);
  skip_a = vfloat(sa, stdx::vector_aligned);
  skip_b = vfloat(sb, stdx::vector_aligned);
}

namespace packet_detail {

using simd_detail::LaneVertex;

// shear_vertex() of geometry.h for vertex k of polygon i, in every lane.
[[gnu::always_inline]] inline LaneVertex<vfloat> sheared(const RayPacket& P, const PolygonLanes& L, int k, size_t i) {
  const float x = L.coord[k][0][i], y = L.coord[k][1][i], z = L.coord[k][2][i];
  const vfloat px = pick(P.kx0, P.kx1, x, y, z) - P.ox;
  const vfloat py = pick(P.ky0, P.ky1, x, y, z) - P.oy;
  const vfloat pz = pick(P.kz0, P.kz1, x, y, z) - P.oz;
  return {px - P.sx * pz, py - P.sy * pz, P.sz * pz};
}

// Polygon i against every lane: intersect_triangle()/intersect_quad()'s arithmetic, as simd_detail::test_block.
[[gnu::always_inline]] inline simd_detail::BlockResult<vfloat> test_polygon(const RayPacket& P, const PolygonLanes& L,
                                                                           size_t i) {
  using simd_detail::edge;
  const LaneVertex<vfloat> A = sheared(P, L, 0, i), B = sheared(P, L, 1, i), C = sheared(P, L, 2, i);
  const vfloat eab = edge(A, B), ebc = edge(B, C), eca = edge(C, A);
  vfloat lo, hi;
  if (L.triangle[i] > 0.f) {  // the block test's triangle lane: (a, b, c, a), edge d→a replaced by c→a
    lo = stdx::min(stdx::min(eab, ebc), eca);
    hi = stdx::max(stdx::max(eab, ebc), eca);
  } else {
    const LaneVertex<vfloat> D = sheared(P, L, 3, i);
    const vfloat ecd = edge(C, D), eda = edge(D, A);
    lo = stdx::min(stdx::min(eab, ebc), stdx::min(ecd, eda));
    hi = stdx::max(stdx::max(eab, ebc), stdx::max(ecd, eda));
  }
  simd_detail::BlockResult<vfloat> r;
  r.zero_edge = lo == 0.f || hi == 0.f;
  const auto inside = lo > 0.f || hi < 0.f;
  const vfloat det = ebc + eca + eab;
  r.t = (ebc * A.z + eca * B.z + eab * C.z) / det;
  stdx::where(!(inside && r.t > 0.f && r.t < P.t_max), r.t) = kInfinity;
  return r;
}

}  // namespace packet_detail

// Closest hit of every active lane among the polygons, never reporting the lane's skip_a. On return t[l] is the
// hit distance (+inf for none) and id[l] the polygon. `scalar_test(lane, i, t_max, hit)` re-tests polygon i for
// the lane's ray with the scalar routine (zero edge functions).
template <class ScalarTest>
inline void closest_polygon_packet(const PolygonLanes& L, const RayPacket& P, float* t_out, uint32_t* id_out,
                                   const ScalarTest& scalar_test) {
  using namespace packet_detail;
  vfloat best(kInfinity), best_id(-1.f);
  for (size_t i = 0; i < L.count; ++i) {
    simd_detail::BlockResult<vfloat> r = test_polygon(P, L, i);
    const float fi = static_cast<float>(i);
    stdx::where(P.skip_a == fi, r.t) = kInfinity;
    if (stdx::any_of(r.zero_edge)) [[unlikely]] {
      stdx::where(r.zero_edge, r.t) = kInfinity;
      for (int l = 0; l < P.count; ++l) {
        if (!r.zero_edge[l] || P.skip_a[l] == fi) continue;
        PolygonHit h{};
        if (scalar_test(l, static_cast<uint32_t>(i), P.t_max[l], h) && h.t < r.t[l]) r.t[l] = h.t;
      }
    }
    const auto closer = r.t < best;
    stdx::where(closer, best) = r.t;
    stdx::where(closer, best_id) = fi;
  }
  for (int l = 0; l < P.count; ++l) {
    t_out[l] = best[l];
    id_out[l] = best[l] < kInfinity ? static_cast<uint32_t>(best_id[l]) : ~0u;
  }
}

// Any hit of every active lane among the polygons, ignoring the lane's skip_a and skip_b. Returns the lanes
// that are occluded as a bit mask (bit l for lane l). Stops as soon as every active lane is occluded.
template <class ScalarTest>
inline uint32_t any_polygon_packet(const PolygonLanes& L, const RayPacket& P, const ScalarTest& scalar_test) {
  using namespace packet_detail;
  vfloat::mask_type blocked(false);
  const vfloat::mask_type active = P.t_max > -kInfinity;
  for (size_t i = 0; i < L.count; ++i) {
    simd_detail::BlockResult<vfloat> r = test_polygon(P, L, i);
    const float fi = static_cast<float>(i);
    const auto skipped = P.skip_a == fi || P.skip_b == fi;
    blocked = blocked || (r.t < P.t_max && !skipped);
    if (stdx::any_of(r.zero_edge && !skipped && !blocked)) [[unlikely]] {
      for (int l = 0; l < P.count; ++l) {
        if (!r.zero_edge[l] || skipped[l] || blocked[l]) continue;
        PolygonHit h{};
        if (scalar_test(l, static_cast<uint32_t>(i), P.t_max[l], h)) blocked[l] = true;
      }
    }
    if (stdx::all_of(blocked || !active)) break;
  }
  uint32_t bits = 0;
  for (int l = 0; l < P.count; ++l) bits |= blocked[l] ? 1u << l : 0u;
  return bits;
}

}  // namespace pt
