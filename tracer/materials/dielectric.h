// Dielectric interface (glass): smooth (delta) and rough (GGX) reflection + transmission.
//
// Rough model: Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces" (EGSR), with the
// generalized half vector, its Jacobians, and visible-normal sampling, exactly as pbrt-v4 DielectricBxDF
// (src/pbrt/bxdfs.cpp, radiance mode). With η = n_t/n_i the relative index for wo's side:
//   reflection (same side):  f_r = D(wm) G2 F(wo·wm) / (4 |cos θo cos θi|),            wm = normalize(wo + wi)
//   transmission:            f_t = D(wm) G2 (1 − F) |wi·wm| |wo·wm| / (|cos θo cos θi| (wi·wm + wo·wm/η)²) / η²
//                                                                                       wm = ±normalize(η wi + wo)
//   (the final 1/η² is the radiance scaling of non-symmetric transport, Veach 1997 §5.2; sampled with
//   TransportMode::Importance, from the light side, it is left out, as in pbrt-v4's importance mode).
// Sampling: wm ~ D_wo (visible normals), reflection with probability F(wo·wm), else refraction about wm:
//   pdf_r = D_wo(wm) F / (4 |wo·wm|),   pdf_t = D_wo(wm) (1 − F) |wi·wm| / (wi·wm + wo·wm/η)².
// Back-facing microfacets (wm on the wrong side of wo or wi) contribute nothing.
// Smooth model (α < kSmoothAlpha): reflect with probability F, else refract; weights 1 and 1/η² (1 for
// importance).
//
// Sides: the front (wo.z > 0) has index 1, the back has m.ior. Every function first mirrors the configuration
// in z so that wo is above (wo.z > 0) and uses η = ior (entering) or 1/ior (leaving); mirroring preserves all
// dot products with the mirrored wm, so the formulas above apply unchanged. BsdfSample::eta = η on
// transmission. Dielectrics are colourless (the albedo is not used).
#pragma once
#include "materials/bsdf_sample.h"
#include "materials/microfacet.h"

namespace pt {

inline Vec3 flip_z(Vec3 v) { return {v.x, v.y, -v.z}; }

// Generalized half vector of (wo, wi) for wo.z > 0 and relative index eta, facing +z; false when degenerate or
// back-facing. etap is η for transmission, 1 for reflection.
inline bool dielectric_half_vector(Vec3 wo, Vec3 wi, float eta, Vec3& wm, float& etap) {
  const bool reflect = wi.z > 0.f;
  etap = reflect ? 1.f : eta;
  const Vec3 h = wi * etap + wo;
  const float len2 = glm::dot(h, h);
  if (!(len2 > 0.f)) return false;
  wm = h / std::sqrt(len2);
  if (wm.z < 0.f) wm = -wm;
  // Discard back-facing microfacets (pbrt-v4 DielectricBxDF::f).
  return glm::dot(wm, wi) * wi.z >= 0.f && glm::dot(wm, wo) > 0.f;
}

// f (kF) and pdf (kPdf) of the rough lobe for wo.z > 0 (BsdfValue): the half vector, F and D computed once.
template <bool kF, bool kPdf>
inline BsdfValue dielectric_value_up(Vec3 wo, Vec3 wi, float alpha, float eta) {
  BsdfValue r;
  if (!(wo.z > 0.f) || wi.z == 0.f) return r;
  Vec3 wm;
  float etap;
  if (!dielectric_half_vector(wo, wi, eta, wm, etap)) return r;
  const float cos_om = glm::dot(wo, wm);
  const float F = fresnel_dielectric(cos_om, eta);
  const float d = ggx_d(wm, alpha);
  if (wi.z > 0.f) {
    if constexpr (kF) r.f = Rgb(0.25f * (d * ggx_g2_over_cos2(wo, wi, alpha)) * F);
    if constexpr (kPdf) r.pdf = ggx_vndf_pdf(wo, wm, d, alpha) * F / (4.f * cos_om);
    return r;
  }
  const float cos_im = glm::dot(wi, wm);
  const float denom = sqr(cos_im + cos_om / etap);
  if (!(denom > 0.f)) return r;
  if constexpr (kF) {
    const float dg = d * ggx_g2_over_cos2(wo, wi, alpha);
    const float f = dg * (1.f - F) * std::abs(cos_im * cos_om) / (denom * etap * etap);
    r.f = Rgb(std::isfinite(f) ? f : 0.f);
  }
  if constexpr (kPdf) {
    const float pdf = ggx_vndf_pdf(wo, wm, d, alpha) * (1.f - F) * std::abs(cos_im) / denom;
    r.pdf = std::isfinite(pdf) ? pdf : 0.f;
  }
  return r;
}

inline bool dielectric_sample_up(Vec3 wo, float uc, Vec2 u, float alpha, float eta, TransportMode mode,
                                 BsdfSample& out) {
  const bool radiance = mode == TransportMode::Radiance;  // refraction scales radiance by 1/η², importance not
  if (!(wo.z > 0.f)) return false;
  if (effectively_smooth(alpha)) {
    const float F = fresnel_dielectric(wo.z, eta);
    Vec3 wt;
    if (uc < F || !refract(wo, Vec3(0.f, 0.f, 1.f), eta, wt)) {
      const Vec3 wi(-wo.x, -wo.y, wo.z);
      out = {wi, Rgb(F / wi.z), F, BsdfFlags::Reflection | BsdfFlags::Specular, 1.f};
      return F > 0.f;
    }
    if (!(wt.z < 0.f)) return false;
    float denom = -wt.z;
    if (radiance) denom = denom * eta * eta;
    out = {wt, Rgb((1.f - F) / denom), 1.f - F, BsdfFlags::Transmission | BsdfFlags::Specular, eta};
    return true;
  }
  const Vec3 wm = ggx_sample_vndf(wo, alpha, u);
  const float cos_om = glm::dot(wo, wm);
  if (!(cos_om > 0.f)) return false;
  const float F = fresnel_dielectric(cos_om, eta);
  const float d_wo = ggx_vndf_pdf(wo, wm, alpha);
  if (uc < F) {
    const Vec3 wi = reflect(-wo, wm);
    if (!(wi.z > 0.f)) return false;
    const float f = 0.25f * ggx_d(wm, alpha) * ggx_g2_over_cos2(wo, wi, alpha) * F;
    out = {wi, Rgb(f), d_wo * F / (4.f * cos_om), BsdfFlags::Reflection | BsdfFlags::Glossy, 1.f};
    return out.pdf > 0.f;
  }
  Vec3 wi;
  if (!refract(wo, wm, eta, wi) || !(wi.z < 0.f)) return false;
  const float cos_im = glm::dot(wi, wm);
  const float denom = sqr(cos_im + cos_om / eta);
  if (!(denom > 0.f)) return false;
  const float pdf = d_wo * (1.f - F) * std::abs(cos_im) / denom;
  const float f = ggx_d(wm, alpha) * ggx_g2_over_cos2(wo, wi, alpha) * (1.f - F) * std::abs(cos_im * cos_om) /
                  (radiance ? denom * eta * eta : denom);
  if (!(pdf > 0.f) || !std::isfinite(pdf) || !std::isfinite(f)) return false;
  out = {wi, Rgb(f), pdf, BsdfFlags::Transmission | BsdfFlags::Glossy, eta};
  return true;
}

// Relative index η = n_t/n_i for light leaving along wo's side.
inline float dielectric_eta(const Material& m, Vec3 wo) { return wo.z > 0.f ? m.ior : 1.f / m.ior; }

// f and pdf (BsdfValue) of the rough lobes; a smooth interface has none (only sample returns its Dirac lobes).
template <bool kF, bool kPdf>
[[gnu::noinline]] inline BsdfValue dielectric_value(const Material& m, Vec3 wo, Vec3 wi) {
  if (effectively_smooth(m.alpha) || wo.z == 0.f) return {};
  const float eta = dielectric_eta(m, wo);
  if (wo.z < 0.f) wo = flip_z(wo), wi = flip_z(wi);
  return dielectric_value_up<kF, kPdf>(wo, wi, m.alpha, eta);
}

inline bool dielectric_sample(const Material& m, Vec3 wo, float uc, Vec2 u, TransportMode mode, BsdfSample& out) {
  if (wo.z == 0.f) return false;
  const float eta = dielectric_eta(m, wo);
  const bool below = wo.z < 0.f;
  if (!dielectric_sample_up(below ? flip_z(wo) : wo, uc, u, m.alpha, eta, mode, out)) return false;
  if (below) out.wi = flip_z(out.wi);
  return true;
}

}  // namespace pt
