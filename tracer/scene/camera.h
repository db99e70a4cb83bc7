// Pinhole camera. Image right = normalize(forward × up); pixel (0,0) is the top-left corner; a pixel's value is
// the mean radiance over its square (box filter one pixel wide), sampled by jittering uniformly inside it.
#pragma once
#include "core/ray.h"

namespace pt {

struct Camera {
  Vec3 forward{0, 0, 1}, right{-1, 0, 0}, up{0, 1, 0};  // orthonormal, world orientation
  float tan_half_x = 1, tan_half_y = 1;                  // half extents of the image plane at distance 1
  int width = 1, height = 1;
  // The eye in the scene's (camera-relative) coordinates: 0 as compiled; a camera moved in place
  // (update_scene_appearance) keeps the geometry where it was and starts its rays here.
  Vec3 origin{0.f};

  // A camera at the (camera-relative) origin; fov in degrees along the given axis.
  static Camera make(DVec3 forward, DVec3 up, double fov_deg, bool fov_horizontal, int width, int height);

  // Ray through image point (x, y) in pixel units, (0,0) = top-left corner of the image.
  Ray generate_ray(float x, float y) const {
    const float sx = (2.f * x / static_cast<float>(width) - 1.f) * tan_half_x;
    const float sy = (1.f - 2.f * y / static_cast<float>(height)) * tan_half_y;
    return {origin, glm::normalize(forward + sx * right + sy * up)};
  }
};

}  // namespace pt
