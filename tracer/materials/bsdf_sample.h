// The vocabulary of the BSDF interface (materials/bsdf.h) that every lobe shares: lobe flags and a sample.
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

struct BsdfSample {
  Vec3 wi{0.f};
  Rgb f{0.f};
  float pdf = 0.f;
  uint32_t flags = kBsdfNone;  // the sampled lobe: reflection|transmission × diffuse|glossy|specular
  float eta = 1.f;             // n_t/n_i on transmission, 1 on reflection
};

}  // namespace pt
