// Cut-outs (glTF's alpha mode MASK): where a material's alpha falls below its cutoff, its surface is not there.
// The ray queries (scene_queries.h) skip such hits inside the hierarchy's traversal, for closest hits and shadow
// rays alike, so a leaf's cut-away part neither shades, nor casts a shadow, nor is hit again by the next ray.
#pragma once
#include <memory>

#include "materials/texture.h"

namespace pt {

struct AlphaMask {
  std::shared_ptr<const Texture> alpha;  // the alpha channel in every channel, or null: the factor alone
  float factor = 1.f;                    // glTF's baseColorFactor alpha
  float cutoff = 0.5f;                   // glTF's alphaCutoff: opaque where factor × alpha ≥ cutoff
  glm::mat3 uv_transform{1.f};           // surface uv → the image's (the base colour texture's transform)

  // Whether the surface is there at texture coordinates uv: the alpha bilinearly filtered at the image's full
  // resolution (the cut's edge is as sharp as the image; the pixel's samples antialias it).
  bool opaque_at(Vec2 uv) const {
    const float a = alpha ? texture_at(*alpha, uv_transform, uv).x : 1.f;
    return factor * a >= cutoff;
  }
};

}  // namespace pt
