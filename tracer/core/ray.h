// Rays and the per-ray constants of the watertight triangle test.
#pragma once
#include "core/math.h"

namespace pt {

struct Ray {
  Vec3 o;  // origin, camera-relative world units
  Vec3 d;  // direction, unit length
};

// Per-ray setup of Woop, Benthin & Wald (2013), "Watertight Ray/Triangle Intersection", JCGT 2(1):
// the axis where |d| is largest becomes z, and a shear maps the ray onto the +z axis through the origin.
struct RayShear {
  int kx, ky, kz;
  float sx, sy, sz;
  explicit RayShear(Vec3 d) {
    kz = max_dimension(glm::abs(d));
    kx = kz == 2 ? 0 : kz + 1;
    ky = kx == 2 ? 0 : kx + 1;
    if (d[kz] < 0.f) std::swap(kx, ky);  // keep the winding so edge-function signs keep their meaning
    sz = 1.f / d[kz];
    sx = d[kx] * sz;
    sy = d[ky] * sz;
  }
};

}  // namespace pt
