// Exact irradiance from a uniform (Lambertian) polygonal emitter, in double precision, for reference values in
// tests.
//
// Lambert's formula (J. H. Lambert, Photometria, 1760; in graphics: D. R. Baum, H. E. Rushmeier, J. M. Winget,
// "Improving Radiosity Solutions Through the Use of Analytically Determined Form-Factors", SIGGRAPH 1989;
// J. Arvo, "Applications of Irradiance Tensors to the Simulation of Non-Lambertian Phenomena", SIGGRAPH 1995,
// where (1/2)·Σ Θi·Γi is the polygon's irradiance vector for unit radiance):
//
//   E(x, n) = (L/2) · Σ_i Θi · (Γi · n),
//   Θi = angle subtended at x by the edge (vi, vi+1)  = atan2(|ai × bi|, ai · bi),  ai = vi − x, bi = vi+1 − x,
//   Γi = (ai × bi)/|ai × bi|  (unit normal of the plane through x and the edge).
//
// Sign convention (the papers differ in how they state it; this one is fixed here and checked by the tests):
// with Γi = normalize((vi − x) × (vi+1 − x)) the sum is positive when the polygon's right-hand normal
// (v1 − v0) × (v2 − v0) points away from x, i.e. the vertices run clockwise as seen from x. An emitter whose
// front normal faces x and whose vertices run counter-clockwise about that normal gives a negative sum; the
// irradiance functions below therefore return the magnitude.
//
// Validity: the formula integrates cos θ over the polygon's solid angle, not max(cos θ, 0). It is exact only
// when the whole polygon lies on or above x's tangent plane, n·(vi − x) ≥ 0 for every vertex (and x is not on
// the polygon). clip_polygon_to_hemisphere() cuts a polygon down to that part (Sutherland–Hodgman), after
// which the formula is exact again: polygon_irradiance_clipped().
#pragma once
#include <glm/glm.hpp>

#include <cmath>
#include <numbers>
#include <vector>

namespace pt::test {

using Polygon = std::vector<glm::dvec3>;

// (1/2)·Σ Θi·(Γi·n): the signed projected solid angle of the polygon seen from x (sign as above); π for a
// polygon covering the whole hemisphere.
inline double lambert_signed_projected_solid_angle(const Polygon& poly, glm::dvec3 x, glm::dvec3 n) {
  double sum = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    const glm::dvec3 a = poly[i] - x, b = poly[(i + 1) % poly.size()] - x;
    const glm::dvec3 c = glm::cross(a, b);
    const double len = glm::length(c);
    if (len == 0.0) continue;  // edge collinear with x: Θ = 0 (or x on the edge, outside the formula's domain)
    const double theta = std::atan2(len, glm::dot(a, b));
    sum += theta * glm::dot(c, n) / len;
  }
  return 0.5 * sum;
}

// True when every vertex is on or above x's tangent plane, the precondition of Lambert's formula.
inline bool polygon_above_tangent_plane(const Polygon& poly, glm::dvec3 x, glm::dvec3 n) {
  for (const auto& v : poly)
    if (glm::dot(v - x, n) < 0.0) return false;
  return true;
}

// Irradiance at x (unit normal n) from a polygon of uniform radiance L seen from x (two-sided emitter, or its
// front faces x). Precondition: polygon_above_tangent_plane(poly, x, n).
inline double polygon_irradiance(const Polygon& poly, glm::dvec3 x, glm::dvec3 n, double radiance) {
  return radiance * std::abs(lambert_signed_projected_solid_angle(poly, x, n));
}

// The part of a convex or simple polygon on or above the plane through x with normal n (Sutherland–Hodgman
// against one plane). Vertex order is kept; an empty result means nothing is above.
inline Polygon clip_polygon_to_hemisphere(const Polygon& poly, glm::dvec3 x, glm::dvec3 n) {
  Polygon out;
  for (size_t i = 0; i < poly.size(); ++i) {
    const glm::dvec3 p = poly[i], q = poly[(i + 1) % poly.size()];
    const double dp = glm::dot(p - x, n), dq = glm::dot(q - x, n);
    if (dp >= 0.0) out.push_back(p);
    if ((dp >= 0.0) != (dq >= 0.0)) out.push_back(p + (q - p) * (dp / (dp - dq)));  // crossing point, on the plane
  }
  return out;
}

// Irradiance from the visible (above-horizon) part of any polygon: exact for all placements with x off the
// polygon.
inline double polygon_irradiance_clipped(const Polygon& poly, glm::dvec3 x, glm::dvec3 n, double radiance) {
  const Polygon c = clip_polygon_to_hemisphere(poly, x, n);
  return c.size() < 3 ? 0.0 : polygon_irradiance(c, x, n, radiance);
}

// Outgoing radiance (any direction) of a Lambertian receiver of albedo ρ lit only by irradiance E: ρ·E/π.
inline double lambertian_outgoing_radiance(double albedo, double irradiance) {
  return albedo * irradiance / std::numbers::pi;
}

}  // namespace pt::test
