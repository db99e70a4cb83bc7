// Uniform solid-angle sampling of a rectangle seen from a point, after C. Ureña, M. Fajardo, A. King,
// "An Area-Preserving Parametrization for Spherical Rectangles", Computer Graphics Forum 32(4) (EGSR 2013).
// The paper's code listing has two routines, SphQuadInit (precomputation) and SphQuadSample (steps 1–4:
// "compute cu", "compute xu", "compute yv", "transform (xu, yv, z0) to world coords"); the comments
// [Init …] and [Sample n] below point at them.
//
// Deviations from the listing, all for precision (the listing is float and loses everything for small solid
// angles: S = γ0+γ1+γ2+γ3 − 2π cancels, and au = u·S + k carries k's rounding, about 1e-7·π, into a
// range of width S):
//  * the edge normals n0..n3 are written in closed form in the local frame R, and each interior angle
//    γi = acos(−ni·ni+1) is evaluated as atan2(|ni × ni+1|, −ni·ni+1) (no acos near ±1);
//  * k and γ0 + γ1 are kept as offsets from π (T0 = k − π, T1 = γ0 + γ1 − π, both sums of atans that are
//    small when the rectangle is small), so au = π + t with t = u·S + T0, and cos au, sin au become −cos t,
//    −sin t;
//  * step 1's fu = (cos au·b0 − b1)/sin au and cu = sign(fu)/√(fu² + b0²) are combined into one expression
//    without the division by sin au;
//  * step 4 is written relative to the corner s instead of o, so the point lies on the rectangle's plane to
//    the rounding of s (o + xu·x + yv·y + z0·z = s + (xu − x0)·x + (yv − y0)·y).
// The scalar entry points compute in double. T0, T1 and S = T1 − T0 are sums and differences of corner terms
// atan(x·y/(h·|v|)) of magnitude ≤ π/2, so S and the sample positions carry a relative error of up to about
// 1e-16·(π/2)/S when o is far off-axis (measured: 2e-9 at S = 1e-9 sr, 7e-7 at S = 1e-12 sr; on-axis stays
// ~1e-16). That is ample down to S ≈ 1e-10 sr; for smaller lights (a 1 mm light 100 m away) area sampling,
// whose pdf conversion is exact there anyway, is the better choice. T = float is good for S ≳ 1e-2 only.
//
// The rectangle is visible from both sides (the listing flips z so that z0 ≤ 0; here h = |z0|);
// one-sided emitters must test the facing themselves. S = 0 means "no sample": o on the rectangle's plane
// (to within 8ε·|s − o| of it), a degenerate edge, or anything non-finite.
//
// The math is templated over the scalar type T (float or double) and written as straight-line code on a plain
// struct (no branches in sampling besides clamps), so it can later be instantiated for SIMD lane types that
// provide sqrt/sin/cos/atan2/copysign/min/max.
#pragma once
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/math.h"

namespace pt {

template <class T>
struct SphericalRectT {
  using V3 = glm::vec<3, T, glm::defaultp>;
  V3 s{0};                // corner of the rectangle
  V3 x{0}, y{0};          // unit edge directions: the x and y axes of the paper's local frame R
  T x0 = 0, y0 = 0;       // rectangle [x0, x1] × [y0, y1] in R (origin o)
  T x1 = 0, y1 = 0;
  T h = 0;                // distance from o to the rectangle's plane (the listing's −z0 after its flip)
  T b0 = 0, b1 = 0;       // the listing's b0 = n0.z, b1 = n2.z
  T t0 = 0;               // k − π, with the listing's k = 2π − γ2 − γ3
  T solid_angle = 0;      // S in steradians; 0 = no sample
};

// [Init] SphQuadInit: o the reference point, s a corner, ex and ey the two perpendicular edges from s.
template <class T>
SphericalRectT<T> make_spherical_rect_t(typename SphericalRectT<T>::V3 o, typename SphericalRectT<T>::V3 s,
                                        typename SphericalRectT<T>::V3 ex, typename SphericalRectT<T>::V3 ey) {
  using std::abs, std::atan2, std::isfinite, std::sqrt;
  SphericalRectT<T> r;
  r.s = s;
  // [Init: local reference system R] exl, eyl, x = ex/exl, y = ey/eyl, z = x × y. y is re-orthogonalised
  // against x (Gram–Schmidt) so that rounding in nearly perpendicular inputs cannot tilt the frame.
  const T exl = glm::length(ex), eyl = glm::length(ey);
  if (!(exl > T(0)) || !(eyl > T(0)) || !isfinite(exl) || !isfinite(eyl)) return r;
  r.x = ex / exl;
  const auto yo = ey - glm::dot(ey, r.x) * r.x;
  const T yol = glm::length(yo);
  if (!(yol > T(0))) return r;
  r.y = yo / yol;
  const auto z = glm::cross(r.x, r.y);
  // [Init: rectangle coords in R] d = s − o; z0 = d·z, flipped to z0 ≤ 0 ("make z point against Q"): h = |z0|.
  const auto d = s - o;
  r.h = abs(glm::dot(d, z));
  r.x0 = glm::dot(d, r.x);
  r.y0 = glm::dot(d, r.y);
  r.x1 = r.x0 + exl;
  r.y1 = r.y0 + eyl;
  const T h = r.h, x0 = r.x0, y0 = r.y0, x1 = r.x1, y1 = r.y1, hh = h * h;
  // [Init: vectors to the four vertices] vij = (xi, yj, z0); |vij| below.
  const T l00 = sqrt(x0 * x0 + y0 * y0 + hh), l01 = sqrt(x0 * x0 + y1 * y1 + hh);
  const T l10 = sqrt(x1 * x1 + y0 * y0 + hh), l11 = sqrt(x1 * x1 + y1 * y1 + hh);
  // [Init: normals to edges] n0 ∝ v00×v10 ∝ (0, z0, −y0), n1 ∝ v10×v11 ∝ (−z0, 0, x1),
  // n2 ∝ v11×v01 ∝ (0, −z0, y1), n3 ∝ v01×v00 ∝ (z0, 0, −x0).
  // [Init: internal angles] γi = acos(−ni·ni+1) = atan2(|ni × ni+1|, −ni·ni+1), which in closed form is
  //   γ0 = atan2(h·|v10|, x1·y0), γ1 = atan2(h·|v11|, −x1·y1), γ2 = atan2(h·|v01|, x0·y1), γ3 = atan2(h·|v00|, −x0·y0),
  // and π/2 − atan2(a, b) = atan2(b, a) for a > 0 turns the listing's k and γ0 + γ1 into offsets from π:
  //   T0 = k − π = (π/2 − γ2) + (π/2 − γ3),   T1 = γ0 + γ1 − π = (γ0 − π/2) + (γ1 − π/2).
  const T t0 = atan2(x0 * y1, h * l01) - atan2(x0 * y0, h * l00);
  const T t1 = atan2(x1 * y1, h * l11) - atan2(x1 * y0, h * l10);
  // [Init: predefined constants] b0 = n0.z, b1 = n2.z.
  r.b0 = -y0 / sqrt(y0 * y0 + hh);
  r.b1 = y1 / sqrt(y1 * y1 + hh);
  r.t0 = t0;
  // [Init: solid angle] S = γ0 + γ1 − k = T1 − T0.
  const T S = t1 - t0;
  // o on the plane (h = 0) would make the formulas return 2π (inside) or 0 (outside): report "no sample",
  // also when h is within the rounding noise of d·z (about ε·|d|), where the side of the plane is undefined.
  const T noise = T(8) * std::numeric_limits<T>::epsilon() * glm::length(d);
  const bool ok = h > noise && S > T(0) && isfinite(S) && isfinite(r.b0) && isfinite(r.b1);
  r.solid_angle = ok ? S : T(0);
  if (!ok) r.b0 = r.b1 = r.t0 = T(0);  // keeps sample_t() finite (it then returns a point of the rectangle)
  return r;
}

// [Sample] SphQuadSample: the point on the rectangle for u, v in [0, 1], uniform in solid angle seen from o
// (pdf 1/S). Meaningless, but finite, when solid_angle == 0.
template <class T>
typename SphericalRectT<T>::V3 sample_t(const SphericalRectT<T>& r, T u, T v) {
  using std::clamp, std::copysign, std::cos, std::max, std::sin, std::sqrt;
  const T tiny = std::numeric_limits<T>::min();
  // [Sample 1] au = u·S + k; fu = (cos au·b0 − b1)/sin au; cu = sign(fu)/√(fu² + b0²); clamp cu to [−1, 1].
  // Here au = π + t: fu = q/sin t with q = b0·cos t + b1, hence cu = sign(q)·sin t/√(q² + b0²·sin² t).
  const T t = u * r.solid_angle + r.t0;
  const T st = sin(t), q = r.b0 * cos(t) + r.b1;
  T cu = copysign(T(1), q) * st / max(sqrt(q * q + r.b0 * r.b0 * st * st), tiny);
  cu = clamp(cu, T(-1), T(1));  // avoid NaNs
  // [Sample 2] xu = −cu·z0/√(1 − cu²) = cu·h/√(1 − cu²), clamped to [x0, x1] (avoids infs).
  T xu = cu * r.h / sqrt(max((T(1) - cu) * (T(1) + cu), tiny));
  xu = clamp(xu, r.x0, r.x1);
  // [Sample 3] d = √(xu² + z0²); h0 = y0/√(d² + y0²), h1 = y1/√(d² + y1²); hv = h0 + v·(h1 − h0);
  // yv = hv·d/√(1 − hv²). The listing's "hv² < 1 − ε ? … : y1" is replaced by a floored denominator and
  // a clamp to [y0, y1], which gives y1 (or y0) in the same limit.
  const T dd = xu * xu + r.h * r.h;
  const T h0 = r.y0 / max(sqrt(dd + r.y0 * r.y0), tiny), h1 = r.y1 / max(sqrt(dd + r.y1 * r.y1), tiny);
  const T hv = h0 + v * (h1 - h0);
  T yv = hv * sqrt(dd) / sqrt(max((T(1) - hv) * (T(1) + hv), tiny));
  yv = clamp(yv, r.y0, r.y1);
  // [Sample 4] o + xu·x + yv·y + z0·z, written from the corner: s + (xu − x0)·x + (yv − y0)·y.
  return r.s + (xu - r.x0) * r.x + (yv - r.y0) * r.y;
}

// Scalar API: float camera-relative inputs, double internally.
using SphericalRect = SphericalRectT<double>;

inline SphericalRect make_spherical_rect(Vec3 o, Vec3 s, Vec3 ex, Vec3 ey) {
  return make_spherical_rect_t<double>(DVec3(o), DVec3(s), DVec3(ex), DVec3(ey));
}

// Point on the rectangle for u in [0, 1]²; check spherical_rect_pdf(r) > 0 first ("no sample" otherwise).
inline Vec3 sample(const SphericalRect& r, Vec2 u) {
  return Vec3(sample_t<double>(r, static_cast<double>(u.x), static_cast<double>(u.y)));
}

// Solid-angle density of sample(): 1/S, or 0 when there is no sample. (Overflows to +inf in float only for
// S < 3e-39 sr, far below the range where this sampler should be used; see the header comment.)
inline float spherical_rect_pdf(const SphericalRect& r) {
  return r.solid_angle > 0.0 ? static_cast<float>(1.0 / r.solid_angle) : 0.f;
}

}  // namespace pt
