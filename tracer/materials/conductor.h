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
#include "core/lanes.h"
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

// The rough lobe's parameters, over T = float (one path) or vfloat (the SIMD shading lanes,
// integrators/shading_lanes.h, one material per lane): the formulas below are written once for both, so the lanes
// round as one path does. E(μ) is a table lookup (m.energy) the caller makes.
template <class T>
struct ConductorLobe {
  lanes::Vec3T<T> f0;      // Schlick's F0 (the albedo)
  lanes::Vec3T<T> eta, k;  // the complex index, where m.complex_ior
  lanes::Mask<T> complex;  // which Fresnel ConductorFresnel::Either takes: the complex index's (true) or Schlick's
  lanes::Vec3T<T> f_ms;    // F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg))
  T e_avg;                 // E_avg
  T alpha;
};
inline ConductorLobe<float> conductor_lobe(const Material& m) {
  const Rgb& fa = m.f_avg;
  const Rgb f_ms = fa * fa * m.energy.e_avg / (Rgb(1.f) - fa * (1.f - m.energy.e_avg));
  return {lanes::of(m.albedo), lanes::of(m.eta), lanes::of(m.k), m.complex_ior, lanes::of(f_ms), m.energy.e_avg, m.alpha};
}

// Which Fresnel: Schlick's through F0, the complex index's, or (for lanes holding both) each lane's own.
enum class ConductorFresnel { Schlick, Complex, Either };
template <ConductorFresnel kC, class T>
[[gnu::always_inline]] inline lanes::Vec3T<T> conductor_fresnel(const ConductorLobe<T>& g, const T& cos_theta) {
  lanes::Vec3T<T> s{}, c{};
  if constexpr (kC != ConductorFresnel::Complex)
    s = {fresnel_schlick(g.f0.x, cos_theta), fresnel_schlick(g.f0.y, cos_theta), fresnel_schlick(g.f0.z, cos_theta)};
  if constexpr (kC != ConductorFresnel::Schlick)
    c = {fresnel_complex(cos_theta, g.eta.x, g.k.x), fresnel_complex(cos_theta, g.eta.y, g.k.y),
         fresnel_complex(cos_theta, g.eta.z, g.k.z)};
  if constexpr (kC == ConductorFresnel::Schlick) return s;
  else if constexpr (kC == ConductorFresnel::Complex) return c;
  else return {select(g.complex, c.x, s.x), select(g.complex, c.y, s.y), select(g.complex, c.z, s.z)};
}

// Probability of sampling the multiple-scattering (cosine) lobe, from E_avg and E(μo) = e_o.
template <class T>
[[gnu::always_inline]] inline T conductor_ms_prob(const T& e_avg, const T& e_o) {
  return select(e_avg < 1.f, lanes::std_clamp(1.f - e_o, T(0.f), T(1.f)), T(0.f));
}

// f (kF) and pdf (kPdf) of the rough lobes for wo.z > 0 and wi.z > 0, given E(μo) = e_o and E(μi) = e_i (read by
// kF alone): the half vector and D computed once. f_ms is 0 where 1 − E_avg ≤ 10⁻⁶.
template <ConductorFresnel kC, bool kF, bool kPdf, class T>
[[gnu::always_inline]] inline void conductor_lobe_value(const ConductorLobe<T>& g, const T& e_o, const T& e_i,
                                                        const lanes::Vec3T<T>& wo, const lanes::Vec3T<T>& wi,
                                                        lanes::Vec3T<T>& f, T& pdf) {
  const HalfVectorD<T> half = half_vector_d(wo, wi, g.alpha, lanes::Mask<T>(true));
  const lanes::Mask<T> has_half = half.ok;
  const lanes::Vec3T<T>& wm = half.wm;
  const T& d = half.d;
  if constexpr (kF) {
    const T one_minus_e_avg = 1.f - g.e_avg;
    const lanes::Mask<T> ms = one_minus_e_avg > 1e-6f;
    const T s = ((1.f - e_o) * (1.f - e_i)) / (kPi * one_minus_e_avg);
    f = {select(ms, g.f_ms.x * s, T(0.f)), select(ms, g.f_ms.y * s, T(0.f)), select(ms, g.f_ms.z * s, T(0.f))};
    const T d_v = d * 0.25f * ggx_g2_over_cos2(wo.x, wo.y, wo.z, wi.x, wi.y, wi.z, g.alpha);
    const lanes::Vec3T<T> F = conductor_fresnel<kC>(g, lanes::dot(wo, wm));
    f = {select(has_half, f.x + d_v * F.x, f.x), select(has_half, f.y + d_v * F.y, f.y),
         select(has_half, f.z + d_v * F.z, f.z)};
  }
  if constexpr (kPdf) {
    const T p_ms = conductor_ms_prob(g.e_avg, e_o);
    // ggx_reflection_pdf: G1(wo) D/(4|wo.z|) where wo·wm > 0.
    const T reflection = select(lanes::dot(wo, wm) > 0.f, 0.25f * ggx_g1_over_cos(wo.x, wo.y, wo.z, g.alpha) * d,
                                T(0.f));
    const T p_ss = select(has_half, reflection, T(0.f));
    pdf = (1.f - p_ms) * p_ss + p_ms * cosine_hemisphere_pdf(wi.z);
  }
}

// The same for one path (BsdfValue), given E(μo) = e_o (a sample has it from its lobe choice).
template <bool kF, bool kPdf>
inline BsdfValue conductor_value_at(const Material& m, float e_o, Vec3 wo, Vec3 wi) {
  const ConductorLobe<float> g = conductor_lobe(m);
  const float e_i = kF ? m.energy(wi.z) : 0.f;
  lanes::Vec3T<float> f{0.f, 0.f, 0.f};
  float pdf = 0.f;
  if (m.complex_ior)
    conductor_lobe_value<ConductorFresnel::Complex, kF, kPdf>(g, e_o, e_i, lanes::of(wo), lanes::of(wi), f, pdf);
  else
    conductor_lobe_value<ConductorFresnel::Schlick, kF, kPdf>(g, e_o, e_i, lanes::of(wo), lanes::of(wi), f, pdf);
  return {lanes::to_vec3(f), pdf};
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
    const Rgb F = m.complex_ior ? fresnel_complex(wo.z, m.eta, m.k) : fresnel_schlick(m.albedo, wo.z);
    if (is_black(F)) return false;
    out = {wi, F / wi.z, 1.f, BsdfFlags::Reflection | BsdfFlags::Specular, 1.f};
    return true;
  }
  const float e_o = m.energy(wo.z);
  Vec3 wi;
  if (uc < conductor_ms_prob(m.energy.e_avg, e_o)) {
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
