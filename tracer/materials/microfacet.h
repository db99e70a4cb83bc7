// Trowbridge–Reitz (GGX) microfacet distribution, isotropic, with the Smith masking function and visible-normal
// sampling. Local frame: z is the macro-surface normal; directions are unit vectors pointing away from the surface.
//
// Sources:
// - D and Λ: Walter et al. 2007, "Microfacet Models for Refraction through Rough Surfaces" (EGSR), eq. 33 and
//   the Smith Λ of Heitz 2014, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs" (JCGT
//   3(2)), eq. 72; pbrt-v4 §9.6 (TrowbridgeReitzDistribution) writes the same.
// - Height-correlated masking-shadowing G2 = 1/(1 + Λ(wo) + Λ(wi)) (Heitz 2014 eq. 99).
// - Visible normals D_wo(wm) = G1(wo)·max(0, wo·wm)·D(wm)/|wo.z| (Heitz 2014 eq. 38) and their sampling:
//   Heitz 2018, "Sampling the GGX Distribution of Visible Normals" (JCGT 7(4)), listing 1.
//
// The formulas are templates over the float type T (Mitsuba 3 style; see fresnel.h for what T must provide).
// Arguments are vector components so that T can be a SIMD lane type. Stable combined forms are provided for
// what the lobes actually evaluate: G1/|cos θ| and G2/(4|cos θo cos θi|) have finite limits at grazing angles
// where Λ → ∞, and are written so that no 0·∞ or ∞/∞ arises.
//
// Smooth threshold: α < kSmoothAlpha is "effectively smooth" and handled as a delta (specular) lobe, as pbrt-v4
// does (TrowbridgeReitzDistribution::EffectivelySmooth: max(αx, αy) < 1e-3). With α = roughness², that is
// roughness < ~0.0316. At α = 1e-3, D peaks at 1/(πα²) ≈ 3.2e5, well inside float range.
#pragma once
#include "core/math.h"
#include "core/simd_sqrt_warnings.h"
#include "materials/fresnel.h"

namespace pt {

inline constexpr float kSmoothAlpha = 1e-3f;
inline bool effectively_smooth(float alpha) { return alpha < kSmoothAlpha; }

PT_SIMD_SQRT_WARNINGS_OFF  // the templates below run on SIMD lanes too (every lane computed)
// GGX normal distribution D(wm) for a microfacet normal with components (x, y, z); 0 below the surface.
// D = 1/(π α² cos⁴θm (1 + tan²θm/α²)²) = 1/(π α² (sin²θm/α² + cos²θm)²): sin² from x² + y² keeps precision
// near the pole where 1 − z² would cancel.
template <class T>
T ggx_d(T x, T y, T z, T alpha) {
  const T a2 = alpha * alpha;
  const T t = (x * x + y * y) / a2 + z * z;
  return select(z > T(0), T(1) / (T(kPi) * a2 * t * t), T(0));
}

// Stable building block r = sqrt(cos²θ + α² sin²θ) = |cos θ|·(1 + 2Λ).
template <class T>
T ggx_smith_r(T cos_abs, T sin2, T alpha) {
  using std::sqrt;
  return sqrt(cos_abs * cos_abs + alpha * alpha * sin2);
}

// Smith Λ(w) = (−1 + sqrt(1 + α² tan²θ))/2 for the direction (x, y, z). +∞ at z = 0.
template <class T>
T ggx_lambda(T x, T y, T z, T alpha) {
  using std::abs;
  using std::sqrt;
  const T tan2 = (x * x + y * y) / (z * z);
  return T(0.5) * (sqrt(T(1) + alpha * alpha * tan2) - T(1));
}

// Smith masking G1(w) = 1/(1 + Λ(w)) = 2|cos|/(|cos| + r).
template <class T>
T ggx_g1(T x, T y, T z, T alpha) {
  using std::abs;
  const T c = abs(z);
  return T(2) * c / (c + ggx_smith_r(c, x * x + y * y, alpha));
}

// G1(w)/|cos θ| = 2/(|cos θ| + r): finite (2/(α sin θ)) at grazing.
template <class T>
T ggx_g1_over_cos(T x, T y, T z, T alpha) {
  using std::abs;
  const T c = abs(z);
  return T(2) / (c + ggx_smith_r(c, x * x + y * y, alpha));
}

// Height-correlated masking-shadowing G2(wo, wi) = 1/(1 + Λ(wo) + Λ(wi)) = 2|co ci|/(|ci| ro + |co| ri).
template <class T>
T ggx_g2(T ox, T oy, T oz, T ix, T iy, T iz, T alpha) {
  using std::abs;
  const T co = abs(oz), ci = abs(iz);
  const T ro = ggx_smith_r(co, ox * ox + oy * oy, alpha), ri = ggx_smith_r(ci, ix * ix + iy * iy, alpha);
  return T(2) * co * ci / (ci * ro + co * ri);
}

// G2/(|cos θo|·|cos θi|) = 2/(|ci| ro + |co| ri): the "visibility" factor of the microfacet BRDF times 4.
// 0/0 only when both directions graze; the caller rejects cos = 0.
template <class T>
T ggx_g2_over_cos2(T ox, T oy, T oz, T ix, T iy, T iz, T alpha) {
  using std::abs;
  const T co = abs(oz), ci = abs(iz);
  const T ro = ggx_smith_r(co, ox * ox + oy * oy, alpha), ri = ggx_smith_r(ci, ix * ix + iy * iy, alpha);
  return T(2) / (ci * ro + co * ri);
}

// The half vector wm = normalize(wo + wi) and D(wm), where `valid` and wo + wi ≠ 0 (`ok`); elsewhere wm = +z and
// D = 0. As glm::normalize computes it: h · (1/√(h·h)).
template <class T>
struct HalfVectorD {
  lanes::Vec3T<T> wm;
  T d;
  lanes::Mask<T> ok;
};
template <class T>
[[gnu::always_inline]] inline HalfVectorD<T> half_vector_d(const lanes::Vec3T<T>& wo, const lanes::Vec3T<T>& wi,
                                                           const T& alpha, const lanes::Mask<T>& valid) {
  const lanes::Vec3T<T> h{wo.x + wi.x, wo.y + wi.y, wo.z + wi.z};
  const T h2 = lanes::dot(h, h);
  const lanes::Mask<T> ok = valid && h2 > 0.f;
  const T inv = 1.f / lanes::sqrt(h2);
  const lanes::Vec3T<T> wm{select(ok, h.x * inv, T(0.f)), select(ok, h.y * inv, T(0.f)), select(ok, h.z * inv, T(1.f))};
  return {wm, select(ok, ggx_d(wm.x, wm.y, wm.z, alpha), T(0.f)), ok};
}

PT_SIMD_SQRT_WARNINGS_ON

// Vector conveniences for the scalar lobes.
inline float ggx_d(Vec3 wm, float alpha) { return ggx_d(wm.x, wm.y, wm.z, alpha); }
inline float ggx_lambda(Vec3 w, float alpha) { return ggx_lambda(w.x, w.y, w.z, alpha); }
inline float ggx_g1(Vec3 w, float alpha) { return ggx_g1(w.x, w.y, w.z, alpha); }
inline float ggx_g2(Vec3 wo, Vec3 wi, float alpha) { return ggx_g2(wo.x, wo.y, wo.z, wi.x, wi.y, wi.z, alpha); }
inline float ggx_g2_over_cos2(Vec3 wo, Vec3 wi, float alpha) {
  return ggx_g2_over_cos2(wo.x, wo.y, wo.z, wi.x, wi.y, wi.z, alpha);
}

// Density of visible normals D_wo(wm) = G1(wo)·max(0, wo·wm)·D(wm)/|wo.z| (per steradian of wm). Requires
// wo.z ≠ 0 or α > 0 (finite either way).
// `d` = ggx_d(wm, alpha), which the caller may have.
inline float ggx_vndf_pdf(Vec3 wo, Vec3 wm, float d, float alpha) {
  return ggx_g1_over_cos(wo.x, wo.y, wo.z, alpha) * std::max(0.f, glm::dot(wo, wm)) * d;
}
inline float ggx_vndf_pdf(Vec3 wo, Vec3 wm, float alpha) { return ggx_vndf_pdf(wo, wm, ggx_d(wm, alpha), alpha); }

// Samples a visible normal wm ~ D_wo (Heitz 2018, listing 1, isotropic α). wo must be in the upper hemisphere
// (wo.z ≥ 0); the caller mirrors directions from below. The result has wm.z ≥ 0 and wo·wm ≥ 0.
inline Vec3 ggx_sample_vndf(Vec3 wo, float alpha, Vec2 u) {
  // Stretch to the hemisphere configuration (α = 1).
  const Vec3 vh = glm::normalize(Vec3(alpha * wo.x, alpha * wo.y, wo.z));
  // Orthonormal basis around vh (T1 is perpendicular to the plane of incidence).
  const float lensq = vh.x * vh.x + vh.y * vh.y;
  const Vec3 t1 = lensq > 0.f ? Vec3(-vh.y, vh.x, 0.f) / std::sqrt(lensq) : Vec3(1.f, 0.f, 0.f);
  const Vec3 t2 = glm::cross(vh, t1);
  // Uniform point on the disk, then warped onto the projected visible half-disk.
  const float r = std::sqrt(u.x), phi = 2.f * kPi * u.y;
  const float p1 = r * std::cos(phi);
  float p2 = r * std::sin(phi);
  const float s = 0.5f * (1.f + vh.z);
  p2 = (1.f - s) * safe_sqrt(1.f - p1 * p1) + s * p2;
  // Reproject onto the hemisphere and unstretch.
  const Vec3 nh = p1 * t1 + p2 * t2 + safe_sqrt(1.f - p1 * p1 - p2 * p2) * vh;
  return glm::normalize(Vec3(alpha * nh.x, alpha * nh.y, std::max(0.f, nh.z)));
}

// Solid-angle density of wi = reflect(−wo, wm) when wm ~ D_wo: D_wo(wm)/(4 wo·wm) = G1(wo) D(wm)/(4 |wo.z|)
// (the Jacobian of the half-vector map, Walter et al. 2007 eq. 14). wm must be the half vector of wo, wi.
// `d` = ggx_d(wm, alpha), which the caller has.
inline float ggx_reflection_pdf(Vec3 wo, Vec3 wm, float d, float alpha) {
  return glm::dot(wo, wm) > 0.f ? 0.25f * ggx_g1_over_cos(wo.x, wo.y, wo.z, alpha) * d : 0.f;
}
inline float ggx_reflection_pdf(Vec3 wo, Vec3 wm, float alpha) { return ggx_reflection_pdf(wo, wm, ggx_d(wm, alpha), alpha); }

}  // namespace pt
