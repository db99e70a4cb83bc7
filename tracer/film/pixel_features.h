// The features of a camera sample (AOVs: denoising albedo, normal, depth, directly seen emission) as the film
// stores them per sample and per pixel. Their convention, and how a path gathers them, is integrators/features.h.
#pragma once
#include <cstddef>
#include <vector>

#include "core/math.h"

namespace pt {

// Depth written where nothing is hit: Cycles' and Blender's "infinitely far" value, finite so that running
// means and filters stay finite.
inline constexpr float kNoHitDepth = 1e10f;

struct PixelFeatures {
  Rgb albedo{0.f};
  Vec3 normal{0.f};
  float depth = kNoHitDepth;
  Rgb emission{0.f};
};

// A whole image of features as row-major planes, top row first: albedo, normal and emission 3 floats per pixel,
// depth 1 (the guide of the viewer's preview, integrators/feature_pass.h).
struct FeatureImage {
  int width = 0, height = 0;
  std::vector<float> albedo, normal, depth, emission;
  size_t pixel_count() const { return static_cast<size_t>(width) * height; }
};

}  // namespace pt
