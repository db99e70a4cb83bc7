// A ray against many spheres at once: intersect_sphere's (geometry.h) discriminant for kSphereLanes spheres per
// SIMD step, so that only the spheres whose quadratic has roots go on to intersect_sphere itself.
//
// Why: a scene's spheres are tested ray by ray in a loop over all of them, in double; on `materials` (10 spheres)
// those tests were about a third of a pass under mis (perf, session 48), and most of them end at the
// discriminant's sign, the ray missing the sphere.
//
// Exactness: each lane computes the discriminant with intersect_sphere's own double operations in the same order
// (the project builds with -ffp-contract=off), so a lane reports "no roots" exactly where intersect_sphere
// returns at `disc < 0`; every other sphere is then asked through intersect_sphere, in index order. Hits, their
// distances and which sphere wins are therefore the plain loop's, bit for bit (tested: "spheres: the lanes drop
// only spheres the ray misses...").
#pragma once
#include <bit>
#include <cstdint>
#include <vector>

#include "core/lanes.h"  // stdx
#include "core/math.h"

namespace pt {

// 4 lanes (256 bits): the division on the discriminant's dependency chain takes about twice as long on 8 lanes
// (512 bits), and bdpt, whose queries wait on it one ray at a time, was slower than the plain loop with 8 on
// `materials` (0.62-0.66 against 0.66-0.67 Msamples/s) and faster with 4 (0.67-0.69 against 0.63-0.64; session 48).
inline constexpr size_t kSphereLanes = 4;
// Below this many spheres each goes straight to intersect_sphere. A room of six spheres whose floor and wall are
// spheres (every ray a candidate for both) ran 10 % slower through the lanes (session 48); `materials`' ten small
// balls 11-19 % faster under mis.
inline constexpr size_t kSphereLanesFrom = 8;

// The spheres' centres and squared radii as padded lanes of doubles: sphere i is lane i % kSphereLanes of block
// i / kSphereLanes. A padding lane has centre 0 and r2 = −1, whose discriminant a·(−1 − |l|²) is negative for
// every ray (a = |d|² > 0), so it is never a candidate.
struct SphereLanes {
  std::vector<double> cx, cy, cz, r2;
  uint32_t count = 0;  // spheres

  size_t blocks() const { return cx.size() / kSphereLanes; }

  // Appends the next sphere.
  void add(DVec3 center, double radius) {
    const uint32_t i = count++;
    if (i % kSphereLanes == 0)
      for (auto* v : {&cx, &cy, &cz, &r2}) v->resize(v->size() + kSphereLanes, v == &r2 ? -1.0 : 0.0);
    cx[i] = center.x, cy[i] = center.y, cz[i] = center.z;
    r2[i] = radius * radius;  // intersect_sphere's r2
  }
};

namespace sphere_detail {

using vdouble = stdx::fixed_size_simd<double, kSphereLanes>;

// Bit k set where sphere kSphereLanes·block + k may be hit by the ray from o along d: intersect_sphere's
// discriminant is not negative (or is NaN, which intersect_sphere does not return at either).
[[gnu::always_inline]] inline unsigned candidates(const SphereLanes& L, size_t block, DVec3 o, DVec3 dd, double a) {
  const size_t at = block * kSphereLanes;
  const vdouble cx(&L.cx[at], stdx::element_aligned), cy(&L.cy[at], stdx::element_aligned),
      cz(&L.cz[at], stdx::element_aligned), r2(&L.r2[at], stdx::element_aligned);
  // f = o − centre; b = −dot(f, dd); l = f + (b / a)·dd; disc = a·(r2 − dot(l, l)), glm's dot as (x + y) + z.
  const vdouble fx = o.x - cx, fy = o.y - cy, fz = o.z - cz;
  const vdouble b = -((fx * dd.x + fy * dd.y) + fz * dd.z);
  const vdouble s = b / a;
  const vdouble lx = fx + s * dd.x, ly = fy + s * dd.y, lz = fz + s * dd.z;
  const vdouble disc = a * (r2 - ((lx * lx + ly * ly) + lz * lz));
  const auto roots = !(disc < 0.0);
  unsigned bits = 0;
  for (size_t k = 0; k < kSphereLanes; ++k) bits |= roots[k] ? 1u << k : 0u;
  return bits;
}

// visit_sphere_candidates' lanes, out of line, the visitor called back through a plain function pointer once per
// candidate: the kernels' per-ray loops, into which the queries are inlined, then carry one call for the lanes
// instead of their code and a second copy of the visitor's (inlined, they cost the scenes of a few spheres, which
// never take them, 2-4 % more instructions per sample; docs/performance.md, session 48).
using Visitor = bool (*)(const void* visit, uint32_t sphere);
[[gnu::noinline]] inline bool visit_lanes(const SphereLanes& L, Vec3 o, Vec3 d, Visitor f, const void* visit) {
  const DVec3 O(o), dd(d);
  const double a = glm::dot(dd, dd);  // intersect_sphere's a
  for (size_t block = 0, n = L.blocks(); block < n; ++block)
    for (unsigned bits = candidates(L, block, O, dd, a); bits != 0; bits &= bits - 1)
      if (f(visit, static_cast<uint32_t>(block * kSphereLanes + static_cast<size_t>(std::countr_zero(bits)))))
        return true;
  return false;
}

}  // namespace sphere_detail

// Calls visit(i) for every sphere i that the ray from o along d may hit (all others certainly miss it), in index
// order, until visit returns true; returns whether one did. Below kSphereLanesFrom spheres, every sphere.
template <class Visit>
[[gnu::always_inline]] inline bool visit_sphere_candidates(const SphereLanes& L, Vec3 o, Vec3 d, const Visit& visit) {
  if (L.count >= kSphereLanesFrom)
    return sphere_detail::visit_lanes(
        L, o, d, [](const void* v, uint32_t i) { return (*static_cast<const Visit*>(v))(i); }, &visit);
  for (uint32_t i = 0; i < L.count; ++i)
    if (visit(i)) return true;
  return false;
}

}  // namespace pt
