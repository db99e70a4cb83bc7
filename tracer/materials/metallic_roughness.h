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
#include "materials/layered_lobe.h"
#include "materials/microfacet.h"
#include "sampling/sampling.h"

namespace pt {

// The dielectric's normal-incidence reflectance ((η − 1)/(η + 1))² (0.04 at the default index 1.5).
inline float gltf_dielectric_f0(float ior) { return sqr((ior - 1.f) / (ior + 1.f)); }

inline Rgb gltf_f0(const Material& m) { return glm::mix(Rgb(gltf_dielectric_f0(m.ior)), m.albedo, m.metallic); }
inline Rgb gltf_diffuse_colour(const Material& m) { return m.albedo * (1.f - m.metallic); }

// Schlick's F through f0 (gltf_fresnel) is layered_lobe.h's, whose lobe this is: the formulas there are written
// once for one path and for the SIMD shading lanes (integrators/shading_lanes.h). The layer's albedo E_d is a table
// lookup the caller makes (gltf_layer_albedo).
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

// A material's lobe for one path; the average only where asked for (a table lookup).
inline LayeredLobe<float> gltf_lobe(const Material& m, Rgb f0, bool with_avg = true) {
  const Rgb diffuse = gltf_diffuse_colour(m);
  return {lanes::of(f0), 1.f, false, lanes::of(diffuse), std::max(luminance(diffuse), 0.f),
          with_avg ? 1.f - gltf_layer_albedo_avg(m) : 0.f, m.alpha};
}

// The same for one path, given f0 = gltf_f0(m) and E_d(μo) = e_o (a sample has both from its lobe choice).
template <bool kF, bool kPdf>
inline BsdfValue metallic_roughness_value_at(const Material& m, Rgb f0, float e_o, Vec3 wo, Vec3 wi) {
  const LayeredLobe<float> g = gltf_lobe(m, f0, kF);
  const float e_i = kF ? gltf_layer_albedo(m, wi.z) : 0.f;
  lanes::Vec3T<float> f{0.f, 0.f, 0.f};
  float pdf = 0.f;
  layered_value<LayerFresnel::Schlick, kF, kPdf>(g, e_o, e_i, lanes::of(wo), lanes::of(wi), f, pdf);
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
  const float p_s = layer_prob<LayerFresnel::Schlick>(gltf_lobe(m, f0, false), wo.z, e_o);
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
