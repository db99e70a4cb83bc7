// Small vector-math vocabulary shared by the whole tracer (GLM underneath).
// Conventions: right-handed world, y up; radiance in linear RGB; angles in radians unless named *_deg.
#pragma once
#include <glm/glm.hpp>
#include <glm/gtc/constants.hpp>
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

namespace pt {

using Vec2 = glm::vec2;
using Vec3 = glm::vec3;
using DVec3 = glm::dvec3;
using Vec4 = glm::vec4;
using Rgb = glm::vec3;  // linear RGB radiance or reflectance

inline constexpr float kPi = 3.14159265358979323846f;
inline constexpr float kInvPi = 0.31830988618379067154f;
inline constexpr float kInv2Pi = 0.15915494309189533577f;
inline constexpr float kInv4Pi = 0.07957747154594766788f;
inline constexpr float kInfinity = std::numeric_limits<float>::infinity();
// Largest float strictly below 1: keeps a random number in [0,1) after scaling.
inline constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;

inline float max_component(Vec3 v) { return std::max(v.x, std::max(v.y, v.z)); }
inline float max_abs_component(Vec3 v) { return max_component(glm::abs(v)); }
inline int max_dimension(Vec3 v) { return v.x > v.y ? (v.x > v.z ? 0 : 2) : (v.y > v.z ? 1 : 2); }
inline constexpr float kLuminanceWeights[3] = {0.2126f, 0.7152f, 0.0722f};
inline float luminance(Rgb c) {
  return kLuminanceWeights[0] * c.x + kLuminanceWeights[1] * c.y + kLuminanceWeights[2] * c.z;
}
inline bool is_black(Rgb c) { return c.x == 0.f && c.y == 0.f && c.z == 0.f; }
inline bool is_finite(Vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }
inline float sqr(float x) { return x * x; }
inline float safe_sqrt(float x) { return std::sqrt(std::max(0.f, x)); }

// Orthonormal basis around a unit vector n (Duff et al. 2017, "Building an Orthonormal Basis, Revisited"):
// branch-free except for the sign, no singularity. frame_tangents gives its tangents s and t over T = float or
// vfloat (core/lanes.h), the caller passing sign = copysign(1, n.z).
template <class T>
[[gnu::always_inline]] inline void frame_tangents(const T& sign, const T& nx, const T& ny, const T& nz, T (&s)[3],
                                                  T (&t)[3]) {
  const T a = -1.f / (sign + nz);
  const T b = nx * ny * a;
  s[0] = 1.f + sign * nx * nx * a, s[1] = sign * b, s[2] = -sign * nx;
  t[0] = b, t[1] = sign + ny * ny * a, t[2] = -ny;
}

struct Frame {
  Vec3 s, t, n;
  [[gnu::always_inline]] static Frame from_normal(Vec3 n) {
    float s[3], t[3];
    frame_tangents(std::copysign(1.f, n.z), n.x, n.y, n.z, s, t);
    return {Vec3(s[0], s[1], s[2]), Vec3(t[0], t[1], t[2]), n};
  }
  Vec3 to_local(Vec3 v) const { return {glm::dot(v, s), glm::dot(v, t), glm::dot(v, n)}; }
  Vec3 to_world(Vec3 v) const { return s * v.x + t * v.y + n * v.z; }
};

// Float rounding helpers for robust ray spawning (pbrt-v4, section 6.8.6): the next representable float above
// (below) v, by stepping the bit pattern; ±0 both step to the smallest denormal. Inline bit arithmetic rather
// than std::nextafter, which is an out-of-line libm call on the hot path.
inline float next_float_up(float v) {
  if (std::isinf(v) && v > 0.f) return v;
  if (v == -0.f) v = 0.f;
  uint32_t bits = std::bit_cast<uint32_t>(v);
  bits = v >= 0.f ? bits + 1 : bits - 1;
  return std::bit_cast<float>(bits);
}
inline float next_float_down(float v) {
  if (std::isinf(v) && v < 0.f) return v;
  if (v == 0.f) v = -0.f;
  uint32_t bits = std::bit_cast<uint32_t>(v);
  bits = v > 0.f ? bits - 1 : bits + 1;
  return std::bit_cast<float>(bits);
}

}  // namespace pt
