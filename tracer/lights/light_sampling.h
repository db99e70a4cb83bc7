// The light interface the integrator sees: choose a light (∝ power), sample a direction to it, evaluate the
// density of a direction found otherwise (for MIS), and the radiance of escaping rays. After pbrt-v4's Light
// (SampleLi / PDF_Li / Le), as plain functions over the scene's light list; the integrator never asks which kind
// of light it holds. All densities are per unit solid angle at the receiving point and exclude the light choice
// (the caller multiplies by Scene::light_pmf).
//
// Strategies per kind:
// - Polygon: a point uniform by area (pbrt-v4 §6.5), converted to solid angle (dist²/(|cos θl|·A)).
// - Rectangle: near the light uniform in the subtended solid angle (spherical rectangle, Ureña et al. 2013),
//   pdf = 1/Ω; farther away by area (use_spherical_rect).
// - Sphere: uniform in the subtended cone from outside (pbrt-v4 §6.2.4), by area from inside.
// - Environment, constant: cosine-weighted about the receiver's normal (the ideal density for a diffuse
//   receiver: in a white furnace every light sample returns exactly 1). Map (file or tabulated sky):
//   ∝ luminance × sin θ over the lat-long image (lights/environment_map.h); under MIS with BSDF sampling
//   (allow_incomplete_pdf, pbrt-v4's allowIncompletePDF) ∝ the luminance above the map's mean, so that the
//   light's samples go where it stands out and BSDF sampling alone covers the rest (MIS compensation).
//   Every function taking allow_incomplete_pdf must be given the same value by both sides of one MIS sum.
// - Sun: uniform in its cone.
// - Point, Spot, Directional (punctual): their one direction, with pdf 1 and LightSample::delta set (no BSDF
//   sample can hit them, so they take no MIS weight).
#pragma once
#include "geometry/interaction.h"
#include "scene/scene.h"  // the lights and their selection probabilities (the one arrow up: tools/include_graph.py)
#include "lights/spherical_rectangle.h"
#include "sampling/sampling.h"

namespace pt {

struct LightSample {
  Vec3 p;          // point on an area light (camera-relative); unused for infinite lights
  Vec3 wi;         // unit direction receiver → light
  float dist;      // distance receiver → light (infinite for infinite lights)
  Rgb Le;          // emitted radiance towards the receiver (0 if it sees the back of a one-sided light)
  float pdf;       // solid-angle density, excluding the light choice; 1 for a punctual light (a Dirac in wi)
  uint32_t prim;   // the light's primitive (kNoPrimitive for infinite lights), excluded from the shadow test
  bool delta = false;  // a punctual light: Le is the incident irradiance's factor I/d² (or E), no MIS partner
};

// The receiving point of a light sample: position and the unit normal of the side being lit.
struct LightReference {
  Vec3 p;
  Vec3 n;
  uint32_t prim = kNoPrimitive;  // the receiver's primitive: a planar light does not light its own surface
};

// A spot light's falloff at cos_axis, the cosine between its axis and the direction it shines along: glTF's
// (KHR_lights_punctual, "Inner and Outer Cone Angles"), t = clamp((cos θ − cos_outer)/(cos_inner − cos_outer),
// 0, 1), intensity × t².
inline float spot_falloff(const Light& l, float cos_axis) {
  const float t = std::clamp((cos_axis - l.cos_outer) / std::max(l.cos_inner - l.cos_outer, 1e-3f), 0.f, 1.f);
  return t * t;
}

[[gnu::always_inline]] inline int choose_light(const Scene& s, float u) {
  const auto it = std::upper_bound(s.light_cdf.begin(), s.light_cdf.end(), u);
  return static_cast<int>(std::min<size_t>(it - s.light_cdf.begin(), s.light_cdf.size() - 1));
}

// The light next-event estimation takes for a receiver at p with normal n (the side lit): by power alone
// (choose_light), or through the scene's light tree where it has one (lights/light_tree.h). `pmf` receives the
// probability of the choice; −1 when the tree can offer no light that reaches the receiver.
[[gnu::always_inline]] inline int choose_light_at(const Scene& s, Vec3 p, Vec3 n, float u, float& pmf) {
  if (s.light_tree.empty()) {
    const int li = choose_light(s, u);
    pmf = s.light_pmf[static_cast<size_t>(li)];
    return li;
  }
  return s.light_tree.choose(p, n, u, s.light_pmf, pmf);
}

// The probability that choose_light_at gives light li for the receiver (p, n).
inline float light_choice_pmf(const Scene& s, Vec3 p, Vec3 n, int li) {
  return s.light_tree.contains(li) ? s.light_tree.pmf(p, n, li) : s.light_pmf[static_cast<size_t>(li)];
}

// Emitted radiance leaving an area light's surface point with front normal n towards direction w.
inline Rgb area_light_emission(const Light& l, Vec3 n, Vec3 w) {
  const float c = glm::dot(n, w);
  return (c > 0.f || (l.two_sided && c < 0.f)) ? l.emission : Rgb(0.f);
}

// A textured area light's image at texture coordinates uv: bilinear at full resolution (level 0), the same
// function wherever it is read (a ray hitting the light, a light sample landing on it), as MIS's two
// strategies must estimate the same integrand.
inline Rgb emission_texel(const Light& l, Vec2 uv) {
  return texture_at(*l.emission_map.texture, l.emission_map.uv_transform, uv);
}

// The texture coordinates of point p on triangle `prim` (its barycentrics by areas; Ericson 2005, §3.4).
inline Vec2 polygon_uv_at(const SceneGeometry& s, uint32_t prim, Vec3 p) {
  if (s.shading.empty() || !s.polygons.triangle[prim]) return Vec2(0.f);
  const Vec3 a = s.polygons.v[0][prim], e1 = s.polygons.v[1][prim] - a, e2 = s.polygons.v[2][prim] - a, q = p - a;
  const float d11 = glm::dot(e1, e1), d12 = glm::dot(e1, e2), d22 = glm::dot(e2, e2);
  const float q1 = glm::dot(q, e1), q2 = glm::dot(q, e2), det = d11 * d22 - d12 * d12;
  if (!(det > 0.f)) return s.shading.uv[prim][0];
  const float b1 = (d22 * q1 - d12 * q2) / det, b2 = (d11 * q2 - d12 * q1) / det;
  const std::array<Vec2, 3>& uv = s.shading.uv[prim];
  return (1.f - b1 - b2) * uv[0] + b1 * uv[1] + b2 * uv[2];
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

// Rectangles are sampled in solid angle only where that pays: close to the light (d² ≤ 4·area, d to its
// centre), where area sampling's density dist²/(cos θl·A) swings by orders of magnitude across the light and a
// receiver a hair from it (the 0.1 gap above `shadertoy`'s light) draws samples weighing thousands. Farther
// away both densities are close and the cheaper area sampling is used. Measured (docs/performance.md): on
// `shadertoy` this takes `nee` from relMSE 0.41 to 0.0030 at 64 spp; extending it to receivers near the
// light's plane as well (h² ≤ area) cut the direct-light noise of `cornell`'s upper back wall but cost more
// time than it saved over the whole image (relMSE at 8 s +20 % against +10 %). The rule depends on the
// receiver alone, so sampling and pdf always agree. (Solid-angle sampling keeps its precision down to
// ~1e-10 sr, lights/spherical_rectangle.h: never approached inside that range.)
inline bool use_spherical_rect(const Light& l, Vec3 ref) {
  const Vec3 d = l.corner + 0.5f * (l.edge_x + l.edge_y) - ref;
  return glm::dot(d, d) <= 4.f * l.area;
}

// A point uniform by area on polygon i (pbrt-v4 §6.5): parallelograms map u onto their area directly (keeping
// its stratification); other polygons pick a half in proportion to its area (reusing u.x; a triangle is all
// half 0), then a point in that triangle.
// True when sample_li samples `l` from `ref` uniformly by area over a parallelogram of uniform emission: the case the
// SIMD shading lanes (integrators/shading_lanes.h) compute themselves; every other light goes the scalar way (an
// emission map's texel among them).
inline bool parallelogram_by_area(const Light& l, Vec3 ref) {
  return l.uniform_parallelogram && !(l.kind == LightKind::Rectangle && use_spherical_rect(l, ref));
}

inline Vec3 sample_polygon_area(const PolygonSoA& P, uint32_t i, Vec2 u) {
  const Vec3 a = P.v[0][i], b = P.v[1][i], c = P.v[2][i];
  if (P.parallelogram[i]) return a + u.x * (b - a) + u.y * (c - b);
  const float f = P.first_half_fraction[i];
  const bool first = u.x < f;
  const Vec2 ut(std::min(first ? u.x / f : (u.x - f) / (1.f - f), kOneMinusEpsilon), u.y);
  const Vec2 bt = sample_uniform_triangle(ut);
  const Vec3 q = first ? b : c, r = first ? c : P.v[3][i];
  return bt.x * a + bt.y * q + (1.f - bt.x - bt.y) * r;
}

// Whether direction w points into the sun light `l`'s disk.
inline bool in_sun_disk(const Light& l, Vec3 w) { return glm::dot(w, l.direction) >= 1.f - l.one_minus_cos_max; }

// Radiance of the infinite light `l` arriving from direction w (an escaping ray's direction).
inline Rgb infinite_light_Le(const Scene& s, const Light& l, Vec3 w) {
  if (l.kind == LightKind::Sun) return in_sun_disk(l, w) ? l.emission : Rgb(0.f);
  return s.environment.uses_map ? s.environment.map->eval(w) : s.environment.radiance;
}

// infinite_light_Le(s, l, w), with infinite_light_pdf(s, l, n, w, allow_incomplete_pdf) in `pdf` where the
// radiance is not black (an environment map looks its texel up once for both).
inline Rgb infinite_light_Le(const Scene& s, const Light& l, Vec3 n, Vec3 w, float& pdf, bool allow_incomplete_pdf) {
  if (l.kind == LightKind::Sun) {
    const bool inside = in_sun_disk(l, w);
    pdf = inside ? uniform_cone_pdf(l.one_minus_cos_max) : 0.f;
    return inside ? l.emission : Rgb(0.f);
  }
  if (s.environment.uses_map) return s.environment.map->eval(w, pdf, allow_incomplete_pdf);
  pdf = cosine_hemisphere_pdf(glm::dot(n, w));
  return s.environment.radiance;
}

// Density with which sample_li() of the infinite light `l` produces direction w at a receiver with normal n.
inline float infinite_light_pdf(const Scene& s, const Light& l, Vec3 n, Vec3 w, bool allow_incomplete_pdf) {
  if (l.kind == LightKind::Sun)
    return in_sun_disk(l, w) ? uniform_cone_pdf(l.one_minus_cos_max) : 0.f;
  return s.environment.uses_map ? s.environment.map->pdf(w, allow_incomplete_pdf)
                                : cosine_hemisphere_pdf(glm::dot(n, w));
}

// Density with which sample_li() of area light li produces the point p_light (front normal n_light) seen from
// the receiver at `ref`. Used for MIS when a BSDF-sampled ray hits an emitter.
template <uint32_t F = kAllFeatures>
inline float area_light_pdf(const Scene& s, const Light& l, Vec3 ref, Vec3 p_light, Vec3 n_light) {
  if ((l.kind == LightKind::Rectangle || l.kind == LightKind::Polygon) && !l.two_sided &&
      glm::dot(n_light, ref - p_light) <= 0.f)
    return 0.f;  // sample_li never samples a one-sided polygon light from behind
  if (l.kind == LightKind::Rectangle && use_spherical_rect(l, ref))
    return spherical_rect_pdf(make_spherical_rect(ref, l.corner, l.edge_x, l.edge_y));
  if ((F & kFeatureSpheres) != 0 && l.kind == LightKind::Sphere) {
    const uint32_t i = l.prim - s.sphere_begin();
    const double r = s.spheres.radius[i];
    const DVec3 dc = DVec3(ref) - s.spheres.center[i];
    const double d2 = glm::dot(dc, dc);
    if (sample_sphere_by_cone(r * r, d2, ref)) return uniform_cone_pdf(sphere_one_minus_cos_max(r * r, d2));
  }
  const Vec3 d = p_light - ref;
  const float dist2 = glm::dot(d, d);
  const float cos_l = std::abs(glm::dot(n_light, d)) / std::sqrt(dist2);
  if (cos_l == 0.f) return 0.f;
  return dist2 / (cos_l * l.area);
}

// Samples light `l` as seen from `ref`. Returns false when no usable sample was produced.
// F: the kernel's geometry (KernelFeature): light kinds on primitives outside it are left out of the code.
// allow_incomplete_pdf: the caller weighs the sample by MIS against BSDF sampling (see the top of this file).
template <uint32_t F = kAllFeatures>
inline bool sample_li(const Scene& s, const Light& l, const LightReference& ref, Vec2 u, LightSample& ls,
                      bool allow_incomplete_pdf) {
  ls.prim = l.prim;
  Vec3 n(0.f);
  // A planar light cannot light its own surface (every direction to it is tangent). Rounding puts a receiver on
  // a rectangle light a hair to either side of its plane, and the spherical rectangle seen from there fills a
  // hemisphere: its samples carried that hemisphere's radiance into the receiver (stress: nee 2.4 % high in the
  // furnace room of two-sided emitting quads). BSDF-sampled rays never hit their own planar primitive either,
  // so area_light_pdf is never asked about this case.
  if ((l.kind == LightKind::Rectangle || l.kind == LightKind::Polygon) && l.prim == ref.prim) return false;
  // A one-sided polygon light seen from behind sends nothing: no sample (area_light_pdf is 0 there too).
  if ((l.kind == LightKind::Rectangle || l.kind == LightKind::Polygon) && !l.two_sided &&
      glm::dot(s.polygons.normal[l.prim], ref.p - s.polygons.v[0][l.prim]) <= 0.f)
    return false;
  ls.delta = false;
  switch (l.kind) {
    case LightKind::Point:
    case LightKind::Spot: {
      // A Dirac in direction: the "radiance" times the cosine over the pdf must give the irradiance I·cos/d², so
      // Le carries I/d² and pdf is 1 (pbrt-v4's PointLight::SampleLi); a spot's falloff multiplies it.
      ls.p = l.position;
      const Vec3 d = l.position - ref.p;
      const float dist2 = glm::dot(d, d);
      if (!(dist2 > 0.f)) return false;
      ls.dist = std::sqrt(dist2);
      ls.wi = d / ls.dist;
      float scale = 1.f / dist2;
      if (l.kind == LightKind::Spot) scale *= spot_falloff(l, glm::dot(-ls.wi, l.direction));
      ls.Le = l.emission * scale;
      ls.pdf = 1.f;
      ls.delta = true;
      return scale > 0.f && std::isfinite(scale);
    }
    case LightKind::Directional: {
      ls.p = Vec3(0.f);
      ls.dist = kInfinity;
      ls.wi = l.direction;
      ls.Le = l.emission;
      ls.pdf = 1.f;
      ls.delta = true;
      return true;
    }
    case LightKind::Environment: {
      ls.dist = kInfinity;
      ls.p = Vec3(0.f);
      if (s.environment.uses_map) {
        if (!s.environment.map->sample(u, ls.wi, ls.pdf, ls.Le, allow_incomplete_pdf)) return false;
        return ls.pdf > 0.f && std::isfinite(ls.pdf);
      }
      const Vec3 local = sample_cosine_hemisphere(u);
      if (!(local.z > 0.f)) return false;
      ls.wi = Frame::from_normal(ref.n).to_world(local);
      ls.Le = s.environment.radiance;
      ls.pdf = cosine_hemisphere_pdf(local.z);
      return true;
    }
    case LightKind::Sun: {
      ls.dist = kInfinity;
      ls.p = Vec3(0.f);
      ls.wi = glm::normalize(Frame::from_normal(l.direction).to_world(sample_uniform_cone(u, l.one_minus_cos_max)));
      ls.Le = l.emission;
      ls.pdf = uniform_cone_pdf(l.one_minus_cos_max);
      return true;
    }
    case LightKind::Rectangle: {
      if (use_spherical_rect(l, ref.p)) {
        const SphericalRect sr = make_spherical_rect(ref.p, l.corner, l.edge_x, l.edge_y);
        if (!(sr.solid_angle > 0.0)) return false;  // the receiver is in the light's plane
        ls.p = sample(sr, u);
        ls.pdf = spherical_rect_pdf(sr);
        const Vec3 d = ls.p - ref.p;
        const float dist2 = glm::dot(d, d);
        if (!(dist2 > 0.f) || !std::isfinite(ls.pdf)) return false;
        ls.dist = std::sqrt(dist2);
        ls.wi = d / ls.dist;
        ls.Le = area_light_emission(l, s.polygons.normal[l.prim], -ls.wi);
        return true;
      }
      [[fallthrough]];  // far from the light: by area
    }
    case LightKind::Polygon: {
      ls.p = sample_polygon_area(s.polygons, l.prim, u);
      n = s.polygons.normal[l.prim];
      break;
    }
    case LightKind::Sphere: {
      if constexpr ((F & kFeatureSpheres) == 0) return false;
      const uint32_t i = l.prim - s.sphere_begin();
      const DVec3 center = s.spheres.center[i];
      const double r = s.spheres.radius[i];
      const DVec3 dc = center - DVec3(ref.p);
      const double d2 = glm::dot(dc, dc);
      if (sample_sphere_by_cone(r * r, d2, ref.p)) {
        // Outside: uniform direction in the subtended cone, then the nearest intersection with the sphere.
        const float omc = sphere_one_minus_cos_max(r * r, d2);
        const Frame frame = Frame::from_normal(Vec3(glm::normalize(dc)));
        const Vec3 wi = glm::normalize(frame.to_world(sample_uniform_cone(u, omc)));
        float t;
        if (!intersect_sphere(center, r, ref.p, wi, kInfinity, t)) return false;  // grazing the rim
        const DVec3 p = center + r * glm::normalize(DVec3(ref.p) + static_cast<double>(t) * DVec3(wi) - center);
        ls.p = Vec3(p);
        n = Vec3(glm::normalize(p - center));
        ls.wi = wi;
        ls.dist = glm::length(ls.p - ref.p);
        ls.Le = area_light_emission(l, n, -wi);
        ls.pdf = uniform_cone_pdf(omc);
        return ls.dist > 0.f && ls.pdf > 0.f && std::isfinite(ls.pdf);
      }
      // Inside: uniform over the sphere's area.
      const Vec3 dir = sample_uniform_sphere(u);
      ls.p = Vec3(center + r * glm::normalize(DVec3(dir)));  // on the surface to double precision (light_emission.h)
      n = dir;
      break;
    }
  }
  const Vec3 d = ls.p - ref.p;
  const float dist2 = glm::dot(d, d);
  if (!(dist2 > 0.f)) return false;
  ls.dist = std::sqrt(dist2);
  ls.wi = d / ls.dist;
  const float cos_l = std::abs(glm::dot(n, ls.wi));
  if (cos_l == 0.f) return false;
  ls.Le = area_light_emission(l, n, -ls.wi);
  if (l.emission_map.texture) [[unlikely]] ls.Le *= emission_texel(l, polygon_uv_at(s, l.prim, ls.p));
  ls.pdf = dist2 / (cos_l * l.area);
  return std::isfinite(ls.pdf);
}

// The whole light-sampling strategy of next-event estimation: choose a light with u_choice (choose_light_at: ∝
// power, or by importance through the light tree), then sample it. ls.pdf includes the choice probability; `li`
// receives the light's index.
template <uint32_t F = kAllFeatures>
inline bool sample_lights(const Scene& s, const LightReference& ref, float u_choice, Vec2 u, LightSample& ls, int& li,
                          bool allow_incomplete_pdf) {
  if (s.lights.empty()) return false;
  float pmf = 0.f;
  li = choose_light_at(s, ref.p, ref.n, u_choice, pmf);
  if (li < 0) return false;
  if (!sample_li<F>(s, s.lights[li], ref, u, ls, allow_incomplete_pdf)) return false;
  ls.pdf *= pmf;
  return ls.pdf > 0.f;
}

// Density of that strategy for the point p_light (front normal n_light) of area light li, seen from a receiver
// at `ref` with normal ref_n (the side lit, as sample_lights was given it).
template <uint32_t F = kAllFeatures>
inline float lights_pdf_area(const Scene& s, int li, Vec3 ref, Vec3 ref_n, Vec3 p_light, Vec3 n_light) {
  return light_choice_pmf(s, ref, ref_n, li) * area_light_pdf<F>(s, s.lights[li], ref, p_light, n_light);
}

// Density of that strategy for an escaping direction w (the sum over the infinite lights, each weighted by its
// choice probability), at a receiver with normal n.
inline float lights_pdf_infinite(const Scene& s, Vec3 n, Vec3 w, bool allow_incomplete_pdf) {
  float p = 0.f;
  for (const uint32_t li : s.infinite_lights)
    p += s.light_pmf[li] * infinite_light_pdf(s, s.lights[li], n, w, allow_incomplete_pdf);
  return p;
}

}  // namespace pt
