// Ray–primitive intersection routines: watertight triangles and convex planar quads, numerically stable spheres.
// All tests report hits with 0 < t < t_max; there is no absolute epsilon anywhere: self-intersection is avoided
// by offsetting spawned origins by a bound on the hit point's rounding error (see interaction.h) and by never
// re-testing the planar primitive a ray leaves.
#pragma once
#include "core/ray.h"

namespace pt {

// Vertices moved into the ray's sheared space (origin at the ray origin, ray along +z).
struct ShearedVertex {
  float x, y, z;
};

inline ShearedVertex shear_vertex(Vec3 v, Vec3 o, const RayShear& s) {
  const Vec3 p = v - o;
  return {p[s.kx] - s.sx * p[s.kz], p[s.ky] - s.sy * p[s.kz], s.sz * p[s.kz]};
}

// Signed edge function of the directed edge p→q at the sheared origin. It is exactly antisymmetric in float
// (e(q,p) == −e(p,q)) so two primitives sharing an edge can never both miss a ray through it. When the float
// result is exactly zero it is recomputed in double, as Woop et al. prescribe, to settle edge hits consistently.
inline float edge_function(ShearedVertex p, ShearedVertex q) {
  float e = q.x * p.y - q.y * p.x;
  if (e == 0.f) e = static_cast<float>(static_cast<double>(q.x) * p.y - static_cast<double>(q.y) * p.x);
  return e;
}

struct PolygonHit {
  float t;
  float b0, b1, b2;  // barycentrics of the hit in triangle (a, b, c) (for a quad: extended to its plane)
};

// Distance along the ray from the edge functions (U, V, W opposite a, b, c) of triangle (a, b, c) and their sum:
// t = (U·a.z + V·b.z + W·c.z)/det in sheared space (Woop et al. 2013), the same float operations as the SIMD tests.
inline float hit_distance(float U, float V, float W, ShearedVertex A, ShearedVertex B, ShearedVertex C, float det) {
  return (U * A.z + V * B.z + W * C.z) / det;
}

// Watertight ray–triangle test (Woop et al. 2013).
inline bool intersect_triangle(Vec3 a, Vec3 b, Vec3 c, Vec3 o, const RayShear& s, float t_max, PolygonHit& hit) {
  const ShearedVertex A = shear_vertex(a, o, s), B = shear_vertex(b, o, s), C = shear_vertex(c, o, s);
  const float U = edge_function(B, C), V = edge_function(C, A), W = edge_function(A, B);
  if ((U < 0.f || V < 0.f || W < 0.f) && (U > 0.f || V > 0.f || W > 0.f)) return false;
  const float det = U + V + W;
  const float t = hit_distance(U, V, W, A, B, C, det);
  // t in (0, t_max); det = 0 (ray parallel to the plane, or degenerate) gives ±inf or NaN and fails.
  if (!(t > 0.f && t < t_max)) return false;
  const float inv_det = 1.f / det;
  hit = {t, U * inv_det, V * inv_det, W * inv_det};
  return true;
}

// Watertight ray–quad test for convex planar quads (a, b, c, d) (parallelograms among them): the four edge
// functions decide inside/outside exactly as for triangles, so a quad and any polygon sharing an edge with it
// stay light-tight; t comes from the plane through (a, b, c) via the same sheared-space interpolation.
inline bool intersect_quad(Vec3 a, Vec3 b, Vec3 c, Vec3 d, Vec3 o, const RayShear& s, float t_max, PolygonHit& hit) {
  const ShearedVertex A = shear_vertex(a, o, s), B = shear_vertex(b, o, s), C = shear_vertex(c, o, s),
                      D = shear_vertex(d, o, s);
  const float eab = edge_function(A, B), ebc = edge_function(B, C), ecd = edge_function(C, D),
              eda = edge_function(D, A);
  if ((eab < 0.f || ebc < 0.f || ecd < 0.f || eda < 0.f) && (eab > 0.f || ebc > 0.f || ecd > 0.f || eda > 0.f))
    return false;
  // Barycentrics in triangle (a,b,c): U opposite a (edge bc), V opposite b (edge ca), W opposite c (edge ab).
  const float U = ebc, W = eab;
  const float V = edge_function(C, A);
  const float det = U + V + W;
  const float t = hit_distance(U, V, W, A, B, C, det);
  if (!(t > 0.f && t < t_max)) return false;
  const float inv_det = 1.f / det;
  hit = {t, U * inv_det, V * inv_det, W * inv_det};
  return true;
}

// Ray–sphere test, numerically stable for huge radii and distant spheres ("Precision Improvements for
// Ray/Sphere Intersection", Haines et al., Ray Tracing Gems ch. 7): the discriminant is formed from the
// perpendicular offset of the centre from the ray rather than b²−4ac, and the roots from q = −b − sign(b)√Δ so
// neither root suffers cancellation. Done in double: spheres are few, and it keeps spheres 10^5 times the scene
// size exact to well below a float ulp of the hit point. Returns the nearest root in (0, t_max). Inlined into the
// loops over a scene's spheres: called out of line (GCC's choice in the larger kernels), it cost `materials` 7 % more
// instructions per sample (docs/performance.md, session 45).
[[gnu::always_inline]] inline bool intersect_sphere(DVec3 center, double radius, Vec3 o, Vec3 d, float t_max, float& t_hit) {
  const DVec3 dd(d);
  const DVec3 f = DVec3(o) - center;  // centre → origin
  const double a = glm::dot(dd, dd);
  const double b = -glm::dot(f, dd);  // half of the textbook b, negated
  const DVec3 l = f + (b / a) * dd;   // perpendicular from the centre to the ray's line
  const double r2 = radius * radius;
  const double disc = a * (r2 - glm::dot(l, l));
  if (disc < 0.0) return false;
  const double sq = std::sqrt(disc);
  const double q = b + std::copysign(sq, b);
  const double c = glm::dot(f, f) - r2;
  double t0 = q != 0.0 ? c / q : 0.0, t1 = q / a;
  if (t0 > t1) std::swap(t0, t1);
  const double t = t0 > 0.0 ? t0 : t1;
  if (!(t > 0.0) || t >= static_cast<double>(t_max)) return false;
  t_hit = static_cast<float>(t);
  if (!(t_hit > 0.f)) t_hit = std::numeric_limits<float>::denorm_min();
  return true;
}

}  // namespace pt
