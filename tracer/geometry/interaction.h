// Surface interaction: the hit point with a bound on its rounding error, the geometric normal, and robust
// spawning of new rays from it (after pbrt-v4 §6.8: offset along the normal by the error bound, then round away).
#pragma once
#include "geometry/primitives.h"

namespace pt {

// γ(n) = n·u / (1 − n·u), u = 2^-24: the classic bound on n chained float roundings (Higham).
constexpr float gamma_bound(int n) {
  constexpr float u = 0x1p-24f;
  return (n * u) / (1.f - n * u);
}

struct Interaction {
  Vec3 p;          // hit point, camera-relative
  Vec3 p_error;    // per-component bound on |p − true point|
  Vec3 ng;         // unit front (geometric) normal
  uint32_t prim;   // global primitive id
  uint32_t material;
  bool planar;     // polygons cannot be hit again by a ray leaving them
};

// F: the kernel's feature set (KernelFeature); a kind of primitive outside it is never hit, so its code is left out.
template <uint32_t F = kAllFeatures>
inline Interaction make_interaction(const SceneGeometry& s, const Ray& ray, const Hit& h) {
  Interaction it;
  it.prim = h.prim;
  it.material = s.material_of(h.prim);
  constexpr bool kOnlyPolygons = (F & kFeatureSpheres) == 0, kOnlySpheres = (F & kFeaturePolygons) == 0;
  if (kOnlyPolygons || (!kOnlySpheres && h.prim < s.sphere_begin())) {
    // The ray kernels report only distances. The barycentrics of the point o + t·d in the polygon's plane (in
    // half 0; in half 1 when a quad's point lies beyond its diagonal a–c, i.e. b's weight is negative) locate
    // the hit to within the rounding of o + t·d; the point is then re-interpolated from the vertices below, so
    // it lies on the polygon whatever that rounding was.
    const uint32_t i = h.prim;
    const PolygonSoA& P = s.polygons;
    const Vec3 a = P.v[0][i];
    const Vec3 q = ray.o + h.t * ray.d - a;
    const auto& dual = P.dual[i];
    uint32_t half = 0;
    float b1 = glm::dot(q, dual[0][0]), b2 = glm::dot(q, dual[0][1]);
    if (b1 < 0.f && !P.triangle[i]) {
      half = 1;
      b1 = glm::dot(q, dual[1][0]), b2 = glm::dot(q, dual[1][1]);
    }
    float b0 = 1.f - b1 - b2;
    const Vec3 b = P.v[half + 1][i], c = P.v[half + 2][i];
    const Vec3 m = P.edge_margin[i][half];
    it.ng = P.normal[i];
    // Keep the point inside by more than its rounding error: a point near an edge shared with another face must
    // not round to the far side of that face.
    if (b0 < m.x || b1 < m.y || b2 < m.z) {
      b0 = std::max(b0, m.x), b1 = std::max(b1, m.y), b2 = std::max(b2, m.z);
      const float inv = 1.f / (b0 + b1 + b2);
      b0 *= inv, b1 *= inv, b2 *= inv;
    }
    // Interpolate the hit from the vertices (pbrt-v4 eq. 6.26): its error is γ7·Σ|bᵢ·vᵢ|, independent of t.
    it.p = b0 * a + b1 * b + b2 * c;
    it.p_error = gamma_bound(7) * (glm::abs(b0 * a) + glm::abs(b1 * b) + glm::abs(b2 * c));
    it.planar = true;
  } else {
    // Sphere: recompute in double and project back onto the surface, so the only float error left is the final
    // rounding of p (bounded by γ3·|p| with margin).
    const uint32_t i = h.prim - s.sphere_begin();
    const DVec3 c = s.spheres.center[i];
    const DVec3 pd = DVec3(ray.o) + static_cast<double>(h.t) * DVec3(ray.d);
    const DVec3 n = glm::normalize(pd - c);
    const DVec3 p = c + s.spheres.radius[i] * n;
    it.p = Vec3(p);
    it.p_error = gamma_bound(3) * glm::abs(it.p);
    it.ng = Vec3(n);
    it.planar = false;
  }
  return it;
}

// Origin for a ray leaving `it` towards direction w: pushed off the surface along the normal by the error bound
// (to the side w points to), then rounded one ulp further away so the offset survives rounding.
inline Vec3 offset_ray_origin(const Interaction& it, Vec3 w) {
  const float dist = glm::dot(glm::abs(it.ng), it.p_error);
  Vec3 offset = dist * it.ng;
  if (glm::dot(w, it.ng) < 0.f) offset = -offset;
  Vec3 po = it.p + offset;
  for (int k = 0; k < 3; ++k) {
    if (offset[k] > 0.f) po[k] = next_float_up(po[k]);
    else if (offset[k] < 0.f) po[k] = next_float_down(po[k]);
  }
  return po;
}

inline uint32_t skip_on_leave(const Interaction& it) { return it.planar ? it.prim : ~0u; }

}  // namespace pt
