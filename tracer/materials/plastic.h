// Plastic: a Lambertian base (albedo) under a dielectric coat (index m.ior, GGX roughness), coupled as in
// Kelemen & Szirmay-Kalos 2001, "A Microfacet Based Coupled Specular-Matte BRDF Model with Importance Sampling"
// (Eurographics short presentations):
//   f(wo, wi) = f_coat(wo, wi) + (albedo/π) (1 − E_c(μo)) (1 − E_c(μi)) / (1 − E_c,avg),
// where f_coat is the GGX reflection lobe of the coat with the exact dielectric Fresnel F(wo·wm) (the
// reflection half of dielectric.h, outside → ior), E_c(μ) its directional albedo (m.energy, tabulated by
// prepare_material) and E_c,avg = 2∫E_c(μ)μ dμ. The diffuse term integrates to albedo·(1 − E_c(μo)), so
// ∫f cos θi dωi = E_c(μo) + albedo (1 − E_c(μo)) ≤ 1, with equality at albedo 1; and f is reciprocal.
// Smooth coat (α < kSmoothAlpha): f_coat is the specular reflection of weight F(μo) and E_c = F exactly.
//
// Lobe choice: the coat with probability p_c = E_c(μo) / (E_c(μo) + (1 − E_c(μo)) lum(albedo)) (each lobe's
// share of the reflected energy, by luminance), else the cosine hemisphere. pdf is the matching mixture (only
// the diffuse part for a smooth coat); rough samples return the full f and pdf.
// Reflection-only and two-sided: wo.z ≥ 0 on entry (bsdf.h mirrors to the front).
#pragma once
#include "materials/bsdf_sample.h"
#include "materials/microfacet.h"
#include "sampling/sampling.h"

namespace pt {

inline float plastic_coat_albedo(const Material& m, float cos_theta) {
  return effectively_smooth(m.alpha) ? fresnel_dielectric(cos_theta, m.ior) : m.energy(cos_theta);
}

inline float plastic_coat_prob(const Material& m, float cos_o) {
  const float ec = plastic_coat_albedo(m, cos_o);
  const float denom = ec + (1.f - ec) * std::max(luminance(m.albedo), 0.f);
  return denom > 0.f ? ec / denom : 1.f;
}

inline Rgb plastic_diffuse(const Material& m, float cos_o, float cos_i) {
  const float one_minus_avg = 1.f - m.energy.e_avg;
  if (!(one_minus_avg > 0.f)) return Rgb(0.f);
  const float s = (1.f - plastic_coat_albedo(m, cos_o)) * (1.f - plastic_coat_albedo(m, cos_i)) / one_minus_avg;
  return m.albedo * (kInvPi * s);
}

inline float plastic_coat_f(const Material& m, Vec3 wo, Vec3 wi) {
  const Vec3 h = wo + wi;
  if (!(glm::dot(h, h) > 0.f)) return 0.f;
  const Vec3 wm = glm::normalize(h);
  return 0.25f * ggx_d(wm, m.alpha) * ggx_g2_over_cos2(wo, wi, m.alpha) *
         fresnel_dielectric(glm::dot(wo, wm), m.ior);
}

inline Rgb plastic_eval(const Material& m, Vec3 wo, Vec3 wi) {
  if (!(wo.z > 0.f) || !(wi.z > 0.f)) return Rgb(0.f);
  Rgb f = plastic_diffuse(m, wo.z, wi.z);
  if (!effectively_smooth(m.alpha)) f += plastic_coat_f(m, wo, wi);
  return f;
}

inline float plastic_pdf(const Material& m, Vec3 wo, Vec3 wi) {
  if (!(wo.z > 0.f) || !(wi.z > 0.f)) return 0.f;
  const float p_c = plastic_coat_prob(m, wo.z);
  float pdf = (1.f - p_c) * cosine_hemisphere_pdf(wi.z);
  if (!effectively_smooth(m.alpha)) {
    const Vec3 h = wo + wi;
    if (glm::dot(h, h) > 0.f) pdf += p_c * ggx_reflection_pdf(wo, glm::normalize(h), m.alpha);
  }
  return pdf;
}

inline bool plastic_sample(const Material& m, Vec3 wo, float uc, Vec2 u, BsdfSample& out) {
  if (!(wo.z > 0.f)) return false;
  const float p_c = plastic_coat_prob(m, wo.z);
  const bool coat = uc < p_c;
  if (effectively_smooth(m.alpha) && coat) {
    const Vec3 wi(-wo.x, -wo.y, wo.z);
    const float F = fresnel_dielectric(wo.z, m.ior);
    out = {wi, Rgb(F / wi.z), p_c, BsdfFlags::Reflection | BsdfFlags::Specular, 1.f};
    return F > 0.f;
  }
  const Vec3 wi = coat ? reflect(-wo, ggx_sample_vndf(wo, m.alpha, u)) : sample_cosine_hemisphere(u);
  if (!(wi.z > 0.f)) return false;
  const float pdf = plastic_pdf(m, wo, wi);
  if (!(pdf > 0.f)) return false;
  out = {wi, plastic_eval(m, wo, wi), pdf, BsdfFlags::Reflection | (coat ? BsdfFlags::Glossy : BsdfFlags::Diffuse), 1.f};
  return true;
}

}  // namespace pt
