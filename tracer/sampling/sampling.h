// Warping functions from the unit square to directions and points, each paired with its density.
// Every pdf here is with respect to the measure named in its comment; the chi-square tests in
// tests/test_sampling.cpp check each routine's histogram against its pdf.
#pragma once
#include "core/lanes.h"
#include "core/math.h"

namespace pt {

// Uniform over the hemisphere z >= 0; pdf = 1/(2π) per steradian.
inline Vec3 sample_uniform_hemisphere(Vec2 u) {
  const float z = u.x;
  const float r = safe_sqrt(1.f - z * z);
  const float phi = 2.f * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}
inline float uniform_hemisphere_pdf() { return kInv2Pi; }

// Uniform over the whole sphere; pdf = 1/(4π) per steradian.
inline Vec3 sample_uniform_sphere(Vec2 u) {
  const float z = 1.f - 2.f * u.x;
  const float r = safe_sqrt(1.f - z * z);
  const float phi = 2.f * kPi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}
inline float uniform_sphere_pdf() { return kInv4Pi; }

// cos x and sin x for |x| ≤ π/4: the single-precision minimax polynomials of Cephes (S. L. Moshier, sinf.c and
// cosf.c, their range |x| ≤ π/4), within 2 ulp of the true values there (tested). Where the angle is known to
// lie in that range this skips libm's range reduction and call: sincosf was 5 % of a `cornell` pass. Templated
// over the float type: the shading lanes (integrators/shading_lanes.h) run the same operations on SIMD lanes.
template <class T>
[[gnu::always_inline]] inline void quarter_turn_cos_sin(const T& x, T& c, T& s) {
  const T z = x * x;
  s = ((-1.9515295891e-4f * z + 8.3321608736e-3f) * z - 1.6666654611e-1f) * z * x + x;
  c = ((2.443315711809948e-5f * z - 1.388731625493765e-3f) * z + 4.166664568298827e-2f) * z * z - 0.5f * z + 1.f;
}
inline Vec2 cos_sin_quarter_turn(float x) {
  float c, s;
  quarter_turn_cos_sin(x, c, s);
  return {c, s};
}

// Concentric map of the square onto the unit disk (Shirley & Chiu 1997): area-preserving, low distortion.
// The angle is θ = (π/4)·(o.y/o.x) in the left/right wedges and θ = π/2 − φ, φ = (π/4)·(o.x/o.y), in the
// others, where (cos θ, sin θ) = (sin φ, cos φ): both need only angles in [−π/4, π/4]. Over T = float or vfloat
// (core/lanes.h): the wedge is a select, so both quotients are computed and one is kept.
template <class T>
[[gnu::always_inline]] inline void disk_concentric(const T& ux, const T& uy, T& dx, T& dy) {
  const T ox = 2.f * ux - 1.f, oy = 2.f * uy - 1.f;
  const auto wide = lanes::abs(ox) > lanes::abs(oy);
  const T angle = (kPi / 4.f) * select(wide, oy / ox, ox / oy);
  T c, s;
  quarter_turn_cos_sin(angle, c, s);
  const auto centre = ox == 0.f && oy == 0.f;
  dx = select(centre, T(0.f), select(wide, ox * c, oy * s));
  dy = select(centre, T(0.f), select(wide, ox * s, oy * c));
}
inline Vec2 sample_uniform_disk_concentric(Vec2 u) {
  Vec2 d;
  disk_concentric(u.x, u.y, d.x, d.y);
  return d;
}

// Cosine-weighted hemisphere z >= 0 (Malley's method: the disk's point lifted to the hemisphere); pdf = cos θ / π
// per steradian. Over T = float or vfloat.
template <class T>
[[gnu::always_inline]] inline lanes::Vec3T<T> cosine_hemisphere(const T& ux, const T& uy) {
  T dx, dy;
  disk_concentric(ux, uy, dx, dy);
  return {dx, dy, lanes::sqrt(lanes::std_max(T(0.f), (1.f - dx * dx) - dy * dy))};
}
inline Vec3 sample_cosine_hemisphere(Vec2 u) { return lanes::to_vec3(cosine_hemisphere(u.x, u.y)); }
template <class T>
[[gnu::always_inline]] inline T cosine_hemisphere_pdf(const T& cos_theta) {
  return lanes::std_max(cos_theta, T(0.f)) * kInvPi;
}

// Uniform over the cone of directions around +z with cos θ >= cos_theta_max; pdf = 1/(2π(1−cos θmax)).
// 1 − cos θ is interpolated directly so that tiny cones (distant or small spheres) keep their precision.
inline Vec3 sample_uniform_cone(Vec2 u, float one_minus_cos_max) {
  const float one_minus_cos = u.x * one_minus_cos_max;
  const float cos_theta = 1.f - one_minus_cos;
  const float sin_theta = safe_sqrt(one_minus_cos * (2.f - one_minus_cos));
  const float phi = 2.f * kPi * u.y;
  return {sin_theta * std::cos(phi), sin_theta * std::sin(phi), cos_theta};
}
inline float uniform_cone_pdf(float one_minus_cos_max) { return 1.f / (2.f * kPi * one_minus_cos_max); }

// Uniform over a triangle: barycentrics (b0, b1) with b2 = 1 − b0 − b1; pdf = 1/area.
// Uses the low-distortion square-to-triangle map of Heitz (2019), "A Low-Distortion Map Between Triangle and Square".
inline Vec2 sample_uniform_triangle(Vec2 u) {
  float b0, b1;
  if (u.x < u.y) {
    b0 = u.x / 2.f;
    b1 = u.y - b0;
  } else {
    b1 = u.y / 2.f;
    b0 = u.x - b1;
  }
  return {b0, b1};
}

// Veach's power heuristic with β = 2 for one sample from each of two strategies; over T = float or vfloat.
template <class T>
[[gnu::always_inline]] inline T power_heuristic(const T& pdf_f, const T& pdf_g) {
  const T f = pdf_f * pdf_f, g = pdf_g * pdf_g;
  return select(lanes::isinf(f), T(1.f), select(f + g > 0.f, f / (f + g), T(0.f)));
}

}  // namespace pt
