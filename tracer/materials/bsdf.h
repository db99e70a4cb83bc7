// The BSDF interface the integrator sees: flags, eval, pdf, sample — plain functions on a Material, in the
// local shading frame (z = the surface's front geometric normal). Directions point away from the surface.
// After pbrt-v4 (src/pbrt/base/bxdf.h: BxDFFlags; the integrator asks "is it specular? does it transmit?",
// never a type) and yocto-gl (yocto_shading.h: eval/sample/pdf triples as plain functions).
//
// Conventions (pbrt-v4 ch. 9):
// - eval returns f (sr⁻¹) without the cosine; pdf is per steradian; a sample's weight is f·|cos θi|/pdf.
// - Specular (delta) lobes are never returned by eval or pdf (their f is a Dirac); sample returns them with
//   flags containing kBsdfSpecular, f = (lobe weight)/|cos θi| and pdf = the lobe's selection probability.
// - Reflection-only materials are two-sided: they mirror wo to the front (wo.z > 0) and treat wi likewise;
//   dielectrics use the sign of wo.z to tell entering (outside, z > 0) from leaving.
// - Transmission carries radiance scaling 1/η² (non-symmetric transport, Veach 1997 §5.2); BsdfSample::eta is
//   the relative index n_t/n_i of the crossed interface (1 for reflection), for Russian roulette's η-scale.
#pragma once
#include "materials/material.h"

namespace pt {

enum BsdfFlags : uint32_t {
  kBsdfNone = 0,
  kBsdfReflection = 1,
  kBsdfTransmission = 2,
  kBsdfDiffuse = 4,
  kBsdfGlossy = 8,
  kBsdfSpecular = 16,
};

// True when the BSDF has a lobe that eval/pdf can see (diffuse or glossy): light sampling makes sense there.
inline bool has_non_specular(uint32_t flags) { return (flags & (kBsdfDiffuse | kBsdfGlossy)) != 0; }
inline bool is_specular(uint32_t flags) { return (flags & kBsdfSpecular) != 0; }
inline bool is_transmissive(uint32_t flags) { return (flags & kBsdfTransmission) != 0; }

struct BsdfSample {
  Vec3 wi{0.f};
  Rgb f{0.f};
  float pdf = 0.f;
  uint32_t flags = kBsdfNone;  // the sampled lobe: reflection|transmission × diffuse|glossy|specular
  float eta = 1.f;             // n_t/n_i on transmission, 1 on reflection
};

// The lobes this material has (a union over its lobes: plastic with a smooth coat is Specular|Diffuse).
uint32_t bsdf_flags(const Material& m);
// f(wo, wi) of the non-specular lobes.
Rgb bsdf_eval(const Material& m, Vec3 wo, Vec3 wi);
// Solid-angle density with which bsdf_sample produces wi from wo (non-specular lobes only, each weighted by its
// selection probability).
float bsdf_pdf(const Material& m, Vec3 wo, Vec3 wi);
// Samples wi from wo with uc (lobe choice) and u (direction). Returns false when no sample was produced
// (grazing, below the surface, zero albedo).
bool bsdf_sample(const Material& m, Vec3 wo, float uc, Vec2 u, BsdfSample& out);

}  // namespace pt
