// Plastic: a Lambertian base (albedo) under a dielectric coat (index m.ior, GGX roughness), coupled as in Kelemen &
// Szirmay-Kalos 2001, "A Microfacet Based Coupled Specular-Matte BRDF Model with Importance Sampling"
// (Eurographics short presentations): layered_lobe.h's lobe with the coat's exact Fresnel,
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
#include "materials/layered_lobe.h"
#include "materials/microfacet.h"
#include "sampling/sampling.h"

namespace pt {

inline float plastic_coat_albedo(const Material& m, float cos_theta) {
  return effectively_smooth(m.alpha) ? fresnel_dielectric(cos_theta, m.ior) : m.energy(cos_theta);
}

// The coupled lobe of layered_lobe.h with the coat's exact Fresnel: its f and pdf are written there once for one
// path and for the SIMD shading lanes (integrators/shading_lanes.h).
inline LayeredLobe<float> plastic_lobe(const Material& m) {
  return {{0.f, 0.f, 0.f}, m.ior, true, lanes::of(m.albedo), std::max(luminance(m.albedo), 0.f),
          1.f - m.energy.e_avg, m.alpha};
}

// f (kF) and pdf (kPdf) (BsdfValue) for wo.z > 0 and wi.z > 0, given E_c(μo) = ec_o (a sample has it from its
// lobe choice).
template <bool kF, bool kPdf>
inline BsdfValue plastic_value_at(const Material& m, float ec_o, Vec3 wo, Vec3 wi) {
  const float ec_i = kF ? plastic_coat_albedo(m, wi.z) : 0.f;
  lanes::Vec3T<float> f{0.f, 0.f, 0.f};
  float pdf = 0.f;
  layered_value<LayerFresnel::Dielectric, kF, kPdf>(plastic_lobe(m), ec_o, ec_i, lanes::of(wo), lanes::of(wi), f, pdf);
  return {lanes::to_vec3(f), pdf};
}

// The same for any directions (0 below the surface).
template <bool kF, bool kPdf>
[[gnu::noinline]] inline BsdfValue plastic_value(const Material& m, Vec3 wo, Vec3 wi) {
  if (!(wo.z > 0.f) || !(wi.z > 0.f)) return {};
  return plastic_value_at<kF, kPdf>(m, plastic_coat_albedo(m, wo.z), wo, wi);
}

inline Rgb plastic_eval(const Material& m, Vec3 wo, Vec3 wi) { return plastic_value<true, false>(m, wo, wi).f; }
inline float plastic_pdf(const Material& m, Vec3 wo, Vec3 wi) { return plastic_value<false, true>(m, wo, wi).pdf; }

inline bool plastic_sample(const Material& m, Vec3 wo, float uc, Vec2 u, BsdfSample& out) {
  if (!(wo.z > 0.f)) return false;
  const float ec_o = plastic_coat_albedo(m, wo.z);
  const float p_c = layer_prob<LayerFresnel::Dielectric>(plastic_lobe(m), wo.z, ec_o);
  const bool coat = uc < p_c;
  if (effectively_smooth(m.alpha) && coat) {
    const Vec3 wi(-wo.x, -wo.y, wo.z);
    const float F = fresnel_dielectric(wo.z, m.ior);
    out = {wi, Rgb(F / wi.z), p_c, BsdfFlags::Reflection | BsdfFlags::Specular, 1.f};
    return F > 0.f;
  }
  const Vec3 wi = coat ? reflect(-wo, ggx_sample_vndf(wo, m.alpha, u)) : sample_cosine_hemisphere(u);
  if (!(wi.z > 0.f)) return false;
  const BsdfValue v = plastic_value_at<true, true>(m, ec_o, wo, wi);
  if (!(v.pdf > 0.f)) return false;
  out = {wi, v.f, v.pdf, BsdfFlags::Reflection | (coat ? BsdfFlags::Glossy : BsdfFlags::Diffuse), 1.f};
  return true;
}

}  // namespace pt
