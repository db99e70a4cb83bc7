// Lambertian reflection f = ρ/π with cosine-weighted sampling (pbrt-v4 DiffuseBxDF).
// Like every reflection-only lobe here, the functions take wo in the upper hemisphere (wo.z ≥ 0): bsdf.h
// mirrors both directions to the front first, which makes the material two-sided.
#pragma once
#include "materials/bsdf_sample.h"
#include "sampling/sampling.h"

namespace pt {

// Lambert: f = ρ/π, one channel over T = float or vfloat (core/lanes.h).
template <class T>
[[gnu::always_inline]] inline T lambert_f(const T& albedo) {
  return albedo * kInvPi;
}
inline Rgb diffuse_f(Rgb albedo) { return {lambert_f(albedo.x), lambert_f(albedo.y), lambert_f(albedo.z)}; }

inline Rgb diffuse_eval(const Material& m, Vec3 wo, Vec3 wi) {
  return wo.z > 0.f && wi.z > 0.f ? diffuse_f(m.albedo) : Rgb(0.f);
}

inline float diffuse_pdf(Vec3 wo, Vec3 wi) { return wo.z > 0.f && wi.z > 0.f ? cosine_hemisphere_pdf(wi.z) : 0.f; }

inline bool diffuse_sample(const Material& m, Vec3 wo, Vec2 u, BsdfSample& out) {
  if (!(wo.z > 0.f) || is_black(m.albedo)) return false;
  const Vec3 wi = sample_cosine_hemisphere(u);
  if (!(wi.z > 0.f)) return false;
  out = {wi, diffuse_f(m.albedo), cosine_hemisphere_pdf(wi.z), BsdfFlags::Reflection | BsdfFlags::Diffuse, 1.f};
  return true;
}

}  // namespace pt
