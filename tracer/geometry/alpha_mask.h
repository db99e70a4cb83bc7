// Cut-outs (glTF's alpha mode MASK): where a material's alpha falls below its cutoff, its surface is not there.
// Partial transparency (glTF's BLEND, an .mtl's d < 1): the surface is there with probability alpha, decided
// anew for every ray that meets it (stochastic transparency: averaged over a pixel's samples, or a shadow's, what
// is behind shows through by 1 − alpha, as alpha blending over it would; no refraction, no tint).
// The ray queries (scene_queries.h) skip such hits inside the hierarchy's traversal, for closest hits and shadow
// rays alike, so a leaf's cut-away part neither shades, nor casts a shadow, nor is hit again by the next ray.
#pragma once
#include <bit>
#include <cstdint>
#include <memory>

#include "core/rng.h"

#include "materials/texture.h"

namespace pt {

struct AlphaMask {
  std::shared_ptr<const Texture> alpha;  // the alpha channel in every channel, or null: the factor alone
  float factor = 1.f;                    // glTF's baseColorFactor alpha; an .mtl's d
  float cutoff = 0.5f;                   // glTF's alphaCutoff: opaque where factor × alpha ≥ cutoff
  bool blend = false;                    // partial transparency: there with probability factor × alpha
  glm::mat3 uv_transform{1.f};           // surface uv → the image's (the base colour texture's transform)

  // Whether the surface is there at texture coordinates uv for a ray whose own uniform number is xi
  // (ray_uniform): the alpha bilinearly filtered at the image's full resolution (the cut's edge is as sharp as
  // the image; the pixel's samples antialias it).
  bool opaque_at(Vec2 uv, float xi = 0.f) const {
    const float a = factor * (alpha ? texture_at(*alpha, uv_transform, uv).x : 1.f);
    return blend ? xi < a : a >= cutoff;
  }
};

// A number in [0, 1) drawn from a ray (its origin's and direction's bits) and the polygon it meets: the same
// ray meeting the same polygon always gets the same number (a traversal may test a hit twice), any other ray an
// independent one. SplitMix64's finaliser (mix64, core/rng.h) mixes the bits.
inline float ray_uniform(Vec3 o, Vec3 d, uint32_t polygon) {
  const auto bits = [](float v) { return static_cast<uint64_t>(std::bit_cast<uint32_t>(v)); };
  uint64_t h = mix64(bits(o.x) | bits(o.y) << 32);
  h = mix64(h ^ (bits(o.z) | bits(d.x) << 32));
  h = mix64(h ^ (bits(d.y) | bits(d.z) << 32));
  h = mix64(h ^ polygon);
  return static_cast<float>(h >> 40) * 0x1p-24f;
}

}  // namespace pt
