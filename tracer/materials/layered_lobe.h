// A diffuse base under a rough specular layer, coupled by albedo scaling (Kelemen & Szirmay-Kalos 2001, "A
// Microfacet Based Coupled Specular-Matte BRDF Model with Importance Sampling"; Kulla & Conty 2017, slide 18):
//   f(wo, wi) = F(wo·wm) D(wm) G2(wo, wi) / (4 μo μi) + diffuse/π · (1 − E(μo))(1 − E(μi)) / (1 − E_avg)
// where E(μ) is the directional albedo of the layer's reflection lobe and E_avg = 2∫E(μ)μ dμ (the caller looks E
// up: each material has its own table). Two materials are this lobe, differing only in the layer's Fresnel:
// - the plastic (plastic.h): the exact dielectric Fresnel of its coat, F(wo·wm, η) (fresnel.h), one value for
//   all three channels;
// - glTF's metallic–roughness (metallic_roughness.h): Schlick's F through an RGB f0 at |wo·wm| (the glTF
//   specification, B.3.4), which also carries the metal.
// Sampling chooses the layer with probability p = s/(s + lum(diffuse)(1 − E(μo))), each lobe's share of the
// energy reflected at wo: s = E(μo) for the plastic, s = lum(F(μo)) clamped to [0, 1] for glTF (p = 1 where the
// denominator is 0); the pdf is the matching mixture of the visible-normal reflection density and the cosine
// hemisphere.
//
// Written once over the number type T (float for one path, vfloat for the SIMD shading lanes of
// integrators/shading_lanes.h, core/lanes.h), so that the lanes round exactly as the scalar lobes do. LayerFresnel
// picks the Fresnel at compile time; the lanes, which may hold both materials side by side, take `Either`, which
// computes both and selects per lane by `dielectric`.
#pragma once
#include "core/lanes.h"
#include "materials/fresnel.h"
#include "materials/microfacet.h"
#include "sampling/sampling.h"

namespace pt {

enum class LayerFresnel { Schlick, Dielectric, Either };

// What the lobe reads of a material (one per lane for vfloat).
template <class T>
struct LayeredLobe {
  lanes::Vec3T<T> f0;          // Schlick's f0 (glTF: gltf_f0)
  T eta;                       // the dielectric coat's index (the plastic's ior)
  lanes::Mask<T> dielectric;   // which Fresnel `Either` takes: the coat's (true) or Schlick's
  lanes::Vec3T<T> diffuse;     // the base's colour (the plastic's albedo; glTF's gltf_diffuse_colour)
  T diffuse_lum;               // max(luminance(diffuse), 0): the base's share in the lobe choice
  T one_minus_avg;             // 1 − E_avg
  T alpha;                     // GGX α
};

// Schlick's F through f0 at |cos θ| (clamped to 1): glTF's (B.3.4).
template <class T>
[[gnu::always_inline]] inline lanes::Vec3T<T> gltf_fresnel(const lanes::Vec3T<T>& f0, const T& cos_theta) {
  const T c = 1.f - lanes::std_clamp(lanes::abs(cos_theta), T(0.f), T(1.f));
  const T c2 = c * c;
  const T k = c2 * c2 * c;
  return {f0.x + (1.f - f0.x) * k, f0.y + (1.f - f0.y) * k, f0.z + (1.f - f0.z) * k};
}

// The layer's Fresnel at wo·wm.
template <LayerFresnel kC, class T>
[[gnu::always_inline]] inline lanes::Vec3T<T> layer_fresnel(const LayeredLobe<T>& g, const T& cos_om) {
  if constexpr (kC == LayerFresnel::Schlick) return gltf_fresnel(g.f0, cos_om);
  const T fd = fresnel_dielectric(cos_om, g.eta);
  if constexpr (kC == LayerFresnel::Dielectric) {
    return {fd, fd, fd};
  } else {
    const lanes::Vec3T<T> fs = gltf_fresnel(g.f0, cos_om);
    return {select(g.dielectric, fd, fs.x), select(g.dielectric, fd, fs.y), select(g.dielectric, fd, fs.z)};
  }
}

// p, the layer's probability in the lobe choice at μo, given E(μo) = e_o.
template <LayerFresnel kC, class T>
[[gnu::always_inline]] inline T layer_prob(const LayeredLobe<T>& g, const T& cos_o, const T& e_o) {
  T s = e_o;
  if constexpr (kC != LayerFresnel::Dielectric) {
    const lanes::Vec3T<T> F = gltf_fresnel(g.f0, cos_o);
    const T lum = (kLuminanceWeights[0] * F.x + kLuminanceWeights[1] * F.y) + kLuminanceWeights[2] * F.z;
    const T schlick = lanes::std_clamp(lum, T(0.f), T(1.f));
    if constexpr (kC == LayerFresnel::Schlick) s = schlick;
    else s = select(g.dielectric, e_o, schlick);
  }
  const T denom = s + g.diffuse_lum * (1.f - e_o);
  return select(denom > 0.f, s / denom, T(1.f));
}

// f (kF) and pdf (kPdf) for wo.z > 0 and wi.z > 0, given E(μo) = e_o and E(μi) = e_i (read by kF alone): the half
// vector and D computed once. The base is 0 where E_avg reaches 1; the layer's lobe is there where the half vector
// exists and the lobe is rough (α ≥ kSmoothAlpha: a smooth layer's Dirac peak is the caller's).
template <LayerFresnel kC, bool kF, bool kPdf, class T>
[[gnu::always_inline]] inline void layered_value(const LayeredLobe<T>& g, const T& e_o, const T& e_i,
                                                 const lanes::Vec3T<T>& wo, const lanes::Vec3T<T>& wi,
                                                 lanes::Vec3T<T>& f, T& pdf) {
  const lanes::Mask<T> smooth = g.alpha < kSmoothAlpha;  // effectively_smooth(α)
  const HalfVectorD<T> half = half_vector_d(wo, wi, g.alpha, !smooth);
  const lanes::Mask<T> rough = half.ok;
  const lanes::Vec3T<T>& wm = half.wm;
  const T& d = half.d;
  if constexpr (kF) {
    const T s = ((1.f - e_o) * (1.f - e_i)) / g.one_minus_avg;
    const lanes::Mask<T> base = g.one_minus_avg > 0.f;
    const T k_base = kInvPi * s;
    f = {select(base, g.diffuse.x * k_base, T(0.f)), select(base, g.diffuse.y * k_base, T(0.f)),
         select(base, g.diffuse.z * k_base, T(0.f))};
    const lanes::Vec3T<T> F = layer_fresnel<kC>(g, lanes::dot(wo, wm));
    const T k = 0.25f * d * ggx_g2_over_cos2(wo.x, wo.y, wo.z, wi.x, wi.y, wi.z, g.alpha);
    f = {select(rough, f.x + F.x * k, f.x), select(rough, f.y + F.y * k, f.y), select(rough, f.z + F.z * k, f.z)};
  }
  if constexpr (kPdf) {
    const T p = layer_prob<kC>(g, wo.z, e_o);
    pdf = (1.f - p) * cosine_hemisphere_pdf(wi.z);
    // ggx_reflection_pdf: G1(wo) D/(4|wo.z|) where wo·wm > 0.
    const T reflection = select(lanes::dot(wo, wm) > 0.f,
                                0.25f * ggx_g1_over_cos(wo.x, wo.y, wo.z, g.alpha) * d, T(0.f));
    pdf = select(rough, pdf + p * reflection, pdf);
  }
}

}  // namespace pt
