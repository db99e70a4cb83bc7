// Conductors: the tinted mirror and the GGX microfacet conductor with multiple-scattering compensation.
// Reflection-only: wo.z ≥ 0 on entry (bsdf.h mirrors to the front).
//
// Single scattering (Walter et al. 2007 eq. 20; pbrt-v4 ConductorBxDF):
//   f_ss(wo, wi) = D(wm) G2(wo, wi) F(wo·wm) / (4 cos θo cos θi),   wm = normalize(wo + wi),
// with the height-correlated Smith G2 and visible-normal sampling (microfacet.h).
// Fresnel: Schlick through F0 = albedo, or the exact complex-index F (fresnel.h) when m.complex_ior.
//
// Multiple scattering (Kulla & Conty 2017, "Revisiting Physically Based Shading at Imageworks", SIGGRAPH course
// "Physically Based Shading in Theory and Practice", slides 16–18):
//   f_ms(wo, wi) = (1 − E(μo))(1 − E(μi)) / (π (1 − E_avg)) · F_ms,
//   F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg)),
// where E(μ) is the directional albedo of f_ss with F = 1 (m.energy), E_avg = 2∫E(μ)μ dμ, and
// F_avg = 2∫F(μ)μ dμ (m.f_avg). With F = 1 the lobe adds exactly 1 − E(μo), so a white conductor reflects
// everything; F_ms accounts for the energy the Fresnel factor absorbs along the longer microfacet paths.
//
// Sampling: a mixture, chosen by uc, of visible-normal reflection (probability 1 − p_ms) and the cosine
// hemisphere for f_ms (probability p_ms = 1 − E(μo), the share of f_ms in a white conductor's albedo); pdf is
// the matching mixture density, and the sample returns the full f and pdf (one-sample MIS over the two lobes).
#pragma once
#include "materials/bsdf_sample.h"
#include "materials/microfacet.h"
#include "sampling/sampling.h"

namespace pt {

// Mirror: reflectance = albedo at every angle. Delta lobe: only sample returns it.
inline bool mirror_sample(const Material& m, Vec3 wo, BsdfSample& out) {
  if (!(wo.z > 0.f) || is_black(m.albedo)) return false;
  const Vec3 wi(-wo.x, -wo.y, wo.z);
  out = {wi, m.albedo / wi.z, 1.f, BsdfFlags::Reflection | BsdfFlags::Specular, 1.f};
  return true;
}

inline Rgb conductor_fresnel(const Material& m, float cos_theta) {
  return m.complex_ior ? fresnel_complex(cos_theta, m.eta, m.k) : fresnel_schlick(m.albedo, cos_theta);
}

// Probability of sampling the multiple-scattering (cosine) lobe, from E(μo).
inline float conductor_ms_prob(const Material& m, float e_o) {
  return m.energy.e_avg < 1.f ? std::clamp(1.f - e_o, 0.f, 1.f) : 0.f;
}

// f_ms from E(μo) and μi.
inline Rgb conductor_ms(const Material& m, float e_o, float cos_i) {
  const float one_minus_e_avg = 1.f - m.energy.e_avg;
  if (!(one_minus_e_avg > 1e-6f)) return Rgb(0.f);
  const Rgb& fa = m.f_avg;
  const Rgb f_ms = fa * fa * m.energy.e_avg / (Rgb(1.f) - fa * one_minus_e_avg);
  return f_ms * ((1.f - e_o) * (1.f - m.energy(cos_i)) / (kPi * one_minus_e_avg));
}

// f (kF) and pdf (kPdf) of the rough lobes (BsdfValue) for wo.z > 0 and wi.z > 0, given E(μo) = e_o (a sample
// has it from its lobe choice): the half vector and D computed once.
template <bool kF, bool kPdf>
inline BsdfValue conductor_value_at(const Material& m, float e_o, Vec3 wo, Vec3 wi) {
  BsdfValue r;
  const Vec3 h = wo + wi;
  const bool has_half = glm::dot(h, h) > 0.f;
  const Vec3 wm = has_half ? glm::normalize(h) : Vec3(0.f, 0.f, 1.f);
  const float d = has_half ? ggx_d(wm, m.alpha) : 0.f;
  if constexpr (kF) {
    r.f = conductor_ms(m, e_o, wi.z);
    if (has_half) {
      const float d_v = d * 0.25f * ggx_g2_over_cos2(wo, wi, m.alpha);
      r.f += d_v * conductor_fresnel(m, glm::dot(wo, wm));
    }
  }
  if constexpr (kPdf) {
    const float p_ms = conductor_ms_prob(m, e_o);
    const float p_ss = has_half ? ggx_reflection_pdf(wo, wm, d, m.alpha) : 0.f;
    r.pdf = (1.f - p_ms) * p_ss + p_ms * cosine_hemisphere_pdf(wi.z);
  }
  return r;
}

// The same for any directions (0 where a lobe is not).
template <bool kF, bool kPdf>
[[gnu::noinline]] inline BsdfValue conductor_value(const Material& m, Vec3 wo, Vec3 wi) {
  if (effectively_smooth(m.alpha) || !(wo.z > 0.f) || !(wi.z > 0.f)) return {};
  return conductor_value_at<kF, kPdf>(m, m.energy(wo.z), wo, wi);
}

inline Rgb conductor_eval(const Material& m, Vec3 wo, Vec3 wi) { return conductor_value<true, false>(m, wo, wi).f; }
inline float conductor_pdf(const Material& m, Vec3 wo, Vec3 wi) { return conductor_value<false, true>(m, wo, wi).pdf; }

inline bool conductor_sample(const Material& m, Vec3 wo, float uc, Vec2 u, BsdfSample& out) {
  if (!(wo.z > 0.f)) return false;
  if (effectively_smooth(m.alpha)) {
    const Vec3 wi(-wo.x, -wo.y, wo.z);
    const Rgb F = conductor_fresnel(m, wo.z);
    if (is_black(F)) return false;
    out = {wi, F / wi.z, 1.f, BsdfFlags::Reflection | BsdfFlags::Specular, 1.f};
    return true;
  }
  const float e_o = m.energy(wo.z);
  Vec3 wi;
  if (uc < conductor_ms_prob(m, e_o)) {
    wi = sample_cosine_hemisphere(u);
  } else {
    const Vec3 wm = ggx_sample_vndf(wo, m.alpha, u);
    wi = reflect(-wo, wm);
  }
  if (!(wi.z > 0.f)) return false;
  const BsdfValue v = conductor_value_at<true, true>(m, e_o, wo, wi);
  if (!(v.pdf > 0.f)) return false;
  out = {wi, v.f, v.pdf, BsdfFlags::Reflection | BsdfFlags::Glossy, 1.f};
  return true;
}

}  // namespace pt
