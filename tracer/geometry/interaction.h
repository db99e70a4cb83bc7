// Surface interaction: the hit point with a bound on its rounding error, the geometric normal, and robust
// spawning of new rays from it (after pbrt-v4 §6.8: offset along the normal by the error bound, then round away).
#pragma once
#include <algorithm>
#include <cmath>

#include "core/lanes.h"
#include "geometry/primitives.h"
#include "geometry/triangle_frame.h"

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
  // Smooth shading (make_interaction fills these for the general-material kernels; vertex_shading below):
  Vec3 ns;              // unit shading normal, on ng's side; ng where the surface is flat-shaded
  Vec2 uv{0.f};         // texture coordinates
  Vec3 du_dp{0.f}, dv_dp{0.f};  // gradients of u and v along the surface: a step δp in it moves uv by (du_dp·δp, dv_dp·δp)
  Vec3 lift{0.f};       // shadow-terminator offset: rays leaving on ng's side start from p + lift
  // A normal map's tangent frame from the file (glTF TANGENT, interpolated): xyz the direction of growing u
  // (not unit), w = ±1 with bitangent = w·(ns × tangent); zero where the file gives none (normal_map.h then
  // takes it from the uv mapping).
  Vec4 tangent{0.f};
  bool lifted = false;  // lift is not zero
};

// vertex_shading's two formulas over T = float or vfloat (core/lanes.h), for one hit or for the SIMD shading lanes
// (integrators/shading_lanes.h), which must round alike:
// - the interpolated normal Σ bₖ·nₖ normalised and turned to ng's side (`side`, ±1, is returned), or ng where
//   that sum is (nearly) zero;
// - the terminator offset −Σ bₖ·min(0, (p − vₖ)·nₖ)·nₖ, with the normals turned by `side`.
template <class T>
[[gnu::always_inline]] inline lanes::Vec3T<T> interpolated_normal(const lanes::Vec3T<T> (&n)[3], const T (&b)[3],
                                                                  const lanes::Vec3T<T>& ng, T& side) {
  const lanes::Vec3T<T> sum{(b[0] * n[0].x + b[1] * n[1].x) + b[2] * n[2].x,
                            (b[0] * n[0].y + b[1] * n[1].y) + b[2] * n[2].y,
                            (b[0] * n[0].z + b[1] * n[1].z) + b[2] * n[2].z};
  const T len2 = lanes::dot(sum, sum);
  side = select(lanes::dot(sum, ng) < 0.f, T(-1.f), T(1.f));
  const T scale = side / lanes::sqrt(len2);
  const lanes::Mask<T> ok = len2 > 1e-12f;
  return {select(ok, sum.x * scale, ng.x), select(ok, sum.y * scale, ng.y), select(ok, sum.z * scale, ng.z)};
}
template <class T>
[[gnu::always_inline]] inline lanes::Vec3T<T> terminator_lift(const lanes::Vec3T<T> (&n)[3],
                                                              const lanes::Vec3T<T> (&v)[3], const T (&b)[3],
                                                              const lanes::Vec3T<T>& p, const T& side) {
  lanes::Vec3T<T> lift{T(0.f), T(0.f), T(0.f)};
  for (int k = 0; k < 3; ++k) {
    const lanes::Vec3T<T> nk{side * n[k].x, side * n[k].y, side * n[k].z};
    const T c = b[k] * lanes::std_min(T(0.f), lanes::dot({p.x - v[k].x, p.y - v[k].y, p.z - v[k].z}, nk));
    lift = {lift.x - c * nk.x, lift.y - c * nk.y, lift.z - c * nk.z};
  }
  return lift;
}

// The texture coordinates of a hit at barycentrics (b0, b1, b2) of a triangle with vertex uv and barycentric
// gradients `dual`, and their gradients along the surface (it.uv, it.du_dp, it.dv_dp): vertex_shading's, and the
// shading lanes' for a textured hit (integrators/shading_lanes.h).
inline void surface_uv(const std::array<Vec2, 3>& uv, float b0, float b1, float b2, const std::array<Vec3, 2>& dual,
                       Interaction& it) {
  it.uv = b0 * uv[0] + b1 * uv[1] + b2 * uv[2];
  // u = u0 + b1·(u1 − u0) + b2·(u2 − u0), and b1, b2 have the gradients `dual` (PolygonSoA::dual).
  const Vec2 e1 = uv[1] - uv[0], e2 = uv[2] - uv[0];
  it.du_dp = e1.x * dual[0] + e2.x * dual[1];
  it.dv_dp = e1.y * dual[0] + e2.y * dual[1];
}

// The shading normal, texture coordinates and terminator offset of a hit at barycentrics (b0, b1, b2) of a
// triangle with (camera-relative) vertices v, per-vertex normals n and uv, and barycentric gradients `dual`:
// - ns interpolates the vertex normals (Phong), turned to ng's side, so that the winding of the triangle keeps
//   deciding which side is the front (one-sided emitters, a glass mesh's inside) even in a file whose normals
//   point the other way; a zero interpolated normal leaves ns = ng.
// - lift moves ray origins off a coarse smooth mesh the way its normals say the surface curves (Hanika 2021,
//   "Hacking the Shadow Terminator", Ray Tracing Gems II ch. 4): p is lifted onto each vertex's tangent plane
//   where it lies below it, and the lifts are blended with the barycentrics, p' = p − Σ bₖ·min(0, (p − vₖ)·nₖ)·nₖ.
//   Shadow rays from it no longer hit the neighbouring faces of the flat triangle, which drew the terminator as
//   a jagged dark band. Kept only when it leaves towards ng's side (never into the surface).
// - tangents (when given: the vertices' file tangents, w their handedness) are interpolated like the normals;
//   the handedness follows ns when ns was turned to ng's side, so the bitangent w·(ns × t) keeps its direction.
inline void vertex_shading(const std::array<Vec3, 3>& n, const std::array<Vec2, 3>& uv, const Vec3 v[3], float b0,
                           float b1, float b2, const std::array<Vec3, 2>& dual, Interaction& it,
                           const std::array<Vec4, 3>* tangent = nullptr) {
  // A face without vertex normals, in a scene whose other faces have some, carries its own normal three times
  // (scene.cpp): it stays exactly flat, ns = ng and no lift. Interpolated and normalised, that normal came out an
  // ulp off ng, and bdpt took such a wall for a smooth surface (smooth_vertex), with its bent frames and adjoint.
  const bool flat = n[0] == it.ng && n[1] == it.ng && n[2] == it.ng;
  const lanes::Vec3T<float> nl[3] = {lanes::of(n[0]), lanes::of(n[1]), lanes::of(n[2])};
  const float b[3] = {b0, b1, b2};
  float side;
  const Vec3 ns = lanes::to_vec3(interpolated_normal(nl, b, lanes::of(it.ng), side));
  if (!flat) it.ns = ns;
  if (tangent) {
    const std::array<Vec4, 3>& t = *tangent;
    const Vec4 mix = b0 * t[0] + b1 * t[1] + b2 * t[2];
    if (mix.w != 0.f) it.tangent = Vec4(Vec3(mix), (mix.w < 0.f ? -1.f : 1.f) * side);
  }
  surface_uv(uv, b0, b1, b2, dual, it);
  if (flat) return;
  const lanes::Vec3T<float> vl[3] = {lanes::of(v[0]), lanes::of(v[1]), lanes::of(v[2])};
  const Vec3 lift = lanes::to_vec3(terminator_lift(nl, vl, b, lanes::of(it.p), side));
  if (glm::dot(lift, it.ng) > 0.f) {
    it.lift = lift;
    it.lifted = true;
  }
}

namespace interaction_detail {

// The hit at distance t along `ray` on polygon (v[0], v[1], v[2][, v[3]]) with the given frame (PolygonSoA's
// normal, dual and edge_margin): fills it.p, p_error, ng, ns and planar; returns the barycentrics in the half
// hit (b[0..2]) and that half.
// The ray kernels report only distances. The barycentrics of the point o + t·d in the polygon's plane (in
// half 0; in half 1 when a quad's point lies beyond its diagonal a–c, i.e. b's weight is negative) locate
// the hit to within the rounding of o + t·d; the point is then re-interpolated from the vertices below, so
// it lies on the polygon whatever that rounding was.
inline uint32_t polygon_point(const Vec3 (&v)[4], bool triangle, const std::array<std::array<Vec3, 2>, 2>& dual,
                              const std::array<Vec3, 2>& margin, Vec3 normal, const Ray& ray, float t,
                              Interaction& it, float (&bary)[3]) {
  const Vec3 a = v[0];
  const Vec3 q = ray.o + t * ray.d - a;
  uint32_t half = 0;
  float b1 = glm::dot(q, dual[0][0]), b2 = glm::dot(q, dual[0][1]);
  if (b1 < 0.f && !triangle) {
    half = 1;
    b1 = glm::dot(q, dual[1][0]), b2 = glm::dot(q, dual[1][1]);
  }
  float b0 = 1.f - b1 - b2;
  const Vec3 b = v[half + 1], c = v[half + 2];
  const Vec3 m = margin[half];
  it.ng = normal;
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
  it.ns = it.ng;
  bary[0] = b0, bary[1] = b1, bary[2] = b2;
  return half;
}

// A hit on triangle i of an instanced mesh (instances.h): the triangle is placed in the world (in double, from
// the instance's transform; its vertices the other way round under a mirroring one, so that its front stays the
// file's), its frame computed there as compile_scene computes a polygon's, and the hit located on it as on any
// polygon. The hit point's error bound also covers the placement's rounding and that of the ray's way into the
// mesh (a few ulps of the vertices' coordinates), so spawned rays clear the mesh's surface as it was tested.
template <bool kShading>
inline void instance_point(const SceneGeometry& s, const Ray& ray, const Hit& h, Interaction& it) {
  const Instance& in = s.instances.instance_of(h.prim);
  const MeshGeometry& mesh = *in.geometry;
  const uint32_t i = h.prim - in.first_prim;
  int order[3] = {0, 1, 2};
  if (in.mirrors) std::swap(order[1], order[2]);
  DVec3 w[3];
  double max_abs = 0.0;
  for (int k = 0; k < 3; ++k) {
    w[k] = in.to_world_linear * DVec3(mesh.vertex(i, order[k])) + in.to_world_offset;
    max_abs = std::max(max_abs, std::max(std::abs(w[k].x), std::max(std::abs(w[k].y), std::abs(w[k].z))));
  }
  const std::array<std::array<Vec3, 2>, 2> dual{triangle_dual(w[0], w[1], w[2]), {}};
  const std::array<Vec3, 2> margin{triangle_margins(w[0], w[1], w[2], hit_error_bound(max_abs)), Vec3(0.f)};
  const Vec3 v[4] = {Vec3(w[0]), Vec3(w[1]), Vec3(w[2]), Vec3(w[0])};
  float b[3];
  polygon_point(v, true, dual, margin, Vec3(glm::normalize(glm::cross(w[1] - w[0], w[2] - w[0]))), ray, h.t, it, b);
  it.p_error += Vec3(static_cast<float>(8.0 * 0x1p-24 * max_abs));
  if constexpr (kShading) {
    const TriangleMesh& m = *mesh.mesh;
    if (!m.normal.empty() || !m.uv.empty()) {
      std::array<Vec3, 3> n{it.ng, it.ng, it.ng}, file_n;
      std::array<Vec2, 3> uv{Vec2(0.f), Vec2(0.f), Vec2(0.f)};
      const bool smooth = m.vertex_normals(i, file_n);
      for (int k = 0; k < 3; ++k) {
        if (smooth) n[k] = glm::normalize(in.normal_to_world * file_n[order[k]]);
        if (!m.uv.empty()) uv[k] = m.uv[m.index[i][order[k]]];
      }
      if (m.tangent.empty()) {
        vertex_shading(n, uv, v, b[0], b[1], b[2], dual[0], it);
      } else {
        // Tangents are directions in the surface: the placement's linear part maps them; a mirroring one turns
        // the frame's handedness around.
        const glm::mat3 linear(in.to_world_linear);
        std::array<Vec4, 3> t;
        for (int k = 0; k < 3; ++k) {
          const Vec4 f = m.tangent[m.index[i][order[k]]];
          t[k] = Vec4(linear * Vec3(f), in.mirrors ? -f.w : f.w);
        }
        vertex_shading(n, uv, v, b[0], b[1], b[2], dual[0], it, &t);
      }
    }
  }
}

}  // namespace interaction_detail

// A hit on a sphere (h.prim ≥ s.sphere_begin(), not an instance's): recomputed in double and projected back onto
// the surface, so the only float error left is the final rounding of p (bounded by γ3·|p| with margin). Fills
// it.p, p_error, ng, ns and planar (the SIMD shading lanes take a sphere's hit from here too).
inline void sphere_point(const SceneGeometry& s, const Ray& ray, const Hit& h, Interaction& it) {
  const uint32_t i = h.prim - s.sphere_begin();
  const DVec3 c = s.spheres.center[i];
  const DVec3 pd = DVec3(ray.o) + static_cast<double>(h.t) * DVec3(ray.d);
  const DVec3 n = glm::normalize(pd - c);
  const DVec3 p = c + s.spheres.radius[i] * n;
  it.p = Vec3(p);
  it.p_error = gamma_bound(3) * glm::abs(it.p);
  it.ng = Vec3(n);
  it.ns = it.ng;
  it.planar = false;
}

// F: the kernel's feature set (KernelFeature); a kind of primitive outside it is never hit, so its code is left out.
template <uint32_t F = kAllFeatures>
inline Interaction make_interaction(const SceneGeometry& s, const Ray& ray, const Hit& h) {
  Interaction it;
  it.prim = h.prim;
  it.material = s.material_of(h.prim);
  constexpr bool kOnlyPolygons = (F & kFeatureSpheres) == 0, kOnlySpheres = (F & kFeaturePolygons) == 0;
  constexpr bool kShading = (F & kFeatureGeneralMaterials) != 0;
  if (kOnlyPolygons || (!kOnlySpheres && h.prim < s.sphere_begin())) {
    const uint32_t i = h.prim;
    if (!kOnlySpheres && i >= s.sphere_begin()) [[unlikely]] {  // only polygons: an instance's triangle
      interaction_detail::instance_point<kShading>(s, ray, h, it);
      return it;
    }
    const PolygonSoA& P = s.polygons;
    const Vec3 v[4] = {P.v[0][i], P.v[1][i], P.v[2][i], P.v[3][i]};
    float b[3];
    const uint32_t half = interaction_detail::polygon_point(v, P.triangle[i], P.dual[i], P.edge_margin[i], P.normal[i],
                                                             ray, h.t, it, b);
    // Vertex normals are read by the general-material kernels alone: a scene that has them runs those
    // (Scene::kernel_features), so the Lambert kernels stay as they were.
    if constexpr (kShading) {
      if (!s.shading.empty()) [[unlikely]] {
        const Vec3 tri[3] = {v[0], v[half + 1], v[half + 2]};
        vertex_shading(s.shading.normal[i], s.shading.uv[i], tri, b[0], b[1], b[2], P.dual[i][0], it);
      }
    }
  } else if (!kOnlyPolygons && s.instances.holds(h.prim)) [[unlikely]] {
    interaction_detail::instance_point<kShading>(s, ray, h, it);
  } else {
    sphere_point(s, ray, h, it);
  }
  return it;
}

// The shading normal to shade `it` with, seen from direction wo: it.ns, bent where needed so that the mirror
// reflection of wo about it stays above the geometric surface on wo's side (after Cycles'
// ensure_valid_reflection): an interpolated normal seen at a grazing angle otherwise reflects into the surface,
// and such faces render black. The reflection may dip to an elevation t = min(0.9·|wo·ng|, 0.01) over the
// surface; below that, ns is turned towards ng in their common plane until it reaches t exactly. With
// x = ns's part across ng, ns = sin θ·x + cos θ·ng and the reflection's elevation is
// (2(ns·wo)ns − wo)·ng = wx·sin 2θ + wz·cos 2θ = ρ·cos(2θ − ψ), ρ = |(wx, wz)|, ψ = atan2(wx, wz), so the
// smallest turn is θ = (ψ + acos(t/ρ))/2; then wo·ns > 0 as well, so shading and geometry agree on which side wo
// is. Returned on ng's side, as it.ns is.
// reflection_clears is its first step over T = float or vfloat (the SIMD shading lanes take the lanes where it
// holds, where it.ns needs no bend): ns and ng turned to wo's side, wz = wo·ng there, the elevation t, and
// whether the reflection stays at t or above.
template <class T>
struct ReflectionCheck {
  T side, wz, t;
  lanes::Mask<T> clears;
};
template <class T>
[[gnu::always_inline]] inline ReflectionCheck<T> reflection_clears(const lanes::Vec3T<T>& ns, const lanes::Vec3T<T>& ng,
                                                                   const lanes::Vec3T<T>& wo) {
  ReflectionCheck<T> c;
  c.side = select(lanes::dot(wo, ng) < 0.f, T(-1.f), T(1.f));
  const lanes::Vec3T<T> g{c.side * ng.x, c.side * ng.y, c.side * ng.z}, s{c.side * ns.x, c.side * ns.y, c.side * ns.z};
  c.wz = lanes::dot(wo, g);
  c.t = lanes::std_min(0.9f * c.wz, T(0.01f));
  const T k = 2.f * lanes::dot(s, wo);
  c.clears = lanes::dot({k * s.x - wo.x, k * s.y - wo.y, k * s.z - wo.z}, g) >= c.t;
  return c;
}
inline Vec3 shading_normal(const Interaction& it, Vec3 wo) {
  const ReflectionCheck<float> c = reflection_clears(lanes::of(it.ns), lanes::of(it.ng), lanes::of(wo));
  if (c.clears) return it.ns;
  const float side = c.side, wz = c.wz, t = c.t;
  const Vec3 ng = side * it.ng, ns = side * it.ns;  // both on wo's side
  const Vec3 across = ns - glm::dot(ns, ng) * ng;
  const float len = glm::length(across);
  if (!(len > 1e-7f)) return it.ng;
  const Vec3 x = across / len;
  const float wx = glm::dot(wo, x);
  const float rho = std::sqrt(wx * wx + wz * wz);
  const float theta = 0.5f * (std::atan2(wx, wz) + std::acos(std::clamp(t / rho, -1.f, 1.f)));
  return side * (std::sin(theta) * x + std::cos(theta) * ng);
}

// Origin for a ray leaving `it` on its back (ng's far side) or front: pushed off the surface along the normal by
// the error bound, then rounded one ulp further away so the offset survives rounding. On the front a
// smooth-shaded hit starts from its lifted point (vertex_shading). The side is the one the ray's direction
// points to (the overload below), except on smooth-shaded surfaces, where the shading frame says it: a
// reflection that dips below the flat triangle near the terminator still leaves from the front (from the lifted
// point, skipping its own triangle), as the smooth surface it stands for would let it.
inline Vec3 offset_ray_origin(const Interaction& it, bool back) {
  const Vec3 p = it.lifted && !back ? it.p + it.lift : it.p;
  return lanes::to_vec3(lanes::offset_point(lanes::of(p), lanes::of(it.p_error), lanes::of(it.ng), back));
}

// The ray leaving towards direction w: on the side w points to.
inline Vec3 offset_ray_origin(const Interaction& it, Vec3 w) { return offset_ray_origin(it, glm::dot(w, it.ng) < 0.f); }

inline uint32_t skip_on_leave(const Interaction& it) { return it.planar ? it.prim : ~0u; }

}  // namespace pt
