// The display transform, defined once for the PNG writer and mirrored exactly by shaders/present.frag
// (the GL test compares the two): exposure in EV stops → tone curve → sRGB encoding → 8-bit.
#pragma once
#include "core/enum_table.h"
#include "core/math.h"

namespace pt {

enum class ToneMap { Clamp, Reinhard, AcesFitted };

template <>
struct EnumTable<ToneMap> {
  static constexpr std::array<EnumEntry<ToneMap>, 3> kEntries{{
      {ToneMap::Clamp, "clamp", "none (clamp)"},
      {ToneMap::Reinhard, "reinhard", "Reinhard"},
      {ToneMap::AcesFitted, "aces", "ACES fitted"},
  }};
};

struct DisplaySettings {
  float exposure_ev = 0.f;
  ToneMap tone_map = ToneMap::Clamp;
};

// ACES filmic curve, Narkowicz 2015 fit ("ACES Filmic Tone Mapping Curve"), applied per channel.
inline float aces_fitted(float x) {
  const float a = 2.51f, b = 0.03f, c = 2.43f, d = 0.59f, e = 0.14f;
  return std::clamp((x * (a * x + b)) / (x * (c * x + d) + e), 0.f, 1.f);
}

// IEC 61966-2-1 sRGB transfer function (linear [0,1] → encoded [0,1]).
inline float srgb_encode(float x) {
  x = std::clamp(x, 0.f, 1.f);
  return x <= 0.0031308f ? 12.92f * x : 1.055f * std::pow(x, 1.f / 2.4f) - 0.055f;
}

inline Rgb tone_map(Rgb c, const DisplaySettings& s) {
  c *= std::exp2(s.exposure_ev);
  switch (s.tone_map) {
    case ToneMap::Clamp: return glm::clamp(c, Rgb(0.f), Rgb(1.f));
    case ToneMap::Reinhard: return c / (Rgb(1.f) + c);
    case ToneMap::AcesFitted: return {aces_fitted(c.x), aces_fitted(c.y), aces_fitted(c.z)};
  }
  return c;
}

// Final 8-bit value of one channel after tone mapping: round to nearest.
inline uint8_t to_srgb8(float tone_mapped) {
  return static_cast<uint8_t>(std::lround(srgb_encode(tone_mapped) * 255.f));
}

}  // namespace pt
