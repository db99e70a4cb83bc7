// Emission sampling: where light paths start (bidirectional path tracing, integrators/bdpt_kernels.h). A point
// on a light and a direction leaving it, with both densities, as pbrt-v3's Light::Sample_Le / Pdf_Le (§12.3,
// §16.1.2). light_sampling.h samples lights as seen from a receiver; this file samples them as sources.
//
// - Area lights (polygons, rectangles, spheres): a point uniform by area (pdf_pos = 1/A), a direction
//   cosine-distributed about the emitting normal (pdf_dir = cos θ/π; two-sided lights pick a side first, so
//   |cos θ|/2π).
// - Infinite lights: a direction from the light's own density (the map's, 1/4π for a constant environment, the
//   sun's cone), then a point uniform on the disk of radius R perpendicular to it that covers the scene's
//   bounding sphere (pdf_pos = 1/πR²), the ray starting R outside. When the scene has an emission focus
//   (Scene::emission_focus_radius > 0: the surfaces that can focus light into caustics), half of the points are
//   drawn instead on the disk that covers the focus sphere, with a density that falls to zero at its rim
//   (2(1 − ρ²/r²)/πr² at distance ρ from its centre), and pdf_pos is the mixture's density there: continuous, so
//   that the MIS weights, which evaluate it at the ray's hit point (rounded, far from the light's disk), agree
//   with the density the ray was drawn with also next to the rim (a hard-edged disk jumped there). Without
//   it a sun over a large ground plane (`sky`: a 2·10⁶ wide quad) aimed its light paths at the whole plane, and
//   almost none ever reached the glass and gold balls: their caustics on the ground were left to camera paths
//   that hit the sun by chance, as fireflies.
// - Punctual lights (pbrt-v4 PointLight / SpotLight / DistantLight::SampleLe): a point light at its position
//   (pdf_pos 1: a Dirac in position) with a direction uniform over the sphere, a spot light with one uniform
//   in its outer cone (1/(2π(1 − cos_outer))) and Le = I × its falloff; both with n = d (no surface, no
//   cosine). A directional light: its one direction (pdf_dir 1, a Dirac) and a point on the disks of the
//   infinite lights, Le = its irradiance E (the power through the disk is E πR²).
//
// The same densities serve the MIS weights of every strategy that reaches a light (bdpt_vertex.h). The
// bidirectional estimator's light-sampling strategy (s = 1) samples infinite lights with these direction
// densities too, rather than sample_li's cosine lobe for a constant environment: a strategy's MIS density must
// be non-zero wherever the strategy can sample, and a cosine lobe about one side's normal cannot sample the
// environment behind a transmissive surface.
#pragma once
#include "lights/light_sampling.h"

namespace pt {

struct EmissionSample {
  Vec3 p;         // origin of the emitted ray (camera-relative); on the disk outside the scene for infinite lights
  Vec3 p_error;   // bound on p's rounding error (area lights; zero for infinite lights)
  Vec3 n;         // unit normal at p on the emitting side (area lights); the ray direction for infinite and
                  // punctual lights (no surface: no cosine)
  Vec3 d;         // unit direction of the emitted ray
  Rgb Le;         // radiance along d
  float pdf_pos;  // per unit area
  float pdf_dir;  // per unit solid angle
};

// Direction density of a point or spot light's emission along w (0 outside a spot's outer cone).
inline float punctual_emission_pdf_dir(const Light& l, Vec3 w) {
  if (l.kind == LightKind::Spot)
    return glm::dot(w, l.direction) >= l.cos_outer ? uniform_cone_pdf(1.f - l.cos_outer) : 0.f;
  return uniform_sphere_pdf();
}

// Direction density of an area light's emission towards w from a point with front normal n.
inline float area_emission_pdf_dir(const Light& l, Vec3 n, Vec3 w) {
  const float c = glm::dot(n, w);
  return l.two_sided ? std::abs(c) * (0.5f * kInvPi) : std::max(c, 0.f) * kInvPi;
}

// The front normal of area light l at its point p.
inline Vec3 area_light_normal(const Scene& s, const Light& l, Vec3 p) {
  if (l.kind == LightKind::Sphere) return glm::normalize(Vec3(DVec3(p) - s.spheres.center[l.prim - s.sphere_begin()]));
  return s.polygons.normal[l.prim];
}

// Density with which infinite light l's emission (and the s = 1 strategy) picks w, the direction towards it.
inline float infinite_light_direction_pdf(const Scene& s, const Light& l, Vec3 w) {
  if (l.kind == LightKind::Sun)
    return in_sun_disk(l, w) ? uniform_cone_pdf(l.one_minus_cos_max) : 0.f;
  return s.environment.uses_map ? s.environment.map->pdf(w) : uniform_sphere_pdf();
}

// Samples w, a direction towards infinite light l, from that density; Le is its radiance along −w.
inline bool sample_infinite_light_direction(const Scene& s, const Light& l, Vec2 u, Vec3& w, Rgb& Le, float& pdf) {
  if (l.kind == LightKind::Sun) {
    w = glm::normalize(Frame::from_normal(l.direction).to_world(sample_uniform_cone(u, l.one_minus_cos_max)));
    Le = l.emission;
    pdf = uniform_cone_pdf(l.one_minus_cos_max);
    return true;
  }
  if (s.environment.uses_map) return s.environment.map->sample(u, w, pdf, Le) && pdf > 0.f && std::isfinite(pdf);
  w = sample_uniform_sphere(u);
  Le = s.environment.radiance;
  pdf = uniform_sphere_pdf();
  return true;
}

// The sum over infinite lights of choice probability × direction density: the density with which a light path
// starts towards the scene from direction w (pbrt-v3's InfiniteLightDensity).
inline float infinite_lights_origin_pdf(const Scene& s, Vec3 w) {
  float p = 0.f;
  for (const uint32_t li : s.infinite_lights) p += s.light_pmf[li] * infinite_light_direction_pdf(s, s.lights[li], w);
  return p;
}

// Radius of the disk infinite lights emit from: the scene's bounding sphere (centred at the camera).
inline float emission_disk_radius(const Scene& s) { return static_cast<float>(std::max(s.bounding_radius, 1e-30)); }

// The share of infinite lights' emitted rays aimed at the emission focus, when the scene has one.
inline constexpr float kEmissionFocusShare = 0.5f;

// Density per unit area, on the disk perpendicular to d, with which an infinite light's emission starts a ray
// travelling along d (unit) through point p: the whole disk's 1/πR², mixed with the focus disk's
// 2(1 − ρ²/r_f²)/πr_f², ρ the ray's distance from the focus's centre (zero from ρ = r_f on).
inline float infinite_emission_pdf_pos(const Scene& s, Vec3 d, Vec3 p) {
  const float R = emission_disk_radius(s);
  const float whole = 1.f / (kPi * R * R);
  const float rf = s.emission_focus_radius;
  if (!(rf > 0.f)) return whole;
  const Vec3 q = p - s.emission_focus_center;
  const Vec3 across = q - glm::dot(q, d) * d;  // the offset from the axis, without cancelling squares far away
  const float rho2 = glm::dot(across, across) / (rf * rf);
  const float focus = rho2 < 1.f ? 2.f * (1.f - rho2) / (kPi * rf * rf) : 0.f;
  return (1.f - kEmissionFocusShare) * whole + kEmissionFocusShare * focus;
}

// A point of the focus disk's density 2(1 − ρ²/r²)/πr² on the unit disk (r = 1): its radial CDF is 1 − (1 − ρ²)²,
// so ρ² = 1 − √(1 − u.x); the angle is uniform.
inline Vec2 sample_focus_disk(Vec2 u) {
  const float rho = std::sqrt(std::max(0.f, 1.f - std::sqrt(1.f - u.x)));
  const float phi = 2.f * kPi * u.y;
  return {rho * std::cos(phi), rho * std::sin(phi)};
}

// The point of a light path arriving from infinity along −w (w towards the light), with u_pos: on the disk
// covering the scene or the focus disk (above); sets es.d, es.n, es.p, es.p_error and es.pdf_pos.
inline bool sample_emission_disk(const Scene& s, Vec3 w, Vec2 u_pos, EmissionSample& es) {
  const float r = emission_disk_radius(s);
  const Frame f = Frame::from_normal(w);
  es.d = -w;
  es.n = es.d;
  es.p_error = Vec3(0.f);
  // The point on the disk (in the plane through its centre, where the density is evaluated: far out along w
  // the subtraction in infinite_emission_pdf_pos would round), and the ray's start outside the scene.
  Vec2 u = u_pos;
  Vec3 on_disk;
  if (s.emission_focus_radius > 0.f && u.x < kEmissionFocusShare) {  // the focus disk
    u.x = std::min(u.x / kEmissionFocusShare, kOneMinusEpsilon);
    const Vec2 disk = sample_focus_disk(u);
    const Vec3 c = s.emission_focus_center;
    on_disk = c + s.emission_focus_radius * (f.s * disk.x + f.t * disk.y);
    es.p = on_disk + (r + glm::length(c)) * w;  // c is inside the bounding sphere: this starts beyond it
  } else {
    if (s.emission_focus_radius > 0.f)
      u.x = std::min((u.x - kEmissionFocusShare) / (1.f - kEmissionFocusShare), kOneMinusEpsilon);
    const Vec2 disk = sample_uniform_disk_concentric(u);
    on_disk = r * (f.s * disk.x + f.t * disk.y);
    es.p = r * (w + f.s * disk.x + f.t * disk.y);  // as before the focus existed: the same bits without one
  }
  es.pdf_pos = infinite_emission_pdf_pos(s, es.d, on_disk);
  return es.pdf_pos > 0.f && std::isfinite(es.pdf_pos);
}

// Samples light l's emission with u_pos (the point) and u_dir (the direction). False when nothing usable came out.
template <uint32_t F = kAllFeatures>
inline bool sample_emission(const Scene& s, const Light& l, Vec2 u_pos, Vec2 u_dir, EmissionSample& es) {
  if (l.infinite()) {
    Vec3 w;
    if (!sample_infinite_light_direction(s, l, u_dir, w, es.Le, es.pdf_dir)) return false;
    return sample_emission_disk(s, w, u_pos, es);
  }
  if (l.kind == LightKind::Directional) {
    es.Le = l.emission;
    es.pdf_dir = 1.f;
    return sample_emission_disk(s, l.direction, u_pos, es);
  }
  if (l.kind == LightKind::Point || l.kind == LightKind::Spot) {
    es.p = l.position;
    es.p_error = Vec3(0.f);
    es.pdf_pos = 1.f;
    if (l.kind == LightKind::Spot) {
      es.d = Frame::from_normal(l.direction).to_world(sample_uniform_cone(u_dir, 1.f - l.cos_outer));
      es.Le = l.emission * spot_falloff(l, glm::dot(es.d, l.direction));
    } else {
      es.d = sample_uniform_sphere(u_dir);
      es.Le = l.emission;
    }
    es.n = es.d;
    es.pdf_dir = punctual_emission_pdf_dir(l, es.d);
    return es.pdf_dir > 0.f;
  }
  if (l.kind == LightKind::Sphere) {
    if constexpr ((F & kFeatureSpheres) == 0) return false;
    const uint32_t i = l.prim - s.sphere_begin();
    const Vec3 dir = sample_uniform_sphere(u_pos);
    // Normalised in double: a float direction is unit only to ~1e-7, which on a sphere of radius 1e5 puts the
    // point 1e-2 off the surface, through the walls of a room built of huge spheres.
    es.p = Vec3(s.spheres.center[i] + s.spheres.radius[i] * glm::normalize(DVec3(dir)));
    es.p_error = gamma_bound(3) * glm::abs(es.p);
    es.n = dir;
  } else {
    const PolygonSoA& P = s.polygons;
    const uint32_t i = l.prim;
    es.p = sample_polygon_area(P, i, u_pos);
    es.p_error = gamma_bound(8) * (glm::abs(P.v[0][i]) + glm::abs(P.v[1][i]) + glm::abs(P.v[2][i]) + glm::abs(P.v[3][i]));
    es.n = P.normal[i];
  }
  // Two-sided lights: the first half of u_dir.x emits from the front, the second from the back.
  Vec2 u = u_dir;
  if (l.two_sided) {
    const bool back = u.x >= 0.5f;
    u.x = std::min(back ? 2.f * u.x - 1.f : 2.f * u.x, kOneMinusEpsilon);
    if (back) es.n = -es.n;
  }
  const Vec3 local = sample_cosine_hemisphere(u);
  if (!(local.z > 0.f)) return false;
  es.d = Frame::from_normal(es.n).to_world(local);
  es.Le = l.emission;
  es.pdf_pos = 1.f / l.area;
  es.pdf_dir = cosine_hemisphere_pdf(local.z) * (l.two_sided ? 0.5f : 1.f);
  return es.pdf_dir > 0.f && std::isfinite(es.pdf_pos);
}

}  // namespace pt
