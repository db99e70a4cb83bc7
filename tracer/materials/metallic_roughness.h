// glTF 2.0's metallic–roughness material (The Khronos Group, "glTF 2.0 Specification", Appendix B "BRDF
// Implementation", B.3.5 "Complete Model"), with KHR_materials_ior's index:
//   material   = mix(dielectric, metal, metallic)
//   metal      = F_m(wo·wm) D(wm) V(wo, wi),           F_m Schlick through f0 = baseColor
//   dielectric = base + F_d(wo·wm) D(wm) V(wo, wi),    F_d Schlick through f0_d = ((ior − 1)/(ior + 1))²  (0.04)
// with GGX D, the height-correlated Smith V = G2/(4|cos θo cos θi|) (B.3.2–B.3.3; microfacet.h: D = ggx_d, 4V =
// ggx_g2_over_cos2), Schlick's F = f0 + (1 − f0)(1 − |wo·wm|)⁵ (B.3.4) and α = roughness². F is linear in f0, so
// the two specular lobes add up to one, F D V with f0 = lerp(f0_d, baseColor, metallic), exactly as the
// specification writes it.
//
// One departure, the diffuse base under the dielectric's specular layer. The specification weights it by
// 1 − F_d(wo·wm) (its fresnel_mix), which is not energy conserving: measured with the quadrature of
// tests/test_materials.cpp, a white base reflects 1.03 of the light arriving at 60°, 1.20 at 75° and 1.59 at
// 85° (roughness 0), and 1.07 at 85° even at roughness 0.6. Here the base is coupled to the layer by albedo
// scaling (Kelemen & Szirmay-Kalos 2001; Kulla & Conty 2017, slide 18), as the plastic is (plastic.h):
//   base = (1 − metallic) baseColor/π · (1 − E_d(μo))(1 − E_d(μi)) / (1 − E_d,avg)
// where E_d(μ) is the directional albedo of the layer F_d D V (energy_tables.h: SchlickAlbedoTable) and E_d,avg
// = 2∫E_d(μ)μ dμ. It integrates to baseColor (1 − E_d(μo)), so the dielectric reflects E_d(μo) + baseColor
// (1 − E_d(μo)) ≤ 1 (exactly 1 for a white base), and it is reciprocal. At normal incidence it is within a few
// percent of the specification's 1 − F weight; at grazing angles it is darker where the specification creates
// energy. Like the specification: single scattering only (a rough metal loses what a real one reflects after
// several microfacet bounces, ~40 % for a white metal at roughness 1 and normal incidence, as in every glTF
// viewer). Roughness < ~0.03 (α < kSmoothAlpha) is the smooth limit: a Dirac lobe of weight F(cos θo) and
// E_d = F_d exactly (pbrt-v4's rule for near-smooth microfacets).
//
// Sampling: visible-normal reflection (Heitz 2018) with probability p_s = F̄/(F̄ + lum(c_diff)(1 − E_d(μo))),
// F̄ = lum(F(cos θo)), c_diff = (1 − metallic) baseColor (each lobe's share of the energy at wo), else the
// cosine hemisphere; pdf is the matching mixture and rough samples return the full f and pdf.
// Reflection-only and two-sided: wo.z ≥ 0 on entry (bsdf.h mirrors to the front).
#pragma once
#include "core/lanes.h"
#include "materials/bsdf_sample.h"
#include "materials/energy_tables.h"
#include "materials/microfacet.h"
#include "sampling/sampling.h"

namespace pt {

// The dielectric's normal-incidence reflectance ((η − 1)/(η + 1))² (0.04 at the default index 1.5).
inline float gltf_dielectric_f0(float ior) { return sqr((ior - 1.f) / (ior + 1.f)); }

inline Rgb gltf_f0(const Material& m) { return glm::mix(Rgb(gltf_dielectric_f0(m.ior)), m.albedo, m.metallic); }
inline Rgb gltf_diffuse_colour(const Material& m) { return m.albedo * (1.f - m.metallic); }

// What the lobe reads of the material, over T = float or vfloat (core/lanes.h): the formulas below are written
// once for one path and for the SIMD shading lanes (integrators/shading_lanes.h), which take one material per
// lane and must round alike. The layer's albedo E_d is a table lookup the caller makes (gltf_layer_albedo).
template <class T>
struct GltfLobe {
  lanes::Vec3T<T> f0;       // gltf_f0
  lanes::Vec3T<T> diffuse;  // gltf_diffuse_colour
  T diffuse_lum;            // max(luminance(diffuse), 0): the diffuse lobe's share in the sampling choice
  T one_minus_avg;          // 1 − E_d,avg (gltf_layer_albedo_avg)
  T alpha;
};
// Schlick's F through f0 at |cos θ| (clamped to 1).
template <class T>
[[gnu::always_inline]] inline lanes::Vec3T<T> gltf_fresnel(const lanes::Vec3T<T>& f0, const T& cos_theta) {
  const T c = 1.f - lanes::std_clamp(lanes::abs(cos_theta), T(0.f), T(1.f));
  const T c2 = c * c;
  const T k = c2 * c2 * c;
  return {f0.x + (1.f - f0.x) * k, f0.y + (1.f - f0.y) * k, f0.z + (1.f - f0.z) * k};
}
inline Rgb gltf_fresnel(Rgb f0, float cos_theta) { return lanes::to_vec3(gltf_fresnel(lanes::of(f0), cos_theta)); }

// E_d(μ): the directional albedo of the dielectric's specular layer (exactly F_d(μ) when smooth), and its
// cosine-weighted average.
inline float gltf_layer_albedo(const Material& m, float mu) {
  const float f0 = gltf_dielectric_f0(m.ior);
  if (effectively_smooth(m.alpha)) return gltf_fresnel(Rgb(f0), mu).x;
  return ggx_schlick_albedo_table().e(f0, m.roughness, mu);
}
inline float gltf_layer_albedo_avg(const Material& m) {
  const float f0 = gltf_dielectric_f0(m.ior);
  if (effectively_smooth(m.alpha)) return f0 + (1.f - f0) * (1.f / 21.f);  // 2∫F(μ)μ dμ (fresnel_schlick_avg)
  return ggx_schlick_albedo_table().e_avg(f0, m.roughness);
}

// A material's lobe for one path; the averages only where asked for (each is a table lookup).
inline GltfLobe<float> gltf_lobe(const Material& m, Rgb f0, bool with_avg = true) {
  const Rgb diffuse = gltf_diffuse_colour(m);
  return {lanes::of(f0), lanes::of(diffuse), std::max(luminance(diffuse), 0.f),
          with_avg ? 1.f - gltf_layer_albedo_avg(m) : 0.f, m.alpha};
}

// p_s at μo, given E_d(μo) = e_o.
template <class T>
[[gnu::always_inline]] inline T gltf_specular_prob(const GltfLobe<T>& g, const T& cos_o, const T& e_o) {
  const lanes::Vec3T<T> F = gltf_fresnel(g.f0, cos_o);
  const T lum = (kLuminanceWeights[0] * F.x + kLuminanceWeights[1] * F.y) + kLuminanceWeights[2] * F.z;
  const T fs = lanes::std_clamp(lum, T(0.f), T(1.f));
  const T denom = fs + g.diffuse_lum * (1.f - e_o);
  return select(denom > 0.f, fs / denom, T(1.f));
}

// f (kF) and pdf (kPdf) for wo.z > 0 and wi.z > 0, given E_d(μo) = e_o and E_d(μi) = e_i (read by kF alone): the
// half vector and D computed once. The base is (1 − metallic) baseColor/π · (1 − E_d(μo))(1 − E_d(μi))/(1 − E_d,avg)
// (0 where the average reaches 1); the specular lobe F D V where the half vector exists and the lobe is rough.
template <bool kF, bool kPdf, class T>
[[gnu::always_inline]] inline void gltf_value(const GltfLobe<T>& g, const T& e_o, const T& e_i,
                                              const lanes::Vec3T<T>& wo, const lanes::Vec3T<T>& wi,
                                              lanes::Vec3T<T>& f, T& pdf) {
  const lanes::Vec3T<T> h{wo.x + wi.x, wo.y + wi.y, wo.z + wi.z};
  const T h2 = lanes::dot(h, h);
  const lanes::Mask<T> rough = !(g.alpha < kSmoothAlpha) && h2 > 0.f;  // !effectively_smooth(α)
  const T inv = 1.f / lanes::sqrt(h2);  // glm::normalize: h · (1/√(h·h))
  const lanes::Vec3T<T> wm{select(rough, h.x * inv, T(0.f)), select(rough, h.y * inv, T(0.f)),
                           select(rough, h.z * inv, T(1.f))};
  const T d = select(rough, ggx_d(wm.x, wm.y, wm.z, g.alpha), T(0.f));
  if constexpr (kF) {
    const T s = ((1.f - e_o) * (1.f - e_i)) / g.one_minus_avg;
    const lanes::Mask<T> base = g.one_minus_avg > 0.f;
    const T k_base = kInvPi * s;
    f = {select(base, g.diffuse.x * k_base, T(0.f)), select(base, g.diffuse.y * k_base, T(0.f)),
         select(base, g.diffuse.z * k_base, T(0.f))};
    const lanes::Vec3T<T> F = gltf_fresnel(g.f0, lanes::dot(wo, wm));
    const T k = 0.25f * d * ggx_g2_over_cos2(wo.x, wo.y, wo.z, wi.x, wi.y, wi.z, g.alpha);
    f = {select(rough, f.x + F.x * k, f.x), select(rough, f.y + F.y * k, f.y), select(rough, f.z + F.z * k, f.z)};
  }
  if constexpr (kPdf) {
    const T p_s = gltf_specular_prob(g, wo.z, e_o);
    pdf = (1.f - p_s) * cosine_hemisphere_pdf(wi.z);
    // ggx_reflection_pdf: G1(wo) D/(4|wo.z|) where wo·wm > 0.
    const T reflection = select(lanes::dot(wo, wm) > 0.f,
                                0.25f * ggx_g1_over_cos(wo.x, wo.y, wo.z, g.alpha) * d, T(0.f));
    pdf = select(rough, pdf + p_s * reflection, pdf);
  }
}

// The same for one path, given f0 = gltf_f0(m) and E_d(μo) = e_o (a sample has both from its lobe choice).
template <bool kF, bool kPdf>
inline BsdfValue metallic_roughness_value_at(const Material& m, Rgb f0, float e_o, Vec3 wo, Vec3 wi) {
  const GltfLobe<float> g = gltf_lobe(m, f0, kF);
  const float e_i = kF ? gltf_layer_albedo(m, wi.z) : 0.f;
  lanes::Vec3T<float> f{0.f, 0.f, 0.f};
  float pdf = 0.f;
  gltf_value<kF, kPdf>(g, e_o, e_i, lanes::of(wo), lanes::of(wi), f, pdf);
  return {lanes::to_vec3(f), pdf};
}

// The same for any directions (0 below the surface).
template <bool kF, bool kPdf>
[[gnu::noinline]] inline BsdfValue metallic_roughness_value(const Material& m, Vec3 wo, Vec3 wi) {
  if (!(wo.z > 0.f) || !(wi.z > 0.f)) return {};
  return metallic_roughness_value_at<kF, kPdf>(m, gltf_f0(m), gltf_layer_albedo(m, wo.z), wo, wi);
}

inline Rgb metallic_roughness_eval(const Material& m, Vec3 wo, Vec3 wi) {
  return metallic_roughness_value<true, false>(m, wo, wi).f;
}
inline float metallic_roughness_pdf(const Material& m, Vec3 wo, Vec3 wi) {
  return metallic_roughness_value<false, true>(m, wo, wi).pdf;
}

inline bool metallic_roughness_sample(const Material& m, Vec3 wo, float uc, Vec2 u, BsdfSample& out) {
  if (!(wo.z > 0.f)) return false;
  const Rgb f0 = gltf_f0(m);
  const float e_o = gltf_layer_albedo(m, wo.z);
  const float p_s = gltf_specular_prob(gltf_lobe(m, f0, false), wo.z, e_o);
  const bool specular = uc < p_s;
  if (specular && effectively_smooth(m.alpha)) {
    const Vec3 wi(-wo.x, -wo.y, wo.z);
    const Rgb F = gltf_fresnel(f0, wo.z);
    if (is_black(F)) return false;
    out = {wi, F / wi.z, p_s, BsdfFlags::Reflection | BsdfFlags::Specular, 1.f};
    return true;
  }
  const Vec3 wi = specular ? reflect(-wo, ggx_sample_vndf(wo, m.alpha, u)) : sample_cosine_hemisphere(u);
  if (!(wi.z > 0.f)) return false;
  const BsdfValue v = metallic_roughness_value_at<true, true>(m, f0, e_o, wo, wi);
  if (!(v.pdf > 0.f)) return false;
  out = {wi, v.f, v.pdf, BsdfFlags::Reflection | (specular ? BsdfFlags::Glossy : BsdfFlags::Diffuse), 1.f};
  return true;
}

}  // namespace pt
