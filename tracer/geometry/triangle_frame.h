// What shading needs of a triangle beyond its vertices, computed in double from them: the barycentric gradients
// that turn a point of its plane into barycentrics, and the smallest barycentrics that keep an interpolated hit
// point inside it by more than its rounding error. compile_scene stores them per polygon (PolygonSoA);
// make_interaction computes them for the one hit triangle of an instanced mesh (instances.h).
#pragma once
#include <array>

#include "core/math.h"

namespace pt {

// The bound on a hit point's rounding error these margins keep away from the edges: γ7·Σ|bᵢvᵢ| ≤ γ7·max|v|
// (camera-relative), with a 4× margin.
inline double hit_error_bound(double max_abs_coordinate) { return 4.0 * 7.0 * 0x1p-24 * max_abs_coordinate; }

// Smallest barycentrics (b0, b1, b2) of a point inside triangle (a, b, c) that keep it `err` away from each
// edge: b_k = distance to the edge opposite vertex k over that vertex's altitude = err·|edge|/(2·area).
inline Vec3 triangle_margins(DVec3 a, DVec3 b, DVec3 c, double err) {
  const double a2 = glm::length(glm::cross(b - a, c - a));  // twice the area
  DVec3 m = DVec3(glm::length(c - b), glm::length(a - c), glm::length(b - a)) * (err / a2);
  if (m.x + m.y + m.z >= 0.5) m = DVec3(1.0 / 3.0);  // a sliver below float resolution: use its centroid
  return Vec3(m);
}

// The dual vectors of triangle (a, q, r): a point p of its plane has the barycentrics of q and r
// b_q = (p − a)·dual[0], b_r = (p − a)·dual[1] (with e1 = q − a, e2 = r − a, n = e1 × e2:
// dual = (e2 × n, n × e1)/|n|²).
inline std::array<Vec3, 2> triangle_dual(DVec3 a, DVec3 q, DVec3 r) {
  const DVec3 e1 = q - a, e2 = r - a, n = glm::cross(e1, e2);
  const double inv = 1.0 / glm::dot(n, n);
  return {Vec3(glm::cross(e2, n) * inv), Vec3(glm::cross(n, e1) * inv)};
}

}  // namespace pt
