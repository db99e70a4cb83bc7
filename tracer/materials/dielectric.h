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
#include <type_traits>

#include "core/lanes.h"
#include "core/simd_sqrt_warnings.h"
#include "materials/bsdf_sample.h"
#include "materials/fresnel.h"
#include "materials/microfacet.h"

namespace pt {

inline Vec3 flip_z(Vec3 v) { return {v.x, v.y, -v.z}; }

PT_SIMD_SQRT_WARNINGS_OFF  // the templates below run on SIMD lanes too (every lane computed)
// The rough lobe's f (kF; colourless, radiance) and pdf (kPdf) at (wo, wi) for wo.z > 0 and the relative index eta,
// over T = float (one path) or vfloat (the SIMD shading lanes, integrators/lane_lobes.h, one material per lane):
// written once, so that both round alike. Every lane computes both sides and selects its own. The generalized half
// vector wm = ±normalize(etap wi + wo) (etap = 1 on reflection, η on transmission) faces +z; a lane gets 0 where
// wi.z = 0, the half vector is degenerate or back-facing (pbrt-v4 DielectricBxDF::f), the transmission's
// denominator vanishes or its terms are not finite.
template <bool kF, bool kPdf, class T>
[[gnu::always_inline]] inline void dielectric_lobe_value(const lanes::Vec3T<T>& wo, const lanes::Vec3T<T>& wi,
                                                         const T& alpha, const T& eta, T& f, T& pdf) {
  using lanes::abs;
  const lanes::Mask<T> reflects = wi.z > 0.f;
  const T etap = select(reflects, T(1.f), eta);
  const lanes::Vec3T<T> h{wi.x * etap + wo.x, wi.y * etap + wo.y, wi.z * etap + wo.z};
  const T len2 = lanes::dot(h, h);
  const T len = lanes::sqrt(len2);
  lanes::Vec3T<T> wm{h.x / len, h.y / len, h.z / len};
  const lanes::Mask<T> down = wm.z < 0.f;
  wm = {select(down, -wm.x, wm.x), select(down, -wm.y, wm.y), select(down, -wm.z, wm.z)};
  const T cos_om = lanes::dot(wo, wm), cos_im = lanes::dot(wi, wm);
  const T denom = (cos_im + cos_om / etap) * (cos_im + cos_om / etap);
  const lanes::Mask<T> ok = wo.z > 0.f && wi.z != 0.f && len2 > 0.f && cos_im * wi.z >= 0.f && cos_om > 0.f &&
                            (reflects || denom > 0.f);
  const T F = fresnel_dielectric(cos_om, eta);
  const T d = ggx_d(wm.x, wm.y, wm.z, alpha);
  if constexpr (kF) {
    const T dg = d * ggx_g2_over_cos2(wo.x, wo.y, wo.z, wi.x, wi.y, wi.z, alpha);
    const T fr = 0.25f * dg * F;
    const T ft = dg * (1.f - F) * abs(cos_im * cos_om) / (denom * etap * etap);
    f = select(ok, select(reflects, fr, select(lanes::isfinite(ft), ft, T(0.f))), T(0.f));
  }
  if constexpr (kPdf) {  // ggx_vndf_pdf: G1(wo)/|wo.z| · max(0, wo·wm) · D
    const T vndf = ggx_g1_over_cos(wo.x, wo.y, wo.z, alpha) * lanes::std_max(T(0.f), cos_om) * d;
    const T pr = vndf * F / (4.f * cos_om);
    const T pt = vndf * (1.f - F) * abs(cos_im) / denom;
    pdf = select(ok, select(reflects, pr, select(lanes::isfinite(pt), pt, T(0.f))), T(0.f));
  }
}

// The rough lobe's sample at the visible normal wm = ggx_sample_vndf(wo, α, u) for wo.z > 0: the reflection about
// wm where uc < F(wo·wm), else the refraction through it (`refracts`); its f (colourless; `radiance`: with the 1/η²
// of the formulas above) and pdf, from the sampled wm itself (pbrt-v4 DielectricBxDF::Sample_f). Over T as above.
// The mask: a sample (wi on its lobe's side, a positive finite pdf, a finite f).
template <class T>
[[gnu::always_inline]] inline lanes::Mask<T> dielectric_lobe_sample(const lanes::Vec3T<T>& wo,
                                                                    const lanes::Vec3T<T>& wm, const T& uc,
                                                                    const T& alpha, const T& eta, bool radiance,
                                                                    lanes::Vec3T<T>& wi, T& f, T& pdf,
                                                                    lanes::Mask<T>& refracts) {
  using lanes::abs;
  const T cos_om = lanes::dot(wo, wm);
  const T F = fresnel_dielectric(cos_om, eta);
  const T d = ggx_d(wm.x, wm.y, wm.z, alpha);
  const T d_wo = ggx_g1_over_cos(wo.x, wo.y, wo.z, alpha) * lanes::std_max(T(0.f), cos_om) * d;  // ggx_vndf_pdf
  const lanes::Mask<T> reflects = uc < F;
  // reflect(−wo, wm) = −wo − 2(−wo·wm) wm, as glm evaluates it.
  const lanes::Vec3T<T> v{-wo.x, -wo.y, -wo.z};
  const T twice = 2.f * lanes::dot(v, wm);
  wi = {v.x - twice * wm.x, v.y - twice * wm.y, v.z - twice * wm.z};
  lanes::Vec3T<T> wt = wi;
  lanes::Mask<T> through(false);
  if constexpr (std::is_same_v<T, float>) {
    if (!reflects) through = refract_t(wo, wm, eta, wt);  // one path refracts only where it does not reflect
  } else {
    through = refract_t(wo, wm, eta, wt);
  }
  refracts = !reflects;
  wi = {select(reflects, wi.x, wt.x), select(reflects, wi.y, wt.y), select(reflects, wi.z, wt.z)};
  const T g2 = ggx_g2_over_cos2(wo.x, wo.y, wo.z, wi.x, wi.y, wi.z, alpha);
  const T cos_im = lanes::dot(wi, wm);
  const T denom = (cos_im + cos_om / eta) * (cos_im + cos_om / eta);
  const T pr = d_wo * F / (4.f * cos_om);
  const T pt = d_wo * (1.f - F) * abs(cos_im) / denom;
  const T fr = 0.25f * d * g2 * F;
  const T ft = d * g2 * (1.f - F) * abs(cos_im * cos_om) / (radiance ? denom * eta * eta : denom);
  f = select(reflects, fr, ft);
  pdf = select(reflects, pr, pt);
  const lanes::Mask<T> ok_r = wi.z > 0.f && pr > 0.f;
  const lanes::Mask<T> ok_t = through && wi.z < 0.f && denom > 0.f && pt > 0.f && lanes::isfinite(pt) &&
                              lanes::isfinite(ft);
  return cos_om > 0.f && ((reflects && ok_r) || (!reflects && ok_t));
}
PT_SIMD_SQRT_WARNINGS_ON

// f (kF) and pdf (kPdf) of the rough lobe for wo.z > 0 (BsdfValue).
template <bool kF, bool kPdf>
inline BsdfValue dielectric_value_up(Vec3 wo, Vec3 wi, float alpha, float eta) {
  BsdfValue r;
  float f = 0.f, pdf = 0.f;
  dielectric_lobe_value<kF, kPdf>(lanes::of(wo), lanes::of(wi), alpha, eta, f, pdf);
  if constexpr (kF) r.f = Rgb(f);
  if constexpr (kPdf) r.pdf = pdf;
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
  lanes::Vec3T<float> wi;
  float f = 0.f, pdf = 0.f;
  bool refracts = false;
  if (!dielectric_lobe_sample(lanes::of(wo), lanes::of(ggx_sample_vndf(wo, alpha, u)), uc, alpha, eta, radiance, wi,
                              f, pdf, refracts))
    return false;
  const BsdfFlags side = refracts ? BsdfFlags::Transmission : BsdfFlags::Reflection;
  out = {lanes::to_vec3(wi), Rgb(f), pdf, side | BsdfFlags::Glossy, refracts ? eta : 1.f};
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
