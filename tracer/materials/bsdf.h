// The BSDF interface the integrator sees: flags, eval, pdf, sample — plain functions on a Material, in the
// local shading frame (z = the surface's front geometric normal). Directions point away from the surface.
// After pbrt-v4 (src/pbrt/base/bxdf.h: BxDFFlags; the integrator asks "is it specular? does it transmit?",
// never a type) and yocto-gl (yocto_shading.h: eval/sample/pdf triples as plain functions).
//
// Conventions (pbrt-v4 ch. 9):
// - eval returns f (sr⁻¹) without the cosine; pdf is per steradian; a sample's weight is f·|cos θi|/pdf.
// - Specular (delta) lobes are never returned by eval or pdf (their f is a Dirac); sample returns them with
//   flags containing BsdfFlags::Specular, f = (lobe weight)/|cos θi| and pdf = the lobe's selection probability.
// - Reflection-only materials are two-sided: they mirror wo to the front (wo.z > 0) and treat wi likewise;
//   dielectrics use the sign of wo.z to tell entering (outside, z > 0) from leaving.
// - Transmission carries radiance scaling 1/η² (non-symmetric transport, Veach 1997 §5.2); BsdfSample::eta is
//   the relative index n_t/n_i of the crossed interface (1 for reflection), for Russian roulette's η-scale.
//
// The functions below dispatch from the material type to its lobe (materials/*.h): the only place that names a
// material type besides material.cpp; the integrator sees flags only. Reflection-only lobes assume wo.z ≥ 0:
// when wo is below the surface both directions are mirrored in z first and the sampled direction is mirrored
// back, which makes those materials two-sided.
//
// Each function takes the material set it is compiled for (a template argument, like the kernels' geometry):
// with MaterialSet::Lambert, for scenes whose materials are all Lambertian (the Cornell box), the dispatch is
// compiled out and the path loop runs only the few instructions of the Lambert lobe; MaterialSet::Any serves
// every scene.
#pragma once
#include "materials/bsdf_sample.h"
#include "materials/conductor.h"
#include "materials/dielectric.h"
#include "materials/diffuse.h"
#include "materials/metallic_roughness.h"
#include "materials/plastic.h"
#include "materials/subsurface.h"

namespace pt {

enum class MaterialSet { Lambert, Any };

// True when the material is the Lambert lobe alone (what MaterialSet::Lambert may assume).
inline bool is_lambertian(const Material& m) { return m.type == MaterialType::Diffuse; }

namespace bsdf_detail {
inline Vec3 front(Vec3 w, bool flip) { return flip ? Vec3(w.x, w.y, -w.z) : w; }
}  // namespace bsdf_detail

// True when the BSDF has a lobe that eval/pdf can see (diffuse or glossy): light sampling makes sense there.
inline bool has_non_specular(BsdfFlags flags) { return any(flags & (BsdfFlags::Diffuse | BsdfFlags::Glossy)); }
inline bool is_specular(BsdfFlags flags) { return any(flags & BsdfFlags::Specular); }
// Only Dirac lobes (smooth mirror, smooth glass): nothing to connect to or evaluate, a direction is only drawn.
inline bool only_specular(BsdfFlags flags) { return is_specular(flags) && !has_non_specular(flags); }
inline bool is_transmissive(BsdfFlags flags) { return any(flags & BsdfFlags::Transmission); }
inline bool is_reflective(BsdfFlags flags) { return any(flags & BsdfFlags::Reflection); }

// The lobes this material has (a union over its lobes: plastic with a smooth coat is Specular|Diffuse).
template <MaterialSet S = MaterialSet::Any>
inline BsdfFlags bsdf_flags(const Material& m) {
  if constexpr (S == MaterialSet::Lambert) return BsdfFlags::Reflection | BsdfFlags::Diffuse;
  const bool smooth = effectively_smooth(m.alpha);
  switch (m.type) {
    case MaterialType::Diffuse:
      return BsdfFlags::Reflection | BsdfFlags::Diffuse;
    case MaterialType::Mirror:
      return BsdfFlags::Reflection | BsdfFlags::Specular;
    case MaterialType::Conductor:
      return BsdfFlags::Reflection | (smooth ? BsdfFlags::Specular : BsdfFlags::Glossy);
    case MaterialType::Dielectric:
      return BsdfFlags::Reflection | BsdfFlags::Transmission | (smooth ? BsdfFlags::Specular : BsdfFlags::Glossy);
    case MaterialType::Plastic:
      return BsdfFlags::Reflection | BsdfFlags::Diffuse | (smooth ? BsdfFlags::Specular : BsdfFlags::Glossy);
    case MaterialType::Subsurface:
      return BsdfFlags::Reflection | BsdfFlags::Diffuse;
    case MaterialType::MetallicRoughness:  // a full metal has no diffuse part
      return BsdfFlags::Reflection | (m.metallic < 1.f ? BsdfFlags::Diffuse : BsdfFlags::None) |
             (smooth ? BsdfFlags::Specular : BsdfFlags::Glossy);
  }
  return BsdfFlags::None;
}

// f(wo, wi) (kF) and the solid-angle density with which bsdf_sample produces wi from wo (kPdf) of the
// non-specular lobes (each weighted by its selection probability), in one pass (BsdfValue). bsdf_eval and
// bsdf_pdf below ask for one part; next-event estimation under MIS asks for both.
template <MaterialSet S = MaterialSet::Any, bool kF = true, bool kPdf = true>
inline BsdfValue bsdf_value(const Material& m, Vec3 wo, Vec3 wi) {
  BsdfValue r;
  if constexpr (S == MaterialSet::Lambert) {
    if (wo.z * wi.z > 0.f) {
      if constexpr (kF) r.f = diffuse_f(m.albedo);
      if constexpr (kPdf) r.pdf = cosine_hemisphere_pdf(std::abs(wi.z));
    }
    return r;
  }
  if (m.type == MaterialType::Dielectric) return dielectric_value<kF, kPdf>(m, wo, wi);
  const bool flip = wo.z < 0.f;
  wo = bsdf_detail::front(wo, flip);
  wi = bsdf_detail::front(wi, flip);
  switch (m.type) {
    case MaterialType::Diffuse:
      if constexpr (kF) r.f = diffuse_eval(m, wo, wi);
      if constexpr (kPdf) r.pdf = diffuse_pdf(wo, wi);
      break;
    case MaterialType::Mirror:
      break;
    case MaterialType::Conductor:
      return conductor_value<kF, kPdf>(m, wo, wi);
    case MaterialType::Plastic:
      return plastic_value<kF, kPdf>(m, wo, wi);
    case MaterialType::Subsurface:
      if constexpr (kF) r.f = subsurface_eval(m, wo, wi);
      if constexpr (kPdf) r.pdf = subsurface_pdf(wo, wi);
      break;
    case MaterialType::MetallicRoughness:
      return metallic_roughness_value<kF, kPdf>(m, wo, wi);
    case MaterialType::Dielectric:
      break;
  }
  return r;
}

// f(wo, wi) of the non-specular lobes.
template <MaterialSet S = MaterialSet::Any>
inline Rgb bsdf_eval(const Material& m, Vec3 wo, Vec3 wi) {
  return bsdf_value<S, true, false>(m, wo, wi).f;
}

// Solid-angle density with which bsdf_sample produces wi from wo (non-specular lobes only, each weighted by its
// selection probability).
template <MaterialSet S = MaterialSet::Any>
inline float bsdf_pdf(const Material& m, Vec3 wo, Vec3 wi) {
  return bsdf_value<S, false, true>(m, wo, wi).pdf;
}

// Samples wi from wo with uc (lobe choice) and u (direction). Returns false when no sample was produced
// (grazing, below the surface, zero albedo). `mode` says what the path carries: from the light side
// (importance) a refracted sample's f has no 1/η² (only dielectrics differ). eval and pdf are for radiance; the
// adjoint of eval for a light-side vertex is its transpose, bsdf_eval(m, wi, wo) (exact for every BSDF).
template <MaterialSet S = MaterialSet::Any>
inline bool bsdf_sample(const Material& m, Vec3 wo, float uc, Vec2 u, BsdfSample& out,
                        TransportMode mode = TransportMode::Radiance) {
  if constexpr (S == MaterialSet::Lambert) {
    if (!diffuse_sample(m, bsdf_detail::front(wo, wo.z < 0.f), u, out)) return false;
    out.wi = bsdf_detail::front(out.wi, wo.z < 0.f);
    return true;
  }
  if (m.type == MaterialType::Dielectric) return dielectric_sample(m, wo, uc, u, mode, out);
  const bool flip = wo.z < 0.f;
  wo = bsdf_detail::front(wo, flip);
  bool ok = false;
  switch (m.type) {
    case MaterialType::Diffuse:
      ok = diffuse_sample(m, wo, u, out);
      break;
    case MaterialType::Mirror:
      ok = mirror_sample(m, wo, out);
      break;
    case MaterialType::Conductor:
      ok = conductor_sample(m, wo, uc, u, out);
      break;
    case MaterialType::Plastic:
      ok = plastic_sample(m, wo, uc, u, out);
      break;
    case MaterialType::Subsurface:
      ok = subsurface_sample(m, wo, u, out);
      break;
    case MaterialType::MetallicRoughness:
      ok = metallic_roughness_sample(m, wo, uc, u, out);
      break;
    case MaterialType::Dielectric:
      break;
  }
  if (ok) out.wi = bsdf_detail::front(out.wi, flip);
  return ok;
}

// The denoising albedo (integrators/features.h): the colour a denoiser divides out and a compositor multiplies
// back, after Cycles' and Open Image Denoise's convention: the diffuse reflectance of diffuse, plastic (its base)
// and subsurface materials (R_d, the multiple-scattering reflectance); the hemispherical-average Fresnel
// reflectance of conductors (m.f_avg, Kulla & Conty 2017) and the tint of mirrors; 1 for colourless glass; the
// base colour of glTF's metallic–roughness (its diffuse colour and its metal's F0 alike).
template <MaterialSet S = MaterialSet::Any>
inline Rgb bsdf_albedo(const Material& m) {
  if constexpr (S == MaterialSet::Lambert) return m.albedo;
  switch (m.type) {
    case MaterialType::Diffuse:
    case MaterialType::Mirror:
    case MaterialType::Plastic:
    case MaterialType::MetallicRoughness:
      return m.albedo;
    case MaterialType::Conductor:
      return m.f_avg;
    case MaterialType::Dielectric:
      return Rgb(1.f);
    case MaterialType::Subsurface:
      return m.rd;
  }
  return Rgb(0.f);
}

}  // namespace pt
