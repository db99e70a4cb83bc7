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
//
// Two specialisations keep the bits and cut the work:
// - Shared corners. Most of a polygon's cost is shearing its corners into the ray's frame (8 operations per
//   corner), and the polygons of a room share corners (cornell: 28 distinct corners for 68). Where the scene
//   has few enough distinct corners (PolygonLanes::shared_corners), a packet shears each once, into a table,
//   and the polygons read theirs from it: the same operations on the same floats, so the same results.
// - Uniform packets. Where all rays of a packet share their axis permutation (camera rays do), the corner's
//   coordinates are broadcast instead of chosen lane by lane.
#pragma once
#include <bit>
#include <cstdint>
#include <utility>

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
  // The permutation shared by every lane (inactive lanes copy lane 0's ray), as 2 kz + (1 when kx and ky are
  // swapped), or −1 when the lanes differ.
  int perm = -1;

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

// kLanes rays side by side in memory are 6·kLanes floats, component c of ray l at 6l + c: six vectors, and each
// component is a fixed permutation of them. Vector extensions that GCC (12 on) and clang share spell it for any
// width: each pair of vectors shuffled into the lanes they hold, then the three results merged lane by lane (with
// AVX-512, permutes of two sources and masked moves); the generic simd type has no such shuffle.
using RawFloats = float __attribute__((vector_size(sizeof(float) * kLanes)));
static_assert(sizeof(Ray) == 6 * sizeof(float) && sizeof(vfloat) == sizeof(RawFloats));

// Which pair of the six vectors (0, 1, 2) holds component C of lane l, its index within that pair (any index where
// another pair holds it), and the merges' choices: the second operand's lane (kLanes + l) where the lane is from
// the second or third pair.
template <int C>
constexpr int ray_source_pair(int l) {
  return (6 * l + C) / (2 * kLanes);
}
template <int C, int Pair>
constexpr int ray_index_in_pair(int l) {
  return ray_source_pair<C>(l) == Pair ? 6 * l + C - 2 * Pair * kLanes : 0;
}
template <int C, int Pair>
constexpr int ray_merge_index(int l) {
  return ray_source_pair<C>(l) == Pair ? kLanes + l : l;
}

// Component C (0–2: the origin's x, y, z; 3–5: the direction's) of the kLanes rays held in v.
template <int C, size_t... L>
[[gnu::always_inline]] inline vfloat ray_component(const RawFloats (&v)[6], std::index_sequence<L...>) {
  const RawFloats p0 = __builtin_shufflevector(v[0], v[1], ray_index_in_pair<C, 0>(static_cast<int>(L))...);
  const RawFloats p1 = __builtin_shufflevector(v[2], v[3], ray_index_in_pair<C, 1>(static_cast<int>(L))...);
  const RawFloats p2 = __builtin_shufflevector(v[4], v[5], ray_index_in_pair<C, 2>(static_cast<int>(L))...);
  const RawFloats first_two = __builtin_shufflevector(p0, p1, ray_merge_index<C, 1>(static_cast<int>(L))...);
  return std::bit_cast<vfloat>(__builtin_shufflevector(first_two, p2, ray_merge_index<C, 2>(static_cast<int>(L))...));
}

// A skip list as floats: −1 for none (~0u or no list), else the index (exact below 2^24).
[[gnu::always_inline]] inline vfloat skip_floats(const uint32_t* skip) {
  using vuint = stdx::rebind_simd_t<uint32_t, vfloat>;
  if (!skip) return vfloat(-1.f);
  const vuint u(skip, stdx::element_aligned);
  vfloat f = stdx::static_simd_cast<vfloat>(u);
  // The mask carried over by its bits (libstdc++'s __to_bitset and __from_bitset): masks of two element types do
  // not convert.
  stdx::where(vmask::__from_bitset((u == ~0u).__to_bitset()), f) = -1.f;
  return f;
}

}  // namespace packet_detail

inline void RayPacket::load(const Ray* rays, const float* t_max_in, const uint32_t* skip_a_in,
                            const uint32_t* skip_b_in, int n) {
  using packet_detail::pick;
  count = n;
  // A partial packet is completed first: its inactive lanes copy lane 0's ray (so that they share its axis
  // permutation), search (0, −inf) and skip nothing.
  Ray pad_rays[kLanes];
  float pad_t[kLanes];
  uint32_t pad_a[kLanes], pad_b[kLanes];
  if (n < kLanes) {
    for (int l = 0; l < kLanes; ++l) {
      const bool on = l < n;
      pad_rays[l] = rays[on ? l : 0];
      pad_t[l] = on ? t_max_in[l] : -kInfinity;
      pad_a[l] = on && skip_a_in ? skip_a_in[l] : ~0u;
      pad_b[l] = on && skip_b_in ? skip_b_in[l] : ~0u;
    }
    rays = pad_rays, t_max_in = pad_t, skip_a_in = pad_a, skip_b_in = skip_b_in ? pad_b : nullptr;
  }
  // The six vectors are read right after the caller stored the rays one by one, and wait for those stores to
  // complete (store-to-load forwarding cannot serve a vector from several stores); lane-by-lane inserts, which
  // need no such wait, cost more (docs/performance.md, session 49).
  packet_detail::RawFloats raw[6];
  const float* flat = reinterpret_cast<const float*>(rays);
  for (int i = 0; i < 6; ++i)
    raw[i] = std::bit_cast<packet_detail::RawFloats>(vfloat(flat + i * kLanes, stdx::element_aligned));
  constexpr auto lanes = std::make_index_sequence<kLanes>{};
  const vfloat o[3] = {packet_detail::ray_component<0>(raw, lanes), packet_detail::ray_component<1>(raw, lanes),
                       packet_detail::ray_component<2>(raw, lanes)};
  const vfloat d[3] = {packet_detail::ray_component<3>(raw, lanes), packet_detail::ray_component<4>(raw, lanes),
                       packet_detail::ray_component<5>(raw, lanes)};
  t_max = vfloat(t_max_in, stdx::element_aligned);
  skip_a = packet_detail::skip_floats(skip_a_in);
  skip_b = packet_detail::skip_floats(skip_b_in);
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
  const auto same = [](const M& m) { return stdx::all_of(m) || stdx::none_of(m); };
  perm = same(kz0) && same(kz1) && same(flip) ? 2 * (kz0[0] ? 0 : kz1[0] ? 1 : 2) + (flip[0] ? 1 : 0) : -1;
  sz = 1.f / dz;
  sx = pick(kx0, kx1, d[0], d[1], d[2]) * sz;
  sy = pick(ky0, ky1, d[0], d[1], d[2]) * sz;
  ox = pick(kx0, kx1, o[0], o[1], o[2]);
  oy = pick(ky0, ky1, o[0], o[1], o[2]);
  oz = pick(kz0, kz1, o[0], o[1], o[2]);
}

namespace packet_detail {

using simd_detail::LaneVertex;

// The permutation numbered `Perm` (RayPacket::perm): kz = Perm / 2, kx = kz + 1 and ky = kx + 1 (mod 3), kx and
// ky swapped for odd numbers (RayShear, core/ray.h).
template <int Perm>
struct Axes {
  static constexpr int kz = Perm / 2, kx0 = (kz + 1) % 3, ky0 = (kx0 + 1) % 3;
  static constexpr int kx = Perm % 2 ? ky0 : kx0, ky = Perm % 2 ? kx0 : ky0;
};

// shear_vertex() of geometry.h for the point (x, y, z), in every lane. Perm −1: each lane's own permutation
// (chosen by its masks); otherwise every lane's, known at compile time. The coordinates are the same floats
// either way (a choice is exact), so are the results.
template <int Perm>
[[gnu::always_inline]] inline LaneVertex<vfloat> sheared(const RayPacket& P, float x, float y, float z) {
  vfloat px, py, pz;
  if constexpr (Perm < 0) {
    px = pick(P.kx0, P.kx1, x, y, z) - P.ox;
    py = pick(P.ky0, P.ky1, x, y, z) - P.oy;
    pz = pick(P.kz0, P.kz1, x, y, z) - P.oz;
  } else {
    const float c[3] = {x, y, z};
    px = vfloat(c[Axes<Perm>::kx]) - P.ox;
    py = vfloat(c[Axes<Perm>::ky]) - P.oy;
    pz = vfloat(c[Axes<Perm>::kz]) - P.oz;
  }
  return {px - P.sx * pz, py - P.sy * pz, P.sz * pz};
}

// A packet's view of the polygons' corners, sheared: `Shared`, from a table of the distinct corners sheared once
// per packet (at most PolygonLanes::kMaxSharedCorners of them); otherwise sheared at each use.
template <int Perm, bool Shared>
struct ShearedCorners {
  const RayPacket& P;
  const PolygonLanes& L;
  LaneVertex<vfloat> table[Shared ? PolygonLanes::kMaxSharedCorners : 1];

  ShearedCorners(const RayPacket& packet, const PolygonLanes& lanes) : P(packet), L(lanes) {
    if constexpr (Shared)
      for (size_t v = 0; v < L.corner_xyz[0].size(); ++v)
        table[v] = sheared<Perm>(P, L.corner_xyz[0][v], L.corner_xyz[1][v], L.corner_xyz[2][v]);
  }
  // Corner k of polygon i: a reference into the table (a copy made the compiler move it through the stack).
  [[gnu::always_inline]] decltype(auto) operator()(int k, size_t i) const {
    if constexpr (Shared) return static_cast<const LaneVertex<vfloat>&>(table[L.corner_of[k][i]]);
    else return sheared<Perm>(P, L.coord[k][0][i], L.coord[k][1][i], L.coord[k][2][i]);
  }
};

// Polygon i against every lane: intersect_triangle()/intersect_quad()'s arithmetic, as simd_detail::test_block.
template <class Corners>
[[gnu::always_inline]] inline simd_detail::BlockResult<vfloat> test_polygon(const RayPacket& P, const PolygonLanes& L,
                                                                           const Corners& corner, size_t i) {
  using simd_detail::edge;
  const auto &A = corner(0, i), &B = corner(1, i), &C = corner(2, i);
  const vfloat eab = edge(A, B), ebc = edge(B, C), eca = edge(C, A);
  vfloat lo, hi;
  if (L.triangle[i] > 0.f) {  // the block test's triangle lane: (a, b, c, a), edge d→a replaced by c→a
    lo = stdx::min(stdx::min(eab, ebc), eca);
    hi = stdx::max(stdx::max(eab, ebc), eca);
  } else {
    const auto& D = corner(3, i);
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

template <int Perm, bool Shared, class ScalarTest>
void closest_polygon_packet(const PolygonLanes& L, const RayPacket& P, float* t_out, uint32_t* id_out,
                            const ScalarTest& scalar_test) {
  const ShearedCorners<Perm, Shared> corner(P, L);
  vfloat best(kInfinity), best_id(-1.f);
  for (size_t i = 0; i < L.count; ++i) {
    simd_detail::BlockResult<vfloat> r = test_polygon(P, L, corner, i);
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

template <int Perm, bool Shared, class ScalarTest>
uint32_t any_polygon_packet(const PolygonLanes& L, const RayPacket& P, const ScalarTest& scalar_test) {
  const ShearedCorners<Perm, Shared> corner(P, L);
  vfloat::mask_type blocked(false);
  const vfloat::mask_type active = P.t_max > -kInfinity;
  for (size_t i = 0; i < L.count; ++i) {
    simd_detail::BlockResult<vfloat> r = test_polygon(P, L, corner, i);
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

// Calls run.template operator()<Perm, Shared>() with the packet's specialisation: shared corners where the
// polygons have them, then the packet's permutation where uniform; per-polygon shearing is left generic (scenes
// with many distinct corners are not where the packets run).
template <class Run>
decltype(auto) with_specialisation(const PolygonLanes& L, const RayPacket& P, const Run& run) {
  if (!L.shared_corners()) return run.template operator()<-1, false>();
  switch (P.perm) {
    case 0: return run.template operator()<0, true>();
    case 1: return run.template operator()<1, true>();
    case 2: return run.template operator()<2, true>();
    case 3: return run.template operator()<3, true>();
    case 4: return run.template operator()<4, true>();
    case 5: return run.template operator()<5, true>();
    default: return run.template operator()<-1, true>();
  }
}

}  // namespace packet_detail

// Closest hit of every active lane among the polygons, never reporting the lane's skip_a. On return t[l] is the
// hit distance (+inf for none) and id[l] the polygon. `scalar_test(lane, i, t_max, hit)` re-tests polygon i for
// the lane's ray with the scalar routine (zero edge functions).
template <class ScalarTest>
inline void closest_polygon_packet(const PolygonLanes& L, const RayPacket& P, float* t_out, uint32_t* id_out,
                                   const ScalarTest& scalar_test) {
  packet_detail::with_specialisation(L, P, [&]<int Perm, bool Shared>() {
    packet_detail::closest_polygon_packet<Perm, Shared>(L, P, t_out, id_out, scalar_test);
  });
}

// Any hit of every active lane among the polygons, ignoring the lane's skip_a and skip_b. Returns the lanes
// that are occluded as a bit mask (bit l for lane l). Stops as soon as every active lane is occluded.
template <class ScalarTest>
inline uint32_t any_polygon_packet(const PolygonLanes& L, const RayPacket& P, const ScalarTest& scalar_test) {
  return packet_detail::with_specialisation(L, P, [&]<int Perm, bool Shared>() {
    return packet_detail::any_polygon_packet<Perm, Shared>(L, P, scalar_test);
  });
}

}  // namespace pt
