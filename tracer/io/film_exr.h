// The film as one multi-layer OpenEXR file: the beauty image and the layers a compositor or a denoiser reads.
//
// Channel names (layer.channel, read as layers by Blender's compositor, Nuke, tev and OpenImageIO):
//   R, G, B                     beauty: the linear mean radiance (as the PFM)
//   albedo.R/G/B                denoising albedo (integrators/features.h)
//   normal.X/Y/Z                world-space normal of the first non-specular hit, towards the viewer
//   depth.Z                     distance from the camera to the first hit (1e10 where the ray escapes)
//   emission.R/G/B              emitters and environment seen directly or through specular surfaces
//   variance.R/G/B              variance of each pixel's mean (s²/n; infinite below 2 samples)
//   spp.Y                       samples per pixel
//   denoised.R/G/B              the denoised beauty (render --denoise)
#pragma once
#include <string>
#include <vector>

#include "core/enum_table.h"
#include "film/film.h"

namespace pt {

enum class Aov { Albedo, Normal, Depth, Emission, Variance, Spp, Denoised };

template <>
struct EnumTable<Aov> {
  static constexpr std::array<EnumEntry<Aov>, 7> kEntries{{
      {Aov::Albedo, "albedo", "Albedo"},
      {Aov::Normal, "normal", "Normal"},
      {Aov::Depth, "depth", "Depth"},
      {Aov::Emission, "emission", "Emission seen directly"},
      {Aov::Variance, "variance", "Variance"},
      {Aov::Spp, "spp", "Samples per pixel"},
      {Aov::Denoised, "denoised", "Denoised"},
  }};
};

// True for the layers that need the film's feature buffers (Film::enable_features).
inline bool aov_needs_features(Aov a) {
  return a == Aov::Albedo || a == Aov::Normal || a == Aov::Depth || a == Aov::Emission;
}

struct FilmExrOptions {
  std::vector<Aov> aovs;           // layers besides the beauty, in this order
  bool half_float = false;         // 16-bit half instead of 32-bit float channels
  const std::vector<float>* denoised = nullptr;  // RGB image for Aov::Denoised (required when listed)
};

// Writes the file (complete or not at all; ImageError on failure, or when a listed layer has no data: a feature
// layer from a film without features, a denoised layer without an image).
void write_film_exr(const std::string& path, const Film& film, const FilmExrOptions& options);

}  // namespace pt
