// Fresnel reflectance of smooth interfaces and the two directions they produce (mirror reflection, Snell
// refraction). The formulas are templates over the float type T so that a SIMD lane type can reuse them
// (Mitsuba 3 style): T must provide +, −, ×, /, comparisons, and the functions sqrt, abs, min, max, copysign
// found by argument-dependent lookup, plus an overload of pt::select(mask, a, b) (core/lanes.h). The scalar
// instantiation is T = float.
//
// Conventions (pbrt-v4 §9.3): cos_i ≥ 0 is the cosine on the incident side; eta = n_t / n_i is the relative index
// of the transmitted side over the incident side; reflectance is for unpolarised light (mean of s and p).
#pragma once
#include <type_traits>

#include "core/lanes.h"
#include "core/math.h"
#include "core/simd_sqrt_warnings.h"

namespace pt {

// Exact dielectric Fresnel reflectance (pbrt-v4 eq. 9.4–9.5, FrDielectric without the side flip). Returns 1
// under total internal reflection (sin²θt ≥ 1).
// (std::min and std::max as the standard defines them, lane by lane too: lanes::std_min, lanes::std_max.)
PT_SIMD_SQRT_WARNINGS_OFF  // it runs on SIMD lanes too (layered_lobe.h; every lane computed)
template <class T>
T fresnel_dielectric(T cos_i, T eta) {
  cos_i = lanes::std_min(lanes::std_max(cos_i, T(0)), T(1));
  const T sin2_t = (T(1) - cos_i * cos_i) / (eta * eta);
  const T cos_t = lanes::sqrt(lanes::std_max(T(1) - sin2_t, T(0)));
  const T r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  const T r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  // Under TIR the quotients can be 0/0 (cos_i = cos_t = 0); select discards them.
  return select(sin2_t >= T(1), T(1), T(0.5f) * (r_parl * r_parl + r_perp * r_perp));
}
PT_SIMD_SQRT_WARNINGS_ON

// Minimal complex arithmetic over T (pbrt-v4 pstd::complex), enough for the conductor Fresnel equations.
template <class T>
struct Complex {
  T re, im;
};
template <class T>
Complex<T> operator+(Complex<T> a, Complex<T> b) { return {a.re + b.re, a.im + b.im}; }
template <class T>
Complex<T> operator-(Complex<T> a, Complex<T> b) { return {a.re - b.re, a.im - b.im}; }
template <class T>
Complex<T> operator*(Complex<T> a, Complex<T> b) { return {a.re * b.re - a.im * b.im, a.re * b.im + a.im * b.re}; }
template <class T>
Complex<T> operator*(Complex<T> a, T s) { return {a.re * s, a.im * s}; }
template <class T>
Complex<T> operator/(Complex<T> a, Complex<T> b) {
  const T d = b.re * b.re + b.im * b.im;
  return {(a.re * b.re + a.im * b.im) / d, (a.im * b.re - a.re * b.im) / d};
}
template <class T>
T complex_norm(Complex<T> a) { return a.re * a.re + a.im * a.im; }  // |a|²
// Principal square root (pbrt-v4 pstd::sqrt for complex).
PT_SIMD_SQRT_WARNINGS_OFF  // it runs on SIMD lanes too (conductor.h; every lane computed)
template <class T>
Complex<T> complex_sqrt(Complex<T> z) {
  using lanes::abs, lanes::sqrt;
  const T n = sqrt(z.re * z.re + z.im * z.im);
  const T t1 = sqrt(T(0.5f) * (n + abs(z.re)));
  const T t2 = T(0.5f) * z.im / lanes::std_max(t1, T(1e-30f));
  const T re = select(z.re >= T(0), t1, abs(t2));
  const T im = select(z.re >= T(0), t2, lanes::copysign(t1, z.im));
  return {select(n == T(0), T(0), re), select(n == T(0), T(0), im)};
}
PT_SIMD_SQRT_WARNINGS_ON

// Exact Fresnel reflectance of a conductor with complex relative index η + ik, unpolarised (pbrt-v4 FrComplex,
// eq. 9.6 with the complex Snell law). Evaluate per RGB channel.
template <class T>
T fresnel_complex(T cos_i, T eta, T k) {
  cos_i = lanes::std_min(lanes::std_max(cos_i, T(0)), T(1));
  const Complex<T> e{eta, k};
  const T sin2_i = T(1) - cos_i * cos_i;
  const Complex<T> sin2_t = Complex<T>{sin2_i, T(0)} / (e * e);
  const Complex<T> cos_t = complex_sqrt(Complex<T>{T(1), T(0)} - sin2_t);
  const Complex<T> ci{cos_i, T(0)};
  const Complex<T> r_parl = (e * ci - cos_t) / (e * ci + cos_t);
  const Complex<T> r_perp = (ci - e * cos_t) / (ci + e * cos_t);
  // Grazing incidence reflects everything; it also avoids 0/0 for the degenerate index 1 + 0i.
  return select(cos_i <= T(0), T(1), T(0.5f) * (complex_norm(r_parl) + complex_norm(r_perp)));
}
inline Rgb fresnel_complex(float cos_i, Rgb eta, Rgb k) {
  return {fresnel_complex(cos_i, eta.x, k.x), fresnel_complex(cos_i, eta.y, k.y), fresnel_complex(cos_i, eta.z, k.z)};
}

// Schlick's approximation F0 + (1 − F0)(1 − cos θ)⁵ (Schlick 1994). S may be a colour (per-channel F0).
template <class S, class T>
S fresnel_schlick(S f0, T cos_theta) {
  const T m = T(1) - lanes::std_min(lanes::std_max(cos_theta, T(0)), T(1));
  const T m2 = m * m;
  return f0 + (S(1) - f0) * (m2 * m2 * m);
}

// Mirror reflection of an incident direction v (pointing towards the surface) about n: v − 2(v·n)n.
inline Vec3 reflect(Vec3 v, Vec3 n) { return v - 2.f * glm::dot(v, n) * n; }

// Snell refraction of wo (pointing away from the surface, on the side of n) through an interface with relative
// index eta = n_t/n_i. Returns false under total internal reflection.
// Written once over T (float, or vfloat for the SIMD shading lanes, integrators/lane_lobes.h): wt is computed in
// every lane, and is meaningful where the returned mask is set. The operations are glm's, in its order
// (normalize(v) = v · (1/√(v·v))), so both instances round alike.
PT_SIMD_SQRT_WARNINGS_OFF  // it runs on SIMD lanes too (every lane computed)
template <class T>
[[gnu::always_inline]] inline lanes::Mask<T> refract_t(const lanes::Vec3T<T>& wo, const lanes::Vec3T<T>& n,
                                                       const T& eta, lanes::Vec3T<T>& wt) {
  const T cos_i = lanes::dot(n, wo);
  const T sin2_t = lanes::std_max(T(0.f), T(1.f) - cos_i * cos_i) / (eta * eta);
  if constexpr (std::is_same_v<T, float>) {
    if (sin2_t >= 1.f) return false;  // one path stops here; the lanes compute on (and select)
  }
  const T cos_t = lanes::sqrt(lanes::std_max(T(0.f), T(1.f) - sin2_t));  // safe_sqrt
  const T k = cos_i / eta - cos_t;
  const lanes::Vec3T<T> v{-wo.x / eta + k * n.x, -wo.y / eta + k * n.y, -wo.z / eta + k * n.z};
  const T inv = T(1.f) / lanes::sqrt(lanes::dot(v, v));
  wt = {v.x * inv, v.y * inv, v.z * inv};
  return !(sin2_t >= T(1.f));
}
PT_SIMD_SQRT_WARNINGS_ON
inline bool refract(Vec3 wo, Vec3 n, float eta, Vec3& wt) {
  lanes::Vec3T<float> t;
  if (!refract_t(lanes::of(wo), lanes::of(n), eta, t)) return false;
  wt = lanes::to_vec3(t);
  return true;
}

}  // namespace pt
