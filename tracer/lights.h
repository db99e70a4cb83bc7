// Light sampling for next-event estimation and the matching densities for MIS.
// A light is chosen with probability ∝ power (Scene::light_pmf); a point on it is then chosen uniformly by area
// (polygons, or a sphere seen from inside) or uniformly within the cone the sphere subtends (pbrt-v4 §6.2.4);
// the uniform background is sampled cosine-weighted about the receiver's normal (it is constant, so this is
// the ideal density for a diffuse receiver: in a white furnace every light sample returns exactly 1).
// All densities are returned per unit solid angle at the receiving point.
#pragma once
#include "interaction.h"
#include "sampling.h"

namespace pt {

struct LightSample {
  Vec3 p;          // point on the light (camera-relative); unused for the environment
  Vec3 wi;         // unit direction receiver → light
  float dist;      // distance receiver → light (infinite for the environment)
  Rgb Le;          // emitted radiance towards the receiver (0 if it sees the back of a one-sided light)
  float pdf;       // solid-angle density including the light choice
  uint32_t prim;   // the light's primitive, excluded from the shadow test
};

inline int choose_light(const Scene& s, float u) {
  const auto it = std::upper_bound(s.light_cdf.begin(), s.light_cdf.end(), u);
  return static_cast<int>(std::min<size_t>(it - s.light_cdf.begin(), s.light_cdf.size() - 1));
}

// Emitted radiance leaving a light's surface point with front normal n towards direction w.
inline Rgb light_emission(const Light& l, Vec3 n, Vec3 w) {
  const float c = glm::dot(n, w);
  return (c > 0.f || (l.two_sided && c < 0.f)) ? l.emission : Rgb(0.f);
}

// Cone of a sphere seen from a point at squared distance d2 > r2 from its centre: 1 − cos θmax, computed as
// sin²/(1 + cos) to keep its precision for small cones.
inline float sphere_one_minus_cos_max(double r2, double d2) {
  const double sin2 = r2 / d2;
  return static_cast<float>(sin2 / (1.0 + std::sqrt(std::max(0.0, 1.0 - sin2))));
}

// Spheres are sampled by cone when the receiver is clearly outside; receivers on or inside the sphere sample its
// area instead. "Clearly": the receiver's height above the surface, h = (d² − r²)/(d + r) (no cancellation),
// exceeds the rounding error of a point at the receiver's (camera-relative) position, so points on the sphere
// itself that rounding put a hair outside use area sampling, whatever the sphere's size (a margin relative to
// r would be metres wide for a sphere 10^5 times the room).
inline bool sample_sphere_by_cone(double r2, double d2, Vec3 ref) {
  const double h = (d2 - r2) / (std::sqrt(d2) + std::sqrt(r2));
  return h > 0x1p-16 * static_cast<double>(max_abs_component(ref)) + 1e-12 * std::sqrt(r2);
}

// Solid-angle density with which sample_light() would produce direction w towards the environment from a
// receiver with normal n.
inline float environment_pdf(const Scene& s, Vec3 n, Vec3 w) {
  return s.light_pmf[s.environment_light] * cosine_hemisphere_pdf(glm::dot(n, w));
}

// Solid-angle density with which sample_light() would produce the point `p_light` (front normal n_light) of
// light index li, seen from receiver point `ref`. Used for MIS when a BSDF-sampled ray hits an emitter.
template <uint32_t F = kAllFeatures>
inline float light_pdf(const Scene& s, int li, Vec3 ref, Vec3 p_light, Vec3 n_light) {
  const Light& l = s.lights[li];
  const float pmf = s.light_pmf[li];
  if ((F & kFeatureSpheres) != 0 && l.prim >= s.sphere_begin()) {
    const uint32_t i = l.prim - s.sphere_begin();
    const double r = s.spheres.radius[i];
    const DVec3 dc = DVec3(ref) - s.spheres.center[i];
    const double d2 = glm::dot(dc, dc);
    if (sample_sphere_by_cone(r * r, d2, ref)) return pmf * uniform_cone_pdf(sphere_one_minus_cos_max(r * r, d2));
  }
  const Vec3 d = p_light - ref;
  const float dist2 = glm::dot(d, d);
  const float cos_l = std::abs(glm::dot(n_light, d)) / std::sqrt(dist2);
  if (cos_l == 0.f) return 0.f;
  return pmf * dist2 / (cos_l * l.area);
}

// Samples a point on one light as seen from receiver `ref` with shading normal `n_ref` (pointing to the side
// being lit). Returns false when no usable sample was produced.
// F: the kernel's feature set (KernelFeature): light kinds outside it are left out of the code.
template <uint32_t F = kAllFeatures>
inline bool sample_light(const Scene& s, Vec3 ref, Vec3 n_ref, float u_choice, Vec2 u, LightSample& ls) {
  const int li = choose_light(s, u_choice);
  const Light& l = s.lights[li];
  const float pmf = s.light_pmf[li];
  Vec3 n;
  ls.prim = l.prim;
  if ((F & kFeatureEnvironment) != 0 && l.prim == kEnvironment) {
    const Vec3 local = sample_cosine_hemisphere(u);
    if (!(local.z > 0.f)) return false;
    ls.wi = Frame::from_normal(n_ref).to_world(local);
    ls.dist = kInfinity;
    ls.p = Vec3(0.f);
    ls.Le = l.emission;
    ls.pdf = pmf * cosine_hemisphere_pdf(local.z);
    return true;
  }
  if ((F & kFeatureSpheres) == 0 || l.prim < s.sphere_begin()) {
    const uint32_t i = l.prim;
    const PolygonSoA& P = s.polygons;
    const Vec3 a = P.v[0][i], b = P.v[1][i], c = P.v[2][i];
    if (P.parallelogram[i]) {
      ls.p = a + u.x * (b - a) + u.y * (c - b);
    } else {
      // Uniform by area: pick a half in proportion to its area (reusing u.x; a triangle is all half 0), then a
      // point in that triangle.
      const float f = P.first_half_fraction[i];
      const bool first = u.x < f;
      const Vec2 ut(std::min(first ? u.x / f : (u.x - f) / (1.f - f), kOneMinusEpsilon), u.y);
      const Vec2 bt = sample_uniform_triangle(ut);
      const Vec3 q = first ? b : c, r = first ? c : P.v[3][i];
      ls.p = bt.x * a + bt.y * q + (1.f - bt.x - bt.y) * r;
    }
    n = P.normal[i];
  } else {
    const uint32_t i = l.prim - s.sphere_begin();
    const DVec3 center = s.spheres.center[i];
    const double r = s.spheres.radius[i];
    const DVec3 dc = center - DVec3(ref);
    const double d2 = glm::dot(dc, dc);
    if (sample_sphere_by_cone(r * r, d2, ref)) {
      // Outside: uniform direction in the subtended cone, then the nearest intersection with the sphere.
      const float omc = sphere_one_minus_cos_max(r * r, d2);
      const Frame frame = Frame::from_normal(Vec3(glm::normalize(dc)));
      const Vec3 wi = glm::normalize(frame.to_world(sample_uniform_cone(u, omc)));
      float t;
      if (!intersect_sphere(center, r, ref, wi, kInfinity, t)) return false;  // grazing the rim
      const DVec3 p = center + r * glm::normalize(DVec3(ref) + static_cast<double>(t) * DVec3(wi) - center);
      ls.p = Vec3(p);
      n = Vec3(glm::normalize(p - center));
      ls.wi = wi;
      ls.dist = glm::length(ls.p - ref);
      ls.Le = light_emission(l, n, -wi);
      ls.pdf = pmf * uniform_cone_pdf(omc);
      return ls.dist > 0.f && ls.pdf > 0.f && std::isfinite(ls.pdf);
    }
    // Inside: uniform over the sphere's area.
    const Vec3 dir = sample_uniform_sphere(u);
    ls.p = Vec3(center + r * DVec3(dir));
    n = dir;
  }
  const Vec3 d = ls.p - ref;
  const float dist2 = glm::dot(d, d);
  if (!(dist2 > 0.f)) return false;
  ls.dist = std::sqrt(dist2);
  ls.wi = d / ls.dist;
  const float cos_l = std::abs(glm::dot(n, ls.wi));
  if (cos_l == 0.f) return false;
  ls.Le = light_emission(l, n, -ls.wi);
  ls.pdf = pmf * dist2 / (cos_l * l.area);
  return std::isfinite(ls.pdf);
}

}  // namespace pt
