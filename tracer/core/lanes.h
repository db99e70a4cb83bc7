// One number type for one path or for a SIMD vector of paths: formulas written once over T = float (the scalar
// path loop) or T = vfloat (kLanes paths side by side: the wavefront's shading lanes), as Mitsuba 3 writes its
// BSDFs once over its Float type. What differs between the two is here, behind overloads: the mask of a
// comparison (bool or vfloat::mask_type), select, the standard library's min and max, abs, sqrt, isfinite and
// the next float up or down. Everything else is written with +, −, ×, ÷ and comparisons, which both types have.
//
// Bit-identical lanes: each overload performs the scalar function's float operations (std::max(a, b) is
// (a < b) ? b : a, so a NaN operand decides alike; sqrt and ÷ are IEEE-exact in both), and the project compiles
// with -ffp-contract=off, so a formula instantiated for vfloat gives each lane the bits its float instantiation
// gives that path (tests: the wavefront loop's images against the scalar loop's, byte for byte).
//
// Width: std::experimental::native_simd<float> (libstdc++'s Parallelism TS v2): 16 lanes with AVX-512, 8 with
// AVX2, 4 with SSE, whatever the target CPU has.
#pragma once
#include <experimental/simd>
#include <bit>
#include <cmath>
#include <cstdint>

#include "core/math.h"

namespace pt {

namespace stdx = std::experimental;
using vfloat = stdx::native_simd<float>;
using vmask = vfloat::mask_type;
inline constexpr int kLanes = static_cast<int>(vfloat::size());

// m ? a : b, lane by lane, for one value or for lanes of any element type (bdpt's manifold search runs lanes
// of doubles); in namespace pt itself, where the templated formulas (materials/fresnel.h, microfacet.h) find it.
[[gnu::always_inline]] inline float select(bool m, float a, float b) { return m ? a : b; }
[[gnu::always_inline]] inline double select(bool m, double a, double b) { return m ? a : b; }
template <class U, class Abi>
[[gnu::always_inline]] inline stdx::simd<U, Abi> select(const stdx::simd_mask<U, Abi>& m, const stdx::simd<U, Abi>& a,
                                                        const stdx::simd<U, Abi>& b) {
  stdx::simd<U, Abi> r = b;
  stdx::where(m, r) = a;
  return r;
}

namespace lanes {

// The mask a comparison of two T gives.
template <class T>
struct MaskOf {
  using type = bool;
};
template <>
struct MaskOf<vfloat> {
  using type = vmask;
};
template <class T>
using Mask = typename MaskOf<T>::type;

// std::max and std::min as the standard defines them: (a < b) ? b : a and (b < a) ? b : a.
template <class T>
[[gnu::always_inline]] inline T std_max(const T& a, const T& b) {
  return select(a < b, b, a);
}
template <class T>
[[gnu::always_inline]] inline T std_min(const T& a, const T& b) {
  return select(b < a, b, a);
}
// std::clamp(v, lo, hi) as the standard defines it: (v < lo) ? lo : (hi < v) ? hi : v.
template <class T>
[[gnu::always_inline]] inline T std_clamp(const T& v, const T& lo, const T& hi) {
  return select(v < lo, lo, select(hi < v, hi, v));
}
[[gnu::always_inline]] inline float abs(float x) { return std::abs(x); }
[[gnu::always_inline]] inline vfloat abs(const vfloat& x) { return stdx::abs(x); }
[[gnu::always_inline]] inline float sqrt(float x) { return std::sqrt(x); }
[[gnu::always_inline]] inline vfloat sqrt(const vfloat& x) { return stdx::sqrt(x); }
[[gnu::always_inline]] inline bool isfinite(float x) { return std::isfinite(x); }
[[gnu::always_inline]] inline vmask isfinite(const vfloat& x) { return stdx::isfinite(x); }
[[gnu::always_inline]] inline bool isinf(float x) { return std::isinf(x); }
[[gnu::always_inline]] inline vmask isinf(const vfloat& x) { return stdx::isinf(x); }
// std::copysign(a, b): |a| with b's sign bit.
[[gnu::always_inline]] inline float copysign(float a, float b) { return std::copysign(a, b); }
[[gnu::always_inline]] inline vfloat copysign(const vfloat& a, const vfloat& b) {
  const vfloat m = stdx::abs(a);
  return select(stdx::signbit(b), -m, m);
}
// std::copysign(1, x): the sign bit of x as ±1.
[[gnu::always_inline]] inline float sign_of(float x) { return std::copysign(1.f, x); }
[[gnu::always_inline]] inline vfloat sign_of(const vfloat& x) {
  return select(stdx::signbit(x), vfloat(-1.f), vfloat(1.f));
}

// next_float_up / next_float_down of core/math.h: the float's bit pattern stepped by one (±0 to the smallest
// denormal, +inf and −inf kept), lane by lane.
[[gnu::always_inline]] inline float next_up(float v) { return next_float_up(v); }
[[gnu::always_inline]] inline float next_down(float v) { return next_float_down(v); }
namespace detail {
using vbits = stdx::rebind_simd_t<uint32_t, vfloat>;  // unsigned: stepping wraps, never overflows
[[gnu::always_inline]] inline vfloat bits_plus(const vfloat& v, uint32_t k) {
  return stdx::__proposed::simd_bit_cast<vfloat>(stdx::__proposed::simd_bit_cast<vbits>(v) + k);
}
}  // namespace detail
[[gnu::always_inline]] inline vfloat next_up(vfloat v) {
  stdx::where(v == 0.f, v) = 0.f;  // −0 → +0
  const vfloat r = select(v >= 0.f, detail::bits_plus(v, 1u), detail::bits_plus(v, ~0u));
  return select(v == kInfinity, v, r);
}
[[gnu::always_inline]] inline vfloat next_down(vfloat v) {
  stdx::where(v == 0.f, v) = -0.f;
  const vfloat r = select(v > 0.f, detail::bits_plus(v, ~0u), detail::bits_plus(v, 1u));
  return select(v == -kInfinity, v, r);
}

// po pushed one float further in the direction of `of` (offset_ray_origin's last step): a branch for one path,
// selects for lanes.
[[gnu::always_inline]] inline float nudge(float po, float of) {
  return of > 0.f ? next_float_up(po) : of < 0.f ? next_float_down(po) : po;
}
[[gnu::always_inline]] inline vfloat nudge(const vfloat& po, const vfloat& of) {
  return select(of > 0.f, next_up(po), select(of < 0.f, next_down(po), po));
}

// A 3-vector of T, with the operations the formulas need in glm's order of evaluation (component-wise; a dot
// product as (x + y) + z), so that the float instantiation rounds as the glm code it stands for.
template <class T>
struct Vec3T {
  T x, y, z;
};
template <class T>
[[gnu::always_inline]] inline T dot(const Vec3T<T>& a, const Vec3T<T>& b) {
  return (a.x * b.x + a.y * b.y) + a.z * b.z;
}
[[gnu::always_inline]] inline Vec3T<float> of(Vec3 v) { return {v.x, v.y, v.z}; }
[[gnu::always_inline]] inline Vec3 to_vec3(const Vec3T<float>& v) { return {v.x, v.y, v.z}; }

// A spawned ray's origin (pbrt-v4, section 6.8.6): the point p, whose coordinates may be off by err, pushed along
// the geometric normal ng by the error bound's projection on it (towards the back when `back`), then one float
// further on every axis the push moves, so the new ray starts on the intended side of the surface
// (geometry/interaction.h: offset_ray_origin).
template <class T>
[[gnu::always_inline]] inline Vec3T<T> offset_point(const Vec3T<T>& p, const Vec3T<T>& err, const Vec3T<T>& ng,
                                                    const Mask<T>& back) {
  const T dist = (abs(ng.x) * err.x + abs(ng.y) * err.y) + abs(ng.z) * err.z;
  const T ox = dist * ng.x, oy = dist * ng.y, oz = dist * ng.z;
  const T sx = select(back, -ox, ox), sy = select(back, -oy, oy), sz = select(back, -oz, oz);
  return {nudge(p.x + sx, sx), nudge(p.y + sy, sy), nudge(p.z + sz, sz)};
}

}  // namespace lanes
}  // namespace pt
