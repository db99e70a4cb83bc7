// Warping functions from the unit square to directions and points, each paired with its density.
// Every pdf here is with respect to the measure named in its comment; the chi-square tests in
// tests/test_sampling.cpp check each routine's histogram against its pdf.
#pragma once
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

// Concentric map of the square onto the unit disk (Shirley & Chiu 1997): area-preserving, low distortion.
inline Vec2 sample_uniform_disk_concentric(Vec2 u) {
  const Vec2 o = 2.f * u - Vec2(1.f);
  if (o.x == 0.f && o.y == 0.f) return {0.f, 0.f};
  float r, theta;
  if (std::abs(o.x) > std::abs(o.y)) {
    r = o.x;
    theta = (kPi / 4.f) * (o.y / o.x);
  } else {
    r = o.y;
    theta = (kPi / 2.f) - (kPi / 4.f) * (o.x / o.y);
  }
  return r * Vec2(std::cos(theta), std::sin(theta));
}

// Cosine-weighted hemisphere z >= 0 (Malley's method); pdf = cos θ / π per steradian.
inline Vec3 sample_cosine_hemisphere(Vec2 u) {
  const Vec2 d = sample_uniform_disk_concentric(u);
  const float z = safe_sqrt(1.f - d.x * d.x - d.y * d.y);
  return {d.x, d.y, z};
}
inline float cosine_hemisphere_pdf(float cos_theta) { return std::max(cos_theta, 0.f) * kInvPi; }

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

// Veach's power heuristic with β = 2 for one sample from each of two strategies.
inline float power_heuristic(float pdf_f, float pdf_g) {
  const float f = pdf_f * pdf_f, g = pdf_g * pdf_g;
  if (std::isinf(f)) return 1.f;
  return f + g > 0.f ? f / (f + g) : 0.f;
}

}  // namespace pt
