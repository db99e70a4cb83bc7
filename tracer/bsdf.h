// The three materials' scattering functions. Directions point away from the surface; `n` is the unit geometric
// normal flipped to the side the light arrives from (non-emissive surfaces are two-sided for shading).
// Conventions of pbrt-v4 ch. 9: f is the BSDF value (sr⁻¹), pdfs are per steradian, a sample's weight is
// f·|cos θ|/pdf. Delta lobes (mirror, dielectric) are handled by their own sample functions and carry no pdf.
#pragma once
#include "math.h"

namespace pt {

// Lambert: f = ρ/π.
inline Rgb diffuse_f(Rgb albedo) { return albedo * kInvPi; }

// Perfect mirror: R = V − 2(V·N)N for incident direction V (pointing towards the surface).
inline Vec3 reflect(Vec3 v, Vec3 n) { return v - 2.f * glm::dot(v, n) * n; }

// Exact Fresnel reflectance of a smooth dielectric interface for unpolarised light (pbrt-v4 eq. 9.4–9.5).
// cos_i: cosine of the incident angle on the incident side (≥ 0); eta = n_transmitted / n_incident.
// Returns 1 under total internal reflection.
inline float fresnel_dielectric(float cos_i, float eta) {
  cos_i = std::clamp(cos_i, 0.f, 1.f);
  const float sin2_t = (1.f - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1.f) return 1.f;
  const float cos_t = safe_sqrt(1.f - sin2_t);
  const float r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  const float r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  return 0.5f * (r_parl * r_parl + r_perp * r_perp);
}

// Snell refraction of wo (pointing away from the surface, on the side of n) through an interface with relative
// index eta = n_t/n_i. Returns false under total internal reflection.
inline bool refract(Vec3 wo, Vec3 n, float eta, Vec3& wt) {
  const float cos_i = glm::dot(n, wo);
  const float sin2_t = std::max(0.f, 1.f - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1.f) return false;
  const float cos_t = safe_sqrt(1.f - sin2_t);
  wt = glm::normalize(-wo / eta + (cos_i / eta - cos_t) * n);
  return true;
}

struct DeltaSample {
  Vec3 wi;
  Rgb weight;       // f·|cos|/pdf of the chosen lobe
  float eta_scale;  // factor to undo the radiance scaling (1/η²) for Russian roulette decisions
};

// Smooth dielectric: chooses reflection with probability F (so the weight is 1 for the chosen lobe, times the
// 1/η² radiance compression on transmission: pbrt-v4 §9.5.2, radiance mode). ng is the front normal; the front
// side is outside (index 1), the back side inside (index ior).
inline DeltaSample sample_dielectric(Vec3 wo, Vec3 ng, float ior, float u) {
  const bool entering = glm::dot(wo, ng) > 0.f;
  const Vec3 n = entering ? ng : -ng;
  const float eta = entering ? ior : 1.f / ior;  // n_t / n_i
  const float F = fresnel_dielectric(glm::dot(wo, n), eta);
  Vec3 wt;
  if (u < F || !refract(wo, n, eta, wt)) return {reflect(-wo, n), Rgb(1.f), 1.f};
  return {wt, Rgb(1.f / (eta * eta)), eta * eta};
}

}  // namespace pt
