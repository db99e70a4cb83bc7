// Feature buffers (AOVs) of a camera sample: what a denoiser and a compositor need besides the radiance.
//
// Convention (the one of Open Image Denoise's and Cycles' denoising passes, docs/denoising.md): the features
// are those of the first vertex along the camera path that has a non-specular lobe. Smooth mirrors and smooth
// glass are followed along the direction the path itself sampled (the same sample dimensions, so the feature
// path is the radiance path), and their tint multiplies the albedo found behind them. Refraction's radiance
// scale 1/η² is undone: clear glass has tint 1.
// - albedo: tint × the material's denoising albedo (bsdf_albedo in materials/bsdf.h);
// - normal: the shading normal at that vertex in world space (the geometric one where the surface is
//   flat-shaded), turned towards the side the path arrived from;
// - depth:  distance from the camera to the first hit (mirrors included), kNoHitDepth where the camera ray
//   escapes;
// - emission: the radiance of emitters and of the environment seen directly or through the specular chain
//   (what the path gathered before its first non-specular vertex, that vertex's own emission included). It has
//   no noise but the pixel footprint's, so the denoiser leaves it out of the filtered part.
// A path that ends on a specular chain (it escapes, or is absorbed) keeps the features of the last specular
// vertex; a camera ray that escapes has albedo 0 and normal 0.
// The per-pixel record itself (PixelFeatures) is film/pixel_features.h: the film, the denoisers and the file
// writers read it; this file is how a path gathers it.
#pragma once
#include "film/pixel_features.h"
#include "geometry/interaction.h"
#include "materials/bsdf.h"

namespace pt {

// The features of one path while they are being gathered: `out` is null when none are requested, or once the
// first non-specular vertex has been recorded.
struct FeatureTrace {
  PixelFeatures* out = nullptr;
  Rgb tint{1.f};  // product of the specular vertices' weights so far

  // At a surface vertex of the camera path. `scatter_depth` counts scattering events before it (0 at the first
  // hit); `ray_origin` is where the ray that found the vertex started (the camera for the first hit). `last`: the
  // path cannot continue past this vertex (the bounce limit), so its features are final whatever its lobes.
  // `L`: the radiance the path has gathered so far, this vertex's emission included.
  template <MaterialSet kM>
  void at_vertex(int scatter_depth, const Vec3& ray_origin, const Interaction& it, const Vec3& wo,
                 const Material& m, bool last, const Rgb& L) {
    if (scatter_depth == 0) out->depth = glm::length(it.p - ray_origin);
    out->emission = L;
    out->albedo = tint * bsdf_albedo<kM>(m);
    out->normal = glm::dot(it.ng, wo) >= 0.f ? it.ns : -it.ns;
    if (last || has_non_specular(bsdf_flags<kM>(m))) out = nullptr;
  }

  // The camera path left the scene while the features were pending: `L` includes what the escaping ray found.
  void escaped(const Rgb& L) {
    out->emission = L;
    out = nullptr;
  }

  // After a specular vertex sampled `bs`: the chain continues, tinted by the sample's weight.
  void through_specular(const BsdfSample& bs) {
    Rgb w = bs.f * (std::abs(bs.wi.z) / bs.pdf);
    if (is_transmissive(bs.flags)) w *= sqr(bs.eta);
    tint *= w;
  }
};

}  // namespace pt
