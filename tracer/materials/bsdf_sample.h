// The vocabulary of the BSDF interface (materials/bsdf.h) that every lobe shares: lobe flags and a sample.
#pragma once
#include "materials/material.h"

namespace pt {

// A lobe's kind, after pbrt-v4's BxDFFlags (src/pbrt/base/bxdf.h): which side the light leaves on (reflection,
// transmission) and how its directions spread (diffuse, glossy, specular: a Dirac). A material's flags are the
// union over its lobes; a sample's are the lobe it drew. Ask them through the predicates of materials/bsdf.h.
enum class BsdfFlags : uint32_t {
  None = 0,
  Reflection = 1 << 0,
  Transmission = 1 << 1,
  Diffuse = 1 << 2,
  Glossy = 1 << 3,
  Specular = 1 << 4,
};
constexpr BsdfFlags operator|(BsdfFlags a, BsdfFlags b) {
  return static_cast<BsdfFlags>(static_cast<uint32_t>(a) | static_cast<uint32_t>(b));
}
constexpr BsdfFlags operator&(BsdfFlags a, BsdfFlags b) {
  return static_cast<BsdfFlags>(static_cast<uint32_t>(a) & static_cast<uint32_t>(b));
}
constexpr BsdfFlags operator~(BsdfFlags a) { return static_cast<BsdfFlags>(~static_cast<uint32_t>(a)); }
// True when any flag is set.
constexpr bool any(BsdfFlags a) { return a != BsdfFlags::None; }

// Which quantity a path carries (pbrt-v4's TransportMode, Veach 1997 §5.2): radiance from the camera side, or
// importance from the light side (bdpt's light subpaths). Refraction scales radiance by 1/η² but not
// importance, so a refracting lobe's value depends on it; every other lobe is symmetric.
enum class TransportMode { Radiance, Importance };

// f (sr⁻¹, without the cosine) and the solid-angle pdf at one pair of directions, as the lobes' value functions
// return them (Mitsuba 3's BSDF::eval_pdf): a caller that needs both (next-event estimation under MIS, a rough
// lobe's sample) gets them in one pass, which computes what they share once (the half vector, D, a layer's
// albedo at wo). A part the caller did not ask for is left 0.
struct BsdfValue {
  Rgb f{0.f};
  float pdf = 0.f;
};

struct BsdfSample {
  Vec3 wi{0.f};
  Rgb f{0.f};
  float pdf = 0.f;
  BsdfFlags flags = BsdfFlags::None;  // the sampled lobe: reflection|transmission × diffuse|glossy|specular
  float eta = 1.f;             // n_t/n_i on transmission, 1 on reflection
};

}  // namespace pt
