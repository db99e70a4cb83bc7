// Subsurface scattering as a BRDF: the far-field approximation of Jensen et al. 2001, "A Practical Model for
// Subsurface Light Transport" (SIGGRAPH), §4 ("BRDF approximation") for a semi-infinite homogeneous medium of
// relative index η = m.ior under a smooth boundary:
//
//   f = f_ss + f_ms,
//   f_ss = α′ F p(cos θ) / (|n·ωi′| + |n·ωo′|)              single scattering (Hanrahan & Krueger 1993), eq. 7
//   f_ms = F_t(η, ωi) R_d F_t(η, ωo) / π                   multiple scattering (dipole diffusion), eq. 8
//   F = F_t(η, ωi) F_t(η, ωo),   F_t(η, ω) = 1 − F_r(cos θ, η) (Fresnel transmittance, fresnel_dielectric)
//   R_d = (α′/2) (1 + e^{−(4/3) A √(3(1−α′))}) e^{−√(3(1−α′))}                           eq. 9 (total diffuse
//   A = (1 + F_dr)/(1 − F_dr),  F_dr = −1.440/η² + 0.710/η + 0.668 + 0.0636 η              reflectance, §2.4)
//
// α′ = m.albedo per channel (the reduced scattering albedo σs′/σt′); R_d per channel is m.rd (prepare_material).
// ωi′, ωo′ are ωi, ωo refracted into the medium; |n·ω′| = sqrt(1 − sin²θ/η²).
//
// Phase-angle convention: p is the Henyey–Greenstein phase function (Henyey & Greenstein 1941)
//   p(cos θ) = (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2}),
// with θ the scattering angle between the propagation directions before and after the scattering event
// (θ = 0 is forward scattering, favoured by g > 0). Light enters along d_in = refract(−ωi) (pointing into the
// medium) and leaves towards the boundary along d_out = −refract(−ωo) (pointing out), so
//   cos θ = d_in · d_out = −(sinθi sinθo cos Δφ)/η² − |n·ωi′| |n·ωo′|.
// At retro-reflection (ωo = ωi) cos θ = −1: pure back-scattering, which forward-scattering media (g > 0) make dim.
// (With both refracted vectors pointing into the medium, as Jensen writes ωi′·ωo′, the HG argument is −ωi′·ωo′.)
// g is clamped to ±0.99 to keep p finite.
//
// With the normalisation below: f = m.ss_norm · (f_ss + f_ms).
//
// Energy normalisation (not in Jensen et al.): the directional albedo of f,
//   E(μo) = F_t(μo) [R_d (1 − F_avg) + α′ S(μo)],   S(μo) = ∫ F_t(μi) p / (|n·ωi′| + |n·ωo′|) cos θi dωi,
// exceeds 1 for non-absorbing media: at α′ = 1 the dipole's R_d = 1 already counts every scattering order and
// f_ss adds the first again. Measured maxima over θo at α′ = 1: 1.05 (η = 1.33, g = 0), 1.09 (η = 1.2, g = 0),
// 1.32 (η = 1.33, g = −0.5), 1.68 (η = 1.33, g = −0.9); forward scattering (g ≥ 0.5) or η ≥ 1.5 with g ≥ 0 stay
// below 1. prepare_material therefore evaluates max over μo of E per channel (S by Gauss–Legendre quadrature,
// energy_tables.h) and stores m.ss_norm = min(1, 1/max E), which multiplies f: channels that conserve energy
// are untouched, the others are scaled to a maximum albedo of exactly 1.
// f is reciprocal. Sampling: cosine-weighted hemisphere. Reflection-only, two-sided: wo.z ≥ 0 on entry
// (bsdf.h mirrors).
#pragma once
#include "core/lanes.h"
#include "core/simd_sqrt_warnings.h"
#include "materials/bsdf_sample.h"
#include "materials/fresnel.h"
#include "sampling/sampling.h"

namespace pt {

PT_SIMD_SQRT_WARNINGS_OFF  // it runs on SIMD lanes too (integrators/lane_lobes.h; every lane computed)
template <class T>
T henyey_greenstein(T cos_theta, T g) {
  g = lanes::std_clamp(g, T(-0.99f), T(0.99f));
  const T denom = T(1.f) + g * g - T(2.f) * g * cos_theta;
  return T(kInv4Pi) * (T(1.f) - g * g) / (denom * lanes::sqrt(denom));
}
PT_SIMD_SQRT_WARNINGS_ON

// Diffuse Fresnel reflectance F_dr (Egan & Hilgeman 1979 fit, Jensen et al. 2001 §2.4).
inline float subsurface_fdr(float eta) { return -1.440f / (eta * eta) + 0.710f / eta + 0.668f + 0.0636f * eta; }

// Total diffuse reflectance R_d of the dipole for reduced albedo α′ (Jensen et al. 2001 eq. 9 integrated over the
// surface, as in their §2.4).
inline float subsurface_rd(float albedo, float eta) {
  const float a = std::clamp(albedo, 0.f, 1.f);
  const float fdr = subsurface_fdr(eta);
  const float A = (1.f + fdr) / (1.f - fdr);
  const float s = std::sqrt(3.f * (1.f - a));
  return 0.5f * a * (1.f + std::exp(-(4.f / 3.f) * A * s)) * std::exp(-s);
}
inline Rgb subsurface_rd(Rgb albedo, float eta) {
  return {subsurface_rd(albedo.x, eta), subsurface_rd(albedo.y, eta), subsurface_rd(albedo.z, eta)};
}

// The BRDF's parameters over the number type: one material's (T = float) or one per SIMD lane
// (integrators/lane_lobes.h).
template <class T>
struct SubsurfaceLobe {
  lanes::Vec3T<T> albedo, rd, norm;  // α′, R_d and ss_norm per channel
  T g, eta;                          // the phase function's asymmetry, the relative index
};
inline SubsurfaceLobe<float> subsurface_lobe(const Material& m) {
  return {lanes::of(m.albedo), lanes::of(m.rd), lanes::of(m.ss_norm), m.g, m.ior};
}

// f for wo.z > 0 and wi.z > 0 (the caller tests the sides), written once over the number type.
PT_SIMD_SQRT_WARNINGS_OFF  // it runs on SIMD lanes too (every lane computed)
template <class T>
[[gnu::always_inline]] inline lanes::Vec3T<T> subsurface_f(const SubsurfaceLobe<T>& b, const lanes::Vec3T<T>& wo,
                                                           const lanes::Vec3T<T>& wi) {
  using lanes::std_clamp, lanes::std_max, lanes::sqrt;
  const T eta = b.eta;
  const T ft_o = T(1.f) - fresnel_dielectric(wo.z, eta), ft_i = T(1.f) - fresnel_dielectric(wi.z, eta);
  const T inv_eta2 = T(1.f) / (eta * eta);
  const T co = sqrt(std_max(T(0.f), T(1.f) - (wo.x * wo.x + wo.y * wo.y) * inv_eta2));  // |n·ωo′| (safe_sqrt)
  const T ci = sqrt(std_max(T(0.f), T(1.f) - (wi.x * wi.x + wi.y * wi.y) * inv_eta2));  // |n·ωi′|
  const T cos_theta = std_clamp(-(wi.x * wo.x + wi.y * wo.y) * inv_eta2 - ci * co, T(-1.f), T(1.f));
  const T t = ft_o * ft_i;
  const T sum = co + ci;
  const T single = select(sum > T(0.f), t * henyey_greenstein(cos_theta, b.g) / sum, T(0.f));
  const T diffuse = t * T(kInvPi);
  return {b.norm.x * (b.albedo.x * single + b.rd.x * diffuse), b.norm.y * (b.albedo.y * single + b.rd.y * diffuse),
          b.norm.z * (b.albedo.z * single + b.rd.z * diffuse)};
}
PT_SIMD_SQRT_WARNINGS_ON

inline Rgb subsurface_eval(const Material& m, Vec3 wo, Vec3 wi) {
  if (!(wo.z > 0.f) || !(wi.z > 0.f)) return Rgb(0.f);
  const lanes::Vec3T<float> f = subsurface_f(subsurface_lobe(m), lanes::of(wo), lanes::of(wi));
  return Rgb(f.x, f.y, f.z);
}

inline float subsurface_pdf(Vec3 wo, Vec3 wi) {
  return wo.z > 0.f && wi.z > 0.f ? cosine_hemisphere_pdf(wi.z) : 0.f;
}

inline bool subsurface_sample(const Material& m, Vec3 wo, Vec2 u, BsdfSample& out) {
  if (!(wo.z > 0.f)) return false;
  const Vec3 wi = sample_cosine_hemisphere(u);
  if (!(wi.z > 0.f)) return false;
  const Rgb f = subsurface_eval(m, wo, wi);
  if (is_black(f)) return false;
  out = {wi, f, cosine_hemisphere_pdf(wi.z), BsdfFlags::Reflection | BsdfFlags::Diffuse, 1.f};
  return true;
}

}  // namespace pt
